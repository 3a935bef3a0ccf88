"""The robot side of a retarget: its arms and head as chains over one state, their
geometry (shoulder, elbow, wrist, reach), the joint speed limits and the self-collision
pairs.

- **Arms**: ``left_arm`` and ``right_arm`` of the limb profile (``core/limbs.py``),
  without the torso. An arm's elbow joint, *shoulder point* and *wrist point* are the
  solvers' (:mod:`humanoid_ik.solvers.analytic.elbow`, the one definition an elbow pole
  is honoured by: :func:`~humanoid_ik.solvers.analytic.elbow.arm_points`); the shoulder
  point is taken at home (fixed: no torso moves). Its length is its length at full
  stretch: the largest distance from the shoulder point to the end frame over the
  elbow's range, the other joints at home.
- **Head**: the ``head`` limb's chain and gaze axis when it has joints; a fixed head
  (G1) is no effector.
- **Speed limits**: a URDF's ``<limit velocity>`` per joint (MuJoCo's URDF compiler does
  not keep it: the file is read here); a joint without one, and every joint of an MJCF
  model (MuJoCo has no joint speed limit), gets :data:`DEFAULT_SPEED`.
- **Self-collision**: the pairs of ``collision_pairs = "limbs"``
  (:func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`: each forearm and hand
  against the torso and head, hand against hand), expanded to geom id pairs;
  :meth:`RobotSide.collisions` counts those in contact (``mj_geomDistance`` < 0) after
  a bounding-sphere test.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.limbs import Profile, limb_chain
from humanoid_ik.core.models import home_qpos
from humanoid_ik.core.robot import Robot
from humanoid_ik.errors import RetargetError
from humanoid_ik.experiments.retarget.human import SIDES
from humanoid_ik.solvers.analytic.elbow import arm_points, elbow_frame
from humanoid_ik.solvers.mink.pairs import limb_collision_pairs

__all__ = ["DEFAULT_SPEED", "RobotArm", "RobotSide", "urdf_speeds"]

DEFAULT_SPEED = 2.0 * math.pi
"""The speed limit [rad/s] of a joint whose model gives none: one turn per second (a
fast human arm joint; G1's arm motors allow 22-37 rad/s, Talos's 1.8-4.6 rad/s)."""


def urdf_speeds(path: str | os.PathLike[str] | None) -> dict[str, float]:
    """The ``<limit velocity>`` of every joint of the URDF ``path`` [rad/s] (empty for an
    MJCF, a xacro file or a file that cannot be parsed)."""
    if path is None or not str(path).lower().endswith(".urdf"):
        return {}
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return {}
    out: dict[str, float] = {}
    for j in root.iter("joint"):
        lim = j.find("limit")
        name = j.get("name")
        if name and lim is not None and lim.get("velocity") is not None and name not in out:
            try:
                v = float(lim.get("velocity", ""))
            except ValueError:
                continue
            if math.isfinite(v) and v > 0:
                out[name] = v
    return out


@dataclass
class RobotArm:
    """One robot arm: its chain and the geometry a retarget uses.

    Attributes:
        side: ``left`` or ``right``.
        chain: the arm's chain (shoulder to the end frame).
        elbow: the elbow joint's index in the chain (the solvers' ``elbow_frame``).
        shoulder: the shoulder point at home ``(3,)`` [m] (world; fixed: no torso moves).
        wrist_offset: the wrist point in the end frame ``(3,)`` [m].
        length: the arm's length at full stretch [m]: the largest distance from the
            shoulder point to the end frame over the elbow's range, the other joints at
            home.
        pose: the arm can reach a pose (6 joints or more).
        speed: each joint's speed limit ``(n,)`` [rad/s].
    """

    side: str
    chain: Chain
    elbow: int
    shoulder: NDArray[np.float64]
    wrist_offset: NDArray[np.float64]
    length: float
    pose: bool
    speed: NDArray[np.float64]


def _stretch(chain: Chain, elbow: int, shoulder: NDArray[np.float64]) -> float:
    """The arm's length at full stretch: the largest distance from the shoulder point to
    the end frame over the elbow's range, the other joints at home (the chain is put
    back at home)."""
    home = chain.clip(chain.q_home)
    lo, hi = chain.lower[elbow], chain.upper[elbow]
    lo, hi = (lo, hi) if math.isfinite(lo) and math.isfinite(hi) else (-math.pi, math.pi)
    best = 0.0
    for a in np.linspace(lo, hi, 181):
        q = home.copy()
        q[elbow] = a
        chain.set_q(q)
        best = max(best, float(np.linalg.norm(chain.position - shoulder)))
    chain.set_q(home)
    return best


class RobotSide:
    """The robot's arms, head, speed limits and collision pairs over one :class:`Robot`.

    Args:
        model: the compiled model.
        profile: its limbs.
        model_path: the model file (a URDF's speed limits are read from it).

    Raises:
        RetargetError: the robot has no left or right arm.
    """

    def __init__(
        self, model: mujoco.MjModel, profile: Profile, model_path: str | os.PathLike[str] | None
    ):
        self.model = model
        self.profile = profile
        self.robot = Robot(model)
        self.robot.data.qpos[:] = home_qpos(model)
        mujoco.mj_kinematics(model, self.robot.data)
        speeds = urdf_speeds(model_path)
        self.speed_source = "URDF <limit velocity>" if speeds else "default"
        f = np.asarray(profile.forward, dtype=np.float64)
        f = f / np.linalg.norm(f)
        self.heading = np.stack([f, np.cross([0.0, 0.0, 1.0], f), [0.0, 0.0, 1.0]], axis=1)
        """The robot's forward, left, up (columns)."""
        self.arms: dict[str, RobotArm] = {}
        for side in SIDES:
            name = f"{side}_arm"
            if name not in profile.limbs or not profile.limbs[name].joints:
                continue
            c = limb_chain(self.robot, name, profile=profile)
            frame = elbow_frame(c)
            k, off = frame.elbow, frame.wrist_local
            shoulder = arm_points(c, c.clip(c.q_home)).shoulder
            reach = _stretch(c, k, shoulder)
            sp = np.array([speeds.get(n, DEFAULT_SPEED) for n in c.joint_names])
            self.arms[side] = RobotArm(side, c, k, shoulder, off, reach, c.n >= 6, sp)
        if not self.arms:
            have = ", ".join(profile.limbs) or "(none)"
            raise RetargetError(
                f"the robot has no left_arm or right_arm to retarget onto; limbs found: {have} "
                "(name them in a limb profile: docs/limbs.md)"
            )
        self.head: Chain | None = None
        self.gaze_axis = np.array([1.0, 0.0, 0.0])
        self.head_speed = np.zeros(0)
        head = profile.limbs.get("head")
        if head is not None and head.joints and head.frame:
            self.head = limb_chain(self.robot, "head", profile=profile)
            self.head.set_q(self.head.clip(self.head.q_home))
            if head.axis is not None:
                self.gaze_axis = np.asarray(head.axis, dtype=np.float64)
            self.head_speed = np.array(
                [speeds.get(n, DEFAULT_SPEED) for n in self.head.joint_names]
            )
        self._pairs(profile)

    @property
    def chains(self) -> list[Chain]:
        """The arms' chains, then the head's."""
        out = [a.chain for a in self.arms.values()]
        return out + ([self.head] if self.head is not None else [])

    def gaze_origin(self) -> NDArray[np.float64]:
        """Where the gaze frame is at the current kinematics ``(3,)``."""
        assert self.head is not None
        return self.head.position.copy()

    # ---------------------------------------------------------------- collisions
    def _pairs(self, profile: Profile) -> None:
        m = self.model
        self.limb_pairs = limb_collision_pairs(m, profile)
        ids: set[tuple[int, int]] = set()

        def gid(g: str | int) -> int:
            return g if isinstance(g, int) else int(m.geom(g).id)

        for a, b in self.limb_pairs:
            for ga in a:
                for gb in b:
                    i, j = sorted((gid(ga), gid(gb)))
                    if i != j and m.geom_bodyid[i] != m.geom_bodyid[j]:
                        ids.add((i, j))
        pairs = np.array(sorted(ids), dtype=np.int64).reshape(-1, 2)
        self.geom_pairs = pairs
        """The geom id pairs checked per frame ``(P, 2)``."""
        self._radius = m.geom_rbound[pairs[:, 0]] + m.geom_rbound[pairs[:, 1]]
        self._fromto = np.zeros(6)

    def collisions(self, data: mujoco.MjData, margin: float = 0.0) -> int:
        """How many of :attr:`geom_pairs` are closer than ``margin`` [m] (in contact for
        0) at ``data``'s kinematics (``mj_kinematics`` current)."""
        p = self.geom_pairs
        if not len(p):
            return 0
        gap = np.linalg.norm(data.geom_xpos[p[:, 0]] - data.geom_xpos[p[:, 1]], axis=1)
        near = np.flatnonzero(gap - self._radius < margin)
        count = 0
        for k in near.tolist():
            i, j = int(p[k, 0]), int(p[k, 1])
            d = mujoco.mj_geomDistance(self.model, data, i, j, margin + 0.05, self._fromto)
            count += d < margin
        return count

    def describe(self) -> dict[str, object]:
        """What was found, for ``metrics.json``."""
        return {
            "arms": {
                s: {
                    "joints": list(a.chain.joint_names),
                    "end": a.chain.ee_name,
                    "elbow": a.chain.joint_names[a.elbow],
                    "reach_m": a.length,
                    "pose": a.pose,
                    "speed_limit_rad_s": a.speed.tolist(),
                }
                for s, a in self.arms.items()
            },
            "head": None if self.head is None else list(self.head.joint_names),
            "speed_limits": self.speed_source,
            "collision_pairs": int(len(self.geom_pairs)),
        }


def model_label(path: str | os.PathLike[str] | None) -> str:
    """A short name of a model file (its stem), ``humanoid`` for the bundled one."""
    return "humanoid" if path is None else Path(path).name.split(".")[0]
