"""The vectorised driver: many targets at once, one numpy call per step for all of them.

It runs the derivation of :mod:`.swivel` and :mod:`.joints` on arrays: per target the
wrist point, the elbow branches and the swivel frame; per row (a target and one of its
elbow branches) the 15 coefficients of each joint; then, for every row at once, the
preferred swivel, else the nearest swivel where a hinge meets a range end and every
joint is inside its range; then the elbow branch with the closer swivel and the joint
angles there. Targets are solved in chunks of :data:`CHUNK` (each target's answer does
not depend on the others).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import axis_angle_matrix, quat_to_mat
from humanoid_ik.core.types import target_rows
from humanoid_ik.errors import TargetError
from humanoid_ik.solvers.analytic.closed_form import swivel as sw
from humanoid_ik.solvers.analytic.closed_form.geometry import ArmContext, Forearm, arm_context
from humanoid_ik.solvers.analytic.closed_form.joints import (
    GIMBAL,
    branch_angles,
    choose,
    gimbal_angles,
    shoulder_rotation,
)
from humanoid_ik.solvers.analytic.closed_form.numeric import ARRAYS, RANGE_TOL, Vec, dot, sub

__all__ = [
    "BatchSolution",
    "Rows",
    "Setup",
    "Solved",
    "setup",
    "take",
    "feasible_rows",
    "candidates",
    "solve_chunk",
    "starts",
    "solve_batch",
]

CHUNK = 2048
"""Targets solved per vectorised step."""
xp = ARRAYS


class BatchSolution(NamedTuple):
    """What :func:`solve_batch` returns (unpacks as ``q, ok``)."""

    q: NDArray[np.float64]
    """Joint values ``(N, 7)`` [rad]; for a failed target the closest sensible pose."""
    ok: NDArray[np.bool_]
    """``(N,)`` True where the pose is reached with every joint inside its range."""


class Rows(NamedTuple):
    """One row per (target, elbow branch): everything linear in ``(1, cos psi, sin psi)``."""

    full: NDArray[np.int64]  # (M,) 2 * target + elbow branch
    target: NDArray[np.int64]  # (M,) index of the target
    q4: NDArray[np.float64]  # (M,) elbow angle [rad]
    usable: NDArray[np.bool_]  # (M,) elbow inside its range and branch not a duplicate
    frame: NDArray[np.float64]  # (6, 3, M) n, r, k, a, b, cv (see swivel)
    ksh: NDArray[np.float64]  # (15, M) shoulder coefficients
    kwr: NDArray[np.float64] | None  # (15, M) wrist, None for position-only targets
    cp: NDArray[np.float64]  # (M,) cos of the preferred swivel
    sp: NDArray[np.float64]  # (M,) sin of the preferred swivel


class Setup(NamedTuple):
    """What :func:`setup` finds for N targets before any swivel is chosen."""

    rows: Rows
    miss: NDArray[np.float64]  # (N,) distance [m] beyond the reachable shell (0 inside)
    inner: NDArray[np.bool_]  # (N,) the miss is inside the inner hole
    q_wrist: NDArray[np.float64] | None  # (N, 3) wrist angles for position-only targets
    shell: tuple[NDArray, NDArray]  # (N,) inner and outer radius [m] of the reachable shell
    R_t: NDArray[np.float64] | None  # (N, 3, 3) target rotations
    q4: NDArray[np.float64]  # (N, 2) both elbow branches [rad]
    usable: NDArray[np.bool_]  # (N, 2) elbow inside its range, branch not a repeat
    elbow_key: NDArray[np.float64]  # (N, 2) range violation, then distance from the start


def _cols(a: NDArray[np.float64]) -> Vec:
    """The columns of ``a (N, 3)`` as three contiguous ``(N,)`` arrays."""
    c = np.ascontiguousarray(a.T)
    return c[0], c[1], c[2]


def _stack(values: tuple, M: int) -> NDArray[np.float64]:
    """Numbers (arrays ``(M,)`` or floats) stacked as ``(len(values), M)``."""
    return np.stack([np.broadcast_to(v, (M,)) for v in values])


def setup(
    ctx: ArmContext,
    positions: NDArray[np.float64],
    R_t: NDArray[np.float64] | None,
    q0: NDArray[np.float64],
    swivel: NDArray[np.float64] | None,
    keep: str = "best",
) -> Setup:
    """Elbow branches, swivel frames and the swivel-linear coefficients of N targets.

    Rows are made for the elbow branches inside their range (``keep="best"``; a target
    with none keeps its least violating one) or for every distinct branch (``"all"``).

    Args:
        positions: end-effector targets ``(N, 3)`` [m].
        R_t: target rotations ``(N, 3, 3)``, or ``None`` (wrist kept at ``q0``).
        q0: starting postures ``(N, 7)`` [rad].
        swivel: preferred swivels ``(N,)`` [rad], or ``None`` for the starting elbow's.
    """
    N = positions.shape[0]
    p = _cols(positions)
    R_rows = None
    if R_t is not None:
        R_rows = tuple(_cols(R_t[:, i, :]) for i in range(3))
        fa: Forearm = ctx.forearm
        t = sw.wrist_target(ctx, p, R_rows)
        q_wrist = None
    else:
        q_wrist = np.clip(q0[:, 4:], ctx.lower[4:], ctx.upper[4:])
        fa = sw.hand_forearm(xp, ctx, _cols(np.cos(q_wrist)), _cols(np.sin(q_wrist)))
        t = sub(p, ctx.S)
    r2 = dot(t, t)
    r = np.sqrt(r2)
    cos_e = (fa.L2 - r2) / fa.den
    r_min, r_max = np.broadcast_to(fa.r_min, (N,)), np.broadcast_to(fa.r_max, (N,))
    miss = np.where(np.abs(cos_e) > 1.0, np.maximum(np.maximum(r - r_max, r_min - r), 0.0), 0.0)
    plus, minus, distinct2 = sw.elbow_branches(xp, ctx, fa, cos_e)
    q4 = np.stack([plus, minus], axis=1)  # (N, 2)
    distinct = np.ones((N, 2), dtype=bool)
    distinct[:, 1] = distinct2
    lo, hi = ctx.elbow_lo, ctx.elbow_hi
    usable = (q4 >= lo - RANGE_TOL) & (q4 <= hi + RANGE_TOL) & distinct
    el_viol = np.maximum(lo - q4, 0.0) + np.maximum(q4 - hi, 0.0)
    el_key = el_viol * 1e3 + np.abs(q4 - q0[:, 3:4]) + np.where(distinct, 0.0, 1e9)
    if keep == "all":
        kept = distinct
    else:
        least = np.arange(2) == np.argmin(el_key, axis=1)[:, None]
        kept = usable | (~usable.any(axis=1, keepdims=True) & least)
    n, rr, kk = sw.swivel_frame(xp, ctx, t, lambda: sw.rest_direction(xp, ctx, fa))
    if swivel is None:
        e = sw.start_elbow(ctx, _cols(np.cos(q0[:, :3])), _cols(np.sin(q0[:, :3])))
        cp, sp = sw.start_swivel(xp, e, rr, kk)
    else:
        cp, sp = np.cos(swivel), np.sin(swivel)
    full = np.flatnonzero(kept.reshape(2 * N))
    target = full // 2
    q4f = q4.reshape(2 * N)[full]
    frame, ksh, kwr = _row_coefficients(ctx, fa, (n, rr, kk), R_rows, target, q4f)
    rows = Rows(
        full, target, q4f, usable.reshape(2 * N)[full], frame, ksh, kwr, cp[target], sp[target]
    )
    return Setup(rows, miss, r < r_min, q_wrist, (r_min, r_max), R_t, q4, usable, el_key)


def _row_coefficients(
    ctx: ArmContext,
    fa: Forearm,
    nrk: tuple[Vec, Vec, Vec],
    R_rows: tuple | None,
    target: NDArray[np.int64],
    q4: NDArray[np.float64],
) -> tuple[NDArray, NDArray, NDArray | None]:
    """Per row: the frames ``(6, 3, M)`` and the shoulder's and wrist's coefficients."""
    M = target.size

    def at(v: Vec) -> Vec:
        return (v[0][target], v[1][target], v[2][target])

    n, r, k = (at(v) for v in nrk)
    if not isinstance(fa.L2, float):  # one forearm point per target
        fa = Forearm(*(at(f) if isinstance(f, tuple) else f[target] for f in fa))
    ce, se = np.cos(q4), np.sin(q4)
    a, b, cv = sw.arm_frame(xp, ctx, fa, n, ce, se)
    ksh = _stack(sw.triple_coefficients(ctx.sh, sw.triple_target(ctx.sh, n, r, k), a, b, cv), M)
    kwr = None
    if R_rows is not None:
        hand = sw.hand_frames(ctx, tuple(at(row) for row in R_rows), n, r, k)
        kwr = _stack(sw.wrist_coefficients(ctx, hand, ce, se, a, b, cv), M)
    frame = np.array([[np.broadcast_to(x, (M,)) for x in v] for v in (n, r, k, a, b, cv)])
    return frame, ksh, kwr


def take(rows: Rows, idx: NDArray[np.int64]) -> Rows:
    """The rows ``idx`` (every field indexed on its last axis)."""
    return Rows._make(None if f is None else f[..., idx] for f in rows)


def feasible_rows(ctx: ArmContext, rows: Rows, c: NDArray, s: NDArray) -> NDArray[np.bool_]:
    """Every joint inside its range at swivels ``(cos, sin)`` of shape ``(M, K)``."""
    ok = sw.feasible(sw.decompose(xp, ctx.sh, rows.ksh[:, :, None], c, s)) & rows.usable[:, None]
    if rows.kwr is not None:
        ok = ok & sw.feasible(sw.decompose(xp, ctx.wr, rows.kwr[:, :, None], c, s))
    return np.broadcast_to(ok, np.broadcast_shapes(np.shape(c), (rows.full.size, 1)))


def candidates(ctx: ArmContext, rows: Rows) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Every swivel where some hinge meets a range end: the distance key to the
    preferred swivel (``inf`` where there is no root), ``cos, sin, valid``, each
    ``(M, K)``."""
    roots = sw.range_end_roots(xp, ctx.sh, rows.ksh, rows.cp, rows.sp)
    if rows.kwr is not None:
        roots += sw.range_end_roots(xp, ctx.wr, rows.kwr, rows.cp, rows.sp)
    M = rows.full.size
    if not roots:
        z = np.zeros((M, 0))
        return z, z, z, z.astype(bool)
    d, c, s, v = ([np.broadcast_to(root[i], (M,)) for root in roots] for i in range(4))
    valid = np.stack(v, axis=1)
    dist = np.where(valid, np.stack(d, axis=1), np.inf)
    return dist, np.stack(c, axis=1), np.stack(s, axis=1), valid


# ------------------------------------------------------------------------------ solving
class Solved(NamedTuple):
    """What :func:`solve_chunk` returns for N targets."""

    q: NDArray[np.float64]  # (N, 7)
    feasible: NDArray[np.bool_]  # (N,) every joint inside its range
    miss: NDArray[np.float64]  # (N,) distance beyond the shell [m]
    inner: NDArray[np.bool_]  # (N,) inside the inner hole
    elbow_ok: NDArray[np.bool_]  # (N,) some elbow branch inside its range
    swivel: NDArray[np.float64]  # (N,) chosen swivel [rad]
    setup: Setup


def solve_chunk(
    ctx: ArmContext,
    positions: NDArray[np.float64],
    R_t: NDArray[np.float64] | None,
    q0: NDArray[np.float64],
    swivel: NDArray[np.float64] | None,
) -> Solved:
    """Closest feasible swivel to the preferred one, then the joint angles, for N targets."""
    st = setup(ctx, positions, R_t, q0, swivel)
    rows = st.rows
    N = positions.shape[0]
    # per (target, elbow branch): distance key of the best swivel and its cos, sin
    dist = np.full(2 * N, np.inf)
    bc, bs = np.ones(2 * N), np.zeros(2 * N)
    bc[rows.full], bs[rows.full] = rows.cp, rows.sp
    # 1. the preferred swivel itself
    ok0 = feasible_rows(ctx, rows, rows.cp[:, None], rows.sp[:, None])[:, 0]
    dist[rows.full[ok0]] = 0.0
    # 2. otherwise the nearest swivel where a hinge meets a range end and all are inside
    done = np.asarray(np.isfinite(dist.reshape(N, 2)).any(axis=1))
    need = np.flatnonzero(~done[rows.target] & rows.usable)
    if need.size:
        _nearest_roots(ctx, rows, need, dist, bc, bs)
    # 3. the elbow branch with the closer swivel (then the closer elbow angle)
    d2 = dist.reshape(N, 2)
    pick = np.where(
        d2[:, 0] < d2[:, 1] - 1e-12,
        0,
        np.where(d2[:, 1] < d2[:, 0] - 1e-12, 1, np.argmin(st.elbow_key, axis=1)),
    )
    idx = np.arange(N)
    where = np.full(2 * N, -1)
    where[rows.full] = np.arange(rows.full.size)
    full = 2 * idx + pick
    m = where[full]
    c, s = bc[full], bs[full]
    q = np.empty((N, 7))
    q[:, 3] = st.q4[idx, pick]
    q[:, :3] = _joint_angles(ctx, st, m, c, s, q0[:, :3], wrist=False)
    if R_t is None:
        assert st.q_wrist is not None
        q[:, 4:] = st.q_wrist
    else:
        q[:, 4:] = _joint_angles(ctx, st, m, c, s, q0[:, 4:], wrist=True)
    # infeasible targets keep their least violating branch, moved inside the ranges
    q = np.clip(q, ctx.lower, ctx.upper)
    feas = np.isfinite(d2[idx, pick])
    elbow_ok = np.asarray(st.usable.any(axis=1))
    return Solved(q, feas, st.miss, st.inner, elbow_ok, np.arctan2(s, c), st)


def _nearest_roots(
    ctx: ArmContext, rows: Rows, need: NDArray[np.int64], dist: NDArray, bc: NDArray, bs: NDArray
) -> None:
    """For rows ``need``: the candidate swivel nearest the preferred one at which every
    joint is inside its range (the nearest 6 tried first), written into ``dist, bc, bs``."""
    sub_rows = take(rows, need)
    d, c, s, _ = candidates(ctx, sub_rows)
    order = np.argsort(d, axis=1)
    d = np.take_along_axis(d, order, axis=1)
    c = np.take_along_axis(c, order, axis=1)
    s = np.take_along_axis(s, order, axis=1)
    todo = np.arange(need.size)
    start = 0
    for width in (6, d.shape[1]):
        stop = min(width, d.shape[1])
        if start >= stop or todo.size == 0:
            break
        part = take(sub_rows, todo)
        cc, ss, dd = c[todo, start:stop], s[todo, start:stop], d[todo, start:stop]
        f = feasible_rows(ctx, part, cc, ss) & np.isfinite(dd)
        hit = f.any(axis=1)
        k = np.argmax(f, axis=1)
        rows_hit, k = np.flatnonzero(hit), k[hit]
        i = rows.full[need[todo[rows_hit]]]
        dist[i], bc[i], bs[i] = dd[rows_hit, k], cc[rows_hit, k], ss[rows_hit, k]
        todo = todo[~hit & np.isfinite(d[todo, stop - 1])]
        start = stop


def _joint_angles(
    ctx: ArmContext,
    st: Setup,
    m: NDArray[np.int64],
    c: NDArray,
    s: NDArray,
    q_pref: NDArray,
    wrist: bool,
) -> NDArray[np.float64]:
    """Angles ``(N, 3)`` of one three-hinge joint at rows ``m`` and swivels ``(c, s)``:
    the branch inside the ranges closest to ``q_pref (N, 3)`` (gimbal locks read from
    the explicit rotation)."""
    rows = st.rows
    tri = ctx.wr if wrist else ctx.sh
    k = (rows.kwr if wrist else rows.ksh)[:, m]  # type: ignore[index]
    dec = sw.decompose(xp, tri, k, c, s)
    pref = _cols(q_pref)
    plus = branch_angles(xp, tri, dec[2], dec[1], pref)
    minus = branch_angles(xp, tri, dec[3], dec[1], pref)
    q = np.stack(choose(xp, plus, minus)[0], axis=1)
    decomposes = np.broadcast_to(dec[1], c.shape)
    for i in np.flatnonzero(1.0 - dec[0] ** 2 < GIMBAL):
        mi = int(m[i])
        R = shoulder_rotation(rows.frame[:, :, mi], float(c[i]), float(s[i]))
        if wrist:
            assert st.R_t is not None
            R_el = axis_angle_matrix(ctx.geo.elbow_axis, float(rows.q4[mi]))
            R = R_el.T @ R.T @ st.R_t[rows.target[mi]] @ ctx.geo.R_ee0.T
        branches = [
            (math.atan2(float(br[3][i]), float(br[2][i])), float(ang[0][0][i]))
            for br, ang in ((dec[2], plus), (dec[3], minus))
            if decomposes[i]
        ]
        got = gimbal_angles(tri, R, branches, q_pref[i])
        if got is not None:
            q[i] = got[0]
    return q


# ------------------------------------------------------------------------------ the API
def target_arrays(
    positions: ArrayLike, quats: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Positions ``(N, 3)`` and rotations ``(N, 3, 3)`` (or ``None``) from the inputs.

    Raises:
        TargetError: wrong shapes, NaN/inf, non-unit quaternions.
    """
    p, _, unit = target_rows(positions, quats)
    return p, None if unit is None else quat_to_mat(unit)


def starts(chain: Chain, q0: ArrayLike | None, N: int) -> NDArray[np.float64]:
    """Starting postures ``(N, 7)``, inside the ranges (default: the chain's joints).

    Raises:
        TargetError: not 7 finite values nor ``(N, 7)`` of them.
    """
    if q0 is None:
        return np.broadcast_to(chain.clip(chain.q), (N, 7))
    arr = np.asarray(q0, dtype=np.float64)
    if arr.shape not in ((7,), (N, 7)) or not np.all(np.isfinite(arr)):
        raise TargetError(f"q0 must be 7 finite joint values or ({N}, 7), got shape {arr.shape}")
    return np.broadcast_to(chain.clip(arr), (N, 7))


def _swivels(swivel: float | ArrayLike | None, N: int) -> NDArray[np.float64] | None:
    if swivel is None:
        return None
    arr = np.asarray(swivel, dtype=np.float64)
    if arr.shape not in ((), (N,)) or not np.all(np.isfinite(arr)):
        raise TargetError(f"swivel must be a finite number or ({N},) of them, got {swivel!r}")
    return np.broadcast_to(arr, (N,))


def solve_batch(
    chain: Chain,
    positions: ArrayLike,
    quats: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    swivel: float | ArrayLike | None = None,
) -> BatchSolution:
    """Closed-form IK for many targets at once (vectorised with numpy).

    Args:
        chain: a 7-hinge arm (see :func:`~.geometry.structure_problem`).
        positions: end-effector targets ``(N, 3)`` [m].
        quats: target orientations ``(N, 4)`` wxyz, or ``None`` for position targets
            (the wrist keeps its ``q0`` angles).
        q0: starting posture ``(7,)`` or ``(N, 7)`` [rad]; default the chain's joints.
        swivel: preferred swivel [rad], scalar or ``(N,)``; default the starting elbow's.

    Returns:
        ``(q (N, 7), ok (N,))``: the joints at the feasible swivel closest to the
        preferred one; where ``ok`` is False the target is beyond reach or no swivel
        keeps every joint inside its range, and ``q`` is the closest sensible pose
        (arm stretched toward the target, or the least violating branch clipped into
        the ranges).

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: wrong shapes, NaN/inf, non-unit quaternions.
    """
    ctx = arm_context(chain)
    p, R = target_arrays(positions, quats)
    N = p.shape[0]
    q_start = starts(chain, q0, N)
    psi = _swivels(swivel, N)
    q = np.empty((N, 7))
    ok = np.empty(N, dtype=bool)
    for a in range(0, N, CHUNK):
        b = min(a + CHUNK, N)
        res = solve_chunk(
            ctx,
            p[a:b],
            None if R is None else R[a:b],
            np.ascontiguousarray(q_start[a:b]),
            None if psi is None else psi[a:b],
        )
        q[a:b] = res.q
        ok[a:b] = res.feasible & (res.miss == 0.0)
    return BatchSolution(q, ok)
