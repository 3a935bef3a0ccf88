"""A frame the speed limits do not allow exactly: the hand's position first, inside the
box of joint values that the speed limits and the ranges leave from the previous frame.

Where the exact answer would turn a joint faster than its limit (a straight arm near the
shoulder's gimbal lock, a slow wrist), cutting each joint to its limit moves the hand
along a line in joint space that nothing chose: the hand falls off its path by as much
as the cut. Instead, :func:`bounded_solve` takes a few Gauss-Newton steps on the hand
error inside that box (an active set: a joint that would leave the box is held at its
edge and the others solve again), with the orientation error weighted by
:data:`ROTATION_WEIGHT` [m/rad]: the orientation gives way first, the position only
where the box leaves no other way (the hand then lags by the least the limits allow).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import rotation_log

__all__ = ["ROTATION_WEIGHT", "bounded_solve", "hand_cost"]

ROTATION_WEIGHT = 0.02
"""How much one radian of hand orientation error counts against one metre of position
error while a frame is speed-limited [m/rad]: 1 degree weighs as 0.35 mm."""
STEPS = 4
"""Gauss-Newton steps of :func:`bounded_solve`."""
DAMPING = 1e-6
"""Damping of the steps (squared metres)."""


def hand_cost(
    chain: Chain, position: NDArray[np.float64], rotation: NDArray[np.float64] | None
) -> float:
    """The weighted squared hand error at the chain's current kinematics."""
    e = float(np.sum((position - chain.position) ** 2))
    if rotation is not None:
        r = rotation_log(rotation @ chain.rotation.T)
        e += ROTATION_WEIGHT**2 * float(r @ r)
    return e


def _box_step(J: NDArray, e: NDArray, lo: NDArray, hi: NDArray) -> NDArray[np.float64]:
    """The damped least-squares step ``J dq = e`` with ``lo <= dq <= hi``: joints that
    would leave the box are held at its edge, the rest solve again."""
    n = J.shape[1]
    dq = np.zeros(n)
    free = np.ones(n, dtype=bool)
    for _ in range(n):
        Jf = J[:, free]
        r = e - J[:, ~free] @ dq[~free]
        A = Jf @ Jf.T + DAMPING * np.eye(J.shape[0])
        dq[free] = Jf.T @ np.linalg.solve(A, r)
        over = free & ((dq < lo) | (dq > hi))
        if not over.any():
            break
        dq[over] = np.minimum(np.maximum(dq[over], lo[over]), hi[over])
        free &= ~over
        if not free.any():
            break
    return np.minimum(np.maximum(dq, lo), hi)


def bounded_solve(
    chain: Chain,
    start: NDArray[np.float64],
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
    position: NDArray[np.float64],
    rotation: NDArray[np.float64] | None,
) -> tuple[NDArray[np.float64], float]:
    """From ``start`` (inside ``[lo, hi]``), :data:`STEPS` box-bounded Gauss-Newton steps
    on the hand target; returns the joints and their :func:`hand_cost` (the chain is
    left at them). A step that does not lower the cost is halved, then dropped."""
    q = np.minimum(np.maximum(start, lo), hi)
    chain.set_q(q)
    cost = hand_cost(chain, position, rotation)
    for _ in range(STEPS):
        J = chain.current_jacobian()
        if rotation is not None:
            e = np.empty(6)
            e[:3] = position - chain.position
            e[3:] = ROTATION_WEIGHT * rotation_log(rotation @ chain.rotation.T)
            Jw = J.copy()
            Jw[3:] *= ROTATION_WEIGHT
        else:
            e, Jw = position - chain.position, J[:3]
        dq = _box_step(Jw, e, lo - q, hi - q)
        for _half in range(3):
            chain.set_q(q + dq)
            c = hand_cost(chain, position, rotation)
            if c < cost:
                q, cost = q + dq, c
                break
            dq *= 0.5
        else:
            break
    chain.set_q(q)
    return q, cost
