"""The elbow's direction: measured on a robot arm, turned into ``closed_form``'s swivel,
chosen among ``two_link``'s solutions, or reached by null-space steps (``lm`` arms).

The elbow's direction is the unit offset of the elbow point from the shoulder-wrist
line (:meth:`RobotArm.points`); two directions are compared by the angle between them
once both are projected normal to the robot's shoulder-wrist line.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.rotations import rotation_log
from humanoid_ik.experiments.retarget.robot import RobotArm

__all__ = ["elbow_angle", "elbow_steps", "swivel_for"]

_DOWN = np.array([0.0, 0.0, -1.0])
_X = np.array([1.0, 0.0, 0.0])


def _normal(v: NDArray[np.float64], n: NDArray[np.float64]) -> NDArray[np.float64] | None:
    p = v - float(v @ n) * n
    r = float(np.linalg.norm(p))
    return None if r < 1e-9 else p / r


def elbow_angle(arm: RobotArm, want: NDArray[np.float64]) -> tuple[float, float]:
    """(angle [rad] between the arm's elbow direction now and ``want``, the elbow's
    distance from the shoulder-wrist line over the upper arm's length); the angle is
    NaN for a straight arm."""
    S, E, W = arm.points()
    line = W - S
    n = line / max(float(np.linalg.norm(line)), 1e-12)
    up = E - S
    have = _normal(up, n)
    d = _normal(want, n)
    bend = float(np.linalg.norm(up - float(up @ n) * n) / max(float(np.linalg.norm(up)), 1e-12))
    if have is None or d is None:
        return math.nan, bend
    return math.acos(max(-1.0, min(1.0, float(have @ d)))), bend


def swivel_for(
    arm: RobotArm, position: NDArray, rotation: NDArray | None, want: NDArray[np.float64]
) -> float:
    """The ``closed_form`` swivel [rad] that puts the elbow towards ``want`` for a hand
    at ``position``/``rotation``: ``closed_form``'s convention (0 on the side of the
    shoulder-wrist line facing gravity, ``-z``; world ``x`` for a vertical line; turning
    right-handed about shoulder -> wrist); the wrist point is the target's (pose) or the
    hand position (position targets)."""
    W = position if rotation is None else position + rotation @ arm.wrist_offset
    line = W - arm.shoulder
    n = line / max(float(np.linalg.norm(line)), 1e-12)
    ref = _normal(_DOWN, n)
    if ref is None:
        ref = _normal(_X, n)
    d = _normal(want, n)
    if ref is None or d is None:
        return 0.0
    return math.atan2(float(n @ np.cross(ref, d)), float(ref @ d))


def _damped_pinv(J: NDArray[np.float64], lam: float) -> NDArray[np.float64]:
    return np.asarray(J.T @ np.linalg.solve(J @ J.T + lam * np.eye(J.shape[0]), np.eye(J.shape[0])))


def elbow_steps(
    arm: RobotArm,
    q: NDArray[np.float64],
    position: NDArray[np.float64],
    rotation: NDArray[np.float64] | None,
    want: NDArray[np.float64],
    steps: int,
    weight: float = 1.0,
) -> NDArray[np.float64]:
    """``steps`` Gauss-Newton steps from ``q`` towards the hand target (the primary task)
    with the elbow turned towards ``want`` in the hand task's null space (the secondary
    one); each elbow step asks for at most 0.3 of the elbow's distance from its line,
    times ``weight`` (0: the hand alone).
    Returns the joint values (inside the ranges); the chain is left at them."""
    c, k = arm.chain, arm.elbow
    q = q.copy()
    n_j = c.n
    for _ in range(steps):
        c.set_q(q)
        J = c.current_jacobian()
        e = np.empty(6)
        e[:3] = position - c.position
        if rotation is not None:
            e[3:] = rotation_log(rotation @ c.rotation.T)
            Jh = J
        else:
            e, Jh = e[:3], J[:3]
        Jp = _damped_pinv(Jh, 1e-8)
        dq = Jp @ e
        S, E, W = arm.points()
        line = W - S
        n = line / max(float(np.linalg.norm(line)), 1e-12)
        up = E - S
        along = float(up @ n)
        r = float(np.linalg.norm(up - along * n))
        d = _normal(want, n)
        if d is not None and r > 1e-6 and k > 0 and weight > 0:
            goal = S + along * n + r * d
            err = goal - E
            size = float(np.linalg.norm(err))
            if size > 0.3 * r:
                err *= 0.3 * r / size
            err *= weight
            anchors, axes = c.joint_axes()
            JE = np.zeros((3, n_j))
            JE[:, :k] = np.cross(axes[:k], E - anchors[:k]).T
            N = np.eye(n_j) - Jp @ Jh
            JEN = JE @ N
            dq = dq + N @ (_damped_pinv(JEN, 1e-6) @ (err - JE @ dq))
        q = c.clip(q + dq)
    c.set_q(q)
    return q
