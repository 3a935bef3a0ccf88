"""The human's motion scaled onto the robot: per frame, each hand's target position and
orientation, each elbow's wanted direction and the gaze point.

Per arm and frame ``f`` (human points in the clip's world, metres and Z up):

- the heading map ``M_f = H_robot H_human,f^T``: the human's forward/left/up frame
  (``HumanSide.heading``) onto the robot's (``Profile.forward``), a turn about z;
- the hand position ``p_f = S_robot + s M_f (h_f - S_f)``: the hand point ``h`` relative
  to the human shoulder ``S`` (the upper arm's joint), scaled by ``s = k robot reach /
  human arm length`` (``k``: :data:`REACH`; the human arm: upper arm + forearm + hand
  point, at rest), placed at the robot's shoulder point;
- the hand orientation ``R_f = M_f W_f C``: the human wrist's world rotation ``W_f``
  carried over with a fixed offset ``C`` per arm, chosen on the first frame: ``C =
  (M_0 W_0)^T R_0``, where ``R_0`` is the robot end frame's rotation after the first
  frame's position and elbow are reached with the wrist joints at home
  (:func:`rest_offset`). So the first frame's hand orientation is the robot's own
  neutral wrist there, and every later frame turns the hand as the human's turned from
  its first frame. (The T-pose would pair a human arm held out with a robot arm at its
  home pose, often hanging down: not a common rest.)
- the elbow direction ``d_f``: the human elbow's offset from its shoulder-wrist line, a
  unit vector (through ``M_f``); with the bend, the elbow's distance from that line
  over the upper arm's length (``sin`` of the angle between upper arm and the line):
  below :data:`STRAIGHT` the elbow's direction is not defined (a straight arm);
- the gaze point: the robot's gaze frame (at home) plus :data:`GAZE_DISTANCE` along the
  human head's forward direction (the head joint's world rotation applied to the
  rest pose's forward, through ``M_f``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.experiments.retarget.human import HumanSide
from humanoid_ik.experiments.retarget.robot import RobotSide
from humanoid_ik.motion.bvh import BVHClip

__all__ = [
    "BENT",
    "GAZE_DISTANCE",
    "REACH",
    "STRAIGHT",
    "ArmTargets",
    "Targets",
    "rest_offset",
    "scaled_targets",
]

GAZE_DISTANCE = 2.0
"""How far ahead of the robot's gaze frame the gaze point is put [m]."""
STRAIGHT = 0.1
"""An elbow closer to its shoulder-wrist line than this fraction of the upper arm (an
arm within about 6 degrees of straight) has no direction to match: the solve does not
pull it; the pull grows to full at :data:`BENT`."""
BENT = 2 * STRAIGHT
"""From this bend on the elbow's direction is matched in full, and measured."""
REACH = 0.95
"""The fraction of the robot's full-stretch length the human's full arm length maps
onto. 1 is the plain ratio of arm lengths: a human arm held straight is then a robot arm at
full stretch, singular (the hand cannot move along the arm, and no elbow swivel is left
to steer the shoulder off its gimbal lock). 0.95 keeps the robot arm bent by about 36
degrees at the elbow of an arm of two equal links when the human's is straight: every
target lies 5 % nearer the shoulder than the plain ratio puts it (``docs/retarget.md``
has both measured)."""


@dataclass
class ArmTargets:
    """One arm's targets over ``F`` frames (world, robot side).

    Attributes:
        position: hand positions ``(F, 3)`` [m].
        human_rotation: ``M_f W_f`` ``(F, 3, 3)``, the human wrist's rotation mapped
            (the target is this times :attr:`offset`).
        offset: ``C (3, 3)`` (identity until :func:`rest_offset` sets it).
        elbow: the wanted elbow direction ``(F, 3)`` (unit).
        bend: the human elbow's distance from its shoulder-wrist line over the upper
            arm's length ``(F,)``.
        scale: robot reach over human arm length.
        human_position: the human hand point, relative to its shoulder, mapped and
            scaled ``(F, 3)`` (the source of the jerk comparison).
    """

    position: NDArray[np.float64]
    human_rotation: NDArray[np.float64]
    offset: NDArray[np.float64]
    elbow: NDArray[np.float64]
    bend: NDArray[np.float64]
    scale: float
    human_position: NDArray[np.float64]

    def rotation(self, f: int) -> NDArray[np.float64]:
        """The target rotation of frame ``f`` ``(3, 3)``."""
        return self.human_rotation[f] @ self.offset


@dataclass
class Targets:
    """Every frame's targets: per arm (``left``/``right``), the gaze point (``None``
    without a head) and the human gaze direction (mapped) ``(F, 3)``."""

    arms: dict[str, ArmTargets]
    gaze: NDArray[np.float64] | None
    gaze_direction: NDArray[np.float64] | None
    frames: int


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def scaled_targets(
    clip: BVHClip,
    human: HumanSide,
    robot: RobotSide,
    frames: int | None = None,
    reach: float = REACH,
) -> Targets:
    """The targets of the first ``frames`` frames (all by default) of ``clip``, the
    human's full arm length mapped onto ``reach`` times the robot's (:data:`REACH`)."""
    F = clip.n_frames if frames is None else min(frames, clip.n_frames)
    pos, rot = clip.positions[:F], clip.rotations[:F]
    Hh = human.heading(pos)
    M = robot.heading[None] @ np.transpose(Hh, (0, 2, 1))  # (F, 3, 3)
    arms: dict[str, ArmTargets] = {}
    for side, arm in robot.arms.items():
        h = human.arms.get(side)
        if h is None:
            continue
        S, E, W = pos[:, h.shoulder], pos[:, h.elbow], pos[:, h.wrist]
        hand = h.hand_point(pos)
        s = reach * arm.length / h.length
        rel = np.einsum("fij,fj->fi", M, hand - S) * s
        line = _unit(W - S)
        up = E - S
        perp = up - np.sum(up * line, axis=1, keepdims=True) * line
        bend = np.linalg.norm(perp, axis=1) / np.maximum(np.linalg.norm(up, axis=1), 1e-12)
        elbow = np.einsum("fij,fj->fi", M, _unit(perp))
        arms[side] = ArmTargets(
            position=arm.shoulder[None] + rel,
            human_rotation=M @ rot[:, h.wrist],
            offset=np.eye(3),
            elbow=elbow,
            bend=bend,
            scale=s,
            human_position=rel,
        )
    gaze = direction = None
    if robot.head is not None and human.head is not None:
        rest_fwd = human.heading(clip.rest()[None])[0][:, 0]
        direction = np.einsum("fij,fj->fi", M, rot[:, human.head] @ rest_fwd)
        gaze = robot.gaze_origin()[None] + GAZE_DISTANCE * direction
    return Targets(arms, gaze, direction, F)


def rest_offset(targets: ArmTargets, end_rotation: NDArray[np.float64]) -> None:
    """Set the arm's offset ``C`` so that frame 0's target rotation is
    ``end_rotation`` (the robot end frame's at its first-frame position solve)."""
    targets.offset = targets.human_rotation[0].T @ end_rotation
