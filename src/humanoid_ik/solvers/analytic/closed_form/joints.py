"""Joint angles of a three-hinge joint at a chosen swivel: both branches, the one to
keep, and the gimbal lock.

From a :data:`~.swivel.Decomposition`, each branch's angles are ``atan2`` of its
``(x, y)`` pairs, shifted by turns next to the middle of the range (unlimited hinges:
next to the preferred angle). The branch kept is the one inside the ranges closest to
the preferred angles, else the least violating. Where the outer axes nearly align
(``1 - C^2 < GIMBAL``) ``q1`` and ``q3`` are poorly conditioned; the batch then reads
them from the explicit rotation (:func:`gimbal_angles`), the single-target path hands
the target to the batch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.rotations import axis_angle_matrix
from humanoid_ik.solvers.analytic.closed_form.geometry import Triple
from humanoid_ik.solvers.analytic.closed_form.numeric import (
    ARRAYS,
    RANGE_TOL,
    Arithmetic,
    Real,
    Vec,
    into_range,
)

__all__ = [
    "GIMBAL",
    "Angles",
    "branch_angles",
    "choose",
    "shoulder_rotation",
    "gimbal_angles",
]

GIMBAL = 1e-7
"""Below this ``1 - (u1 . R u3)^2`` the outer axes of a joint nearly align and its
angles are read from the explicit rotation (:func:`gimbal_angles`)."""

Angles = tuple[Vec, Real, Real]
"""``(q1, q2, q3)`` [rad], the largest range violation [rad], and the choice key
(``|q - q_pref|_1``, plus ``1e6 (1 + violation)`` outside the ranges, ``inf`` where
the joint does not decompose)."""


def branch_angles(
    xp: Arithmetic, tri: Triple, branch: tuple, decomposes: Real, q_pref: Sequence[Real]
) -> Angles:
    """The :data:`Angles` of one branch of a :data:`~.swivel.Decomposition`.

    ``q_j = a_j + 2 pi round((center_j - a_j) / 2 pi)`` with ``a_j = atan2(y_j, x_j)``
    (``center_j`` the middle of the range, or ``q_pref_j`` for a hinge of kind 0); the
    violation ``max_j max(lo_j - q_j, q_j - hi_j, 0)``.
    """
    x1, y1, c2, s2, x3, y3, _ = branch
    top = xp.maximum
    mid = [m if k else p for m, k, p in zip(tri.center, tri.kind, q_pref, strict=True)]
    lo, hi = tri.lower, tri.upper
    a = into_range(xp, xp.atan2(y1, x1), mid[0])
    b = into_range(xp, xp.atan2(s2, c2), mid[1])
    c = into_range(xp, xp.atan2(y3, x3), mid[2])
    viol = top(top(top(lo[0] - a, a - hi[0]), top(lo[1] - b, b - hi[1])), top(lo[2] - c, c - hi[2]))
    viol = top(viol, 0.0)
    key = abs(a - q_pref[0]) + abs(b - q_pref[1]) + abs(c - q_pref[2])
    key = key + (viol > RANGE_TOL) * (1e6 * (1.0 + viol))
    if decomposes is not True:  # True: a joint that always decomposes
        key = xp.where(decomposes, key, math.inf)
    return (a, b, c), viol, key


def choose(xp: Arithmetic, first: Angles, second: Angles) -> Angles:
    """``second`` where its key is smaller, else ``first``."""
    pick = second[2] < first[2]
    qa, qb = first[0], second[0]
    q = (xp.where(pick, qb[0], qa[0]), xp.where(pick, qb[1], qa[1]), xp.where(pick, qb[2], qa[2]))
    return q, xp.where(pick, second[1], first[1]), xp.where(pick, second[2], first[2])


# ------------------------------------------------------------------------------ gimbal lock
def shoulder_rotation(frame: NDArray[np.float64], c: float, s: float) -> NDArray[np.float64]:
    """``R_sh(psi) = Rot(n, psi) [n r k][a b cv]' = n a' + (c r + s k) b' + (c k - s r) cv'``.

    Args:
        frame: ``n, r, k, a, b, cv`` as rows ``(6, 3)``.
        c, s: ``cos psi, sin psi``.
    """
    n, r, k, a, b, cv = frame
    return np.outer(n, a) + np.outer(c * r + s * k, b) + np.outer(c * k - s * r, cv)


def gimbal_angles(
    tri: Triple,
    R: NDArray[np.float64],
    branches: list[tuple[float, float]],
    q_pref: NDArray[np.float64],
) -> tuple[NDArray[np.float64], float] | None:
    """Angles ``(3,)`` of rotation ``R`` for a joint whose outer axes nearly align, and
    their range violation [rad]; ``None`` when no branch decomposes.

    For each branch's ``(q2, plain q1)``, ``q3`` is read from the remainder
    ``Rot(u2, -q2) Rot(u1, -q1) R``, which absorbs the error of a poorly conditioned
    ``q1``. In the lock itself (``R u3`` within 1e-10 of ``+-u1``) only
    ``q1 +- q3`` is fixed, and several ``q1`` are tried: the preferred one, the ends of
    its range, and those that put ``q3`` on the ends of its range. The split kept is
    inside the ranges, then least violating, then closest to ``q_pref``.
    """
    best = None
    for q2, q1 in branches:
        for qq in _splits(tri, R, q2, q1, q_pref):
            lo, hi = np.array(tri.lower), np.array(tri.upper)
            vv = float(np.max(np.maximum(lo - qq, 0.0) + np.maximum(qq - hi, 0.0)))
            key = (vv > RANGE_TOL, vv, float(np.sum(np.abs(qq - q_pref))))
            if best is None or key < best[0]:
                best = (key, qq, vv)
    return None if best is None else (best[1], best[2])


def _splits(
    tri: Triple, R: NDArray[np.float64], q2: float, q1: float, q_pref: NDArray[np.float64]
) -> list[NDArray[np.float64]]:
    """The ``(q1, q2, q3)`` to try for one branch (see :func:`gimbal_angles`)."""
    u1, u2, u3, f1, f2 = (np.array(v) for v in (tri.u1, tri.u2, tri.u3, tri.f1, tri.f2))
    y = R @ u3
    yp = y - float(y @ u1) * u1
    R2t = axis_angle_matrix(u2, -q2)
    center = np.where(np.array(tri.kind) > 0, tri.center, q_pref)

    def split(a1: float) -> NDArray[np.float64]:
        r = R2t @ axis_angle_matrix(u1, -a1) @ R @ f1
        q3 = math.atan2(float(f2 @ r), float(f1 @ r))
        return into_range(ARRAYS, np.array([a1, q2, q3]), center)

    if float(np.linalg.norm(yp)) > 1e-10:
        return [split(q1)]
    sigma = 1.0 if float(y @ u1) > 0 else -1.0
    total = float(split(0.0)[2]) * sigma  # q1 + sigma q3
    q1s = [float(q_pref[0])]
    if tri.kind[0]:
        q1s += [tri.lower[0], tri.upper[0]]
    if tri.kind[2]:
        q1s += [total - sigma * L for L in (tri.lower[2], tri.upper[2])]
    return [split(a1) for a1 in q1s]
