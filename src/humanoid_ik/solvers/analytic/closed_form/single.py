"""The one-target driver: the derivation of :mod:`.swivel` and :mod:`.joints` on floats.

A numpy call costs about a microsecond, so one target is solved with the same
functions as the batch but on Python floats (:data:`~.numeric.FLOATS`). Only the
search differs, as a loop can: the candidate swivels (the preferred one, then the
range-end roots nearest first) are tried one at a time until every joint is inside,
each joint read lazily (:func:`~.swivel.decompose` stops at the first hinge outside),
and the decompositions found there give the angles. Anything unusual (a target out of
reach or out of range, a joint near its gimbal lock) raises :class:`Fallback`, and
the caller hands the target to the batch driver, which handles those cases.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from operator import itemgetter

from humanoid_ik.solvers.analytic.closed_form import swivel as sw
from humanoid_ik.solvers.analytic.closed_form.geometry import ArmContext, Triple
from humanoid_ik.solvers.analytic.closed_form.joints import GIMBAL, branch_angles, choose
from humanoid_ik.solvers.analytic.closed_form.numeric import FLOATS, RANGE_TOL, Vec, dot, sub

__all__ = ["Fallback", "solve_one"]

xp = FLOATS


class Fallback(Exception):
    """The one-target path leaves this target to the batch driver."""


def solve_one(
    ctx: ArmContext,
    position: list[float],
    rotation: list[list[float]] | None,
    q0: list[float],
    swivel: float | None,
) -> tuple[list[float], float]:
    """Joint values ``(7,)`` [rad] and swivel [rad] for one target.

    The steps of :func:`~.batch.solve_chunk`: the wrist point and the elbow
    ``q4 = alpha +- acos((L2 - |t|^2) / den)`` (:func:`~.swivel.elbow_branches`), the
    swivel frame and the preferred swivel; per elbow branch inside its range the 15
    coefficients of each joint and the feasible swivel nearest the preferred one; then
    the elbow branch with the nearer swivel (ties: the elbow nearer the start) and the
    shoulder and wrist branches there closest to the start.

    Args:
        position: the target position [m].
        rotation: the target rotation's rows, or ``None`` for a position target (the
            wrist keeps ``q0``'s angles).
        q0: the start (inside the ranges).
        swivel: the preferred swivel [rad], or ``None`` for the start's.

    Raises:
        Fallback: the target is out of reach, out of range, or a joint is near its
            gimbal lock.
    """
    along: Vec | Callable[[], Vec]
    if rotation is not None:
        fa = ctx.forearm
        t = sw.wrist_target(ctx, position, rotation)
        along = ctx.rest
    else:
        fa = ctx.memo.get("wrist", q0[4:], lambda c, s: sw.hand_forearm(xp, ctx, c, s))
        t = sub(position, ctx.S)
        along = lambda: sw.rest_direction(xp, ctx, fa)  # noqa: E731
    cos_e = (fa.L2 - dot(t, t)) / fa.den
    if cos_e > 1.0 or cos_e < -1.0:
        raise Fallback
    plus, minus, distinct = sw.elbow_branches(xp, ctx, fa, cos_e)
    lo, hi = ctx.elbow_lo - RANGE_TOL, ctx.elbow_hi + RANGE_TOL
    elbows = [q4 for q4 in ((plus, minus) if distinct else (plus,)) if lo <= q4 <= hi]
    if not elbows:
        raise Fallback
    n, r, k = sw.swivel_frame(xp, ctx, t, along)
    if swivel is None:
        e = ctx.memo.get("shoulder", q0[:3], lambda c, s: sw.start_elbow(ctx, c, s))
        cp, sp = sw.start_swivel(xp, e, r, k)
    else:
        cp, sp = math.cos(swivel), math.sin(swivel)
    sh_target = sw.triple_target(ctx.sh, n, r, k)
    hand = None if rotation is None else sw.hand_frames(ctx, rotation, n, r, k)
    best = None  # (distance key, elbow key, q4, cos, sin, shoulder, wrist decompositions)
    for q4 in elbows:
        ce, se = math.cos(q4), math.sin(q4)
        a, b, cv = sw.arm_frame(xp, ctx, fa, n, ce, se)
        ksh = sw.triple_coefficients(ctx.sh, sh_target, a, b, cv)
        kwr = None if hand is None else sw.wrist_coefficients(ctx, hand, ce, se, a, b, cv)
        found = _nearest_feasible(ctx, ksh, kwr, cp, sp, math.inf if best is None else best[0])
        if found is None:
            continue
        ekey = abs(q4 - q0[3])
        if (
            best is None
            or found[0] < best[0] - 1e-12
            or (found[0] <= best[0] + 1e-12 and ekey < best[1])
        ):
            best = (found[0], ekey, q4, *found[1:])
    if best is None:
        raise Fallback
    _, _, q4, c, s, dsh, dwr = best
    q = _angles(ctx.sh, dsh, q0[:3])
    q.append(q4)
    q += q0[4:] if dwr is None else _angles(ctx.wr, dwr, q0[4:])
    return q, math.atan2(s, c)


def _nearest_feasible(
    ctx: ArmContext,
    ksh: sw.Coefficients,
    kwr: sw.Coefficients | None,
    cp: float,
    sp: float,
    best: float,
) -> tuple | None:
    """The feasible swivel nearest ``(cp, sp)`` for one elbow branch: the preferred one,
    else the nearest range-end root at which every joint is inside; none further than
    ``best + 1e-12`` (distance keys: ``1 - cos`` of the angle to the preferred swivel).

    Returns:
        ``(distance key, cos, sin, shoulder, wrist decompositions there)`` (the wrist's
        ``None`` for a position target), or ``None``.
    """
    sh, wr = ctx.sh, ctx.wr
    candidates = [(0.0, cp, sp, True)]
    roots = None
    limit = best + 1e-12
    while True:
        for dist, c, s, _ in candidates:
            if dist > limit:
                return None
            if kwr is None:
                dsh = sw.decompose(xp, sh, ksh, c, s, True)
                if dsh is not None:
                    return dist, c, s, dsh, None
                continue
            # the wrist first: at the range-end roots it is the more often outside
            dwr = sw.decompose(xp, wr, kwr, c, s, True)
            if dwr is not None:
                dsh = sw.decompose(xp, sh, ksh, c, s, True)
                if dsh is not None:
                    return dist, c, s, dsh, dwr
        if roots is not None:
            return None
        # the preferred swivel failed: the range-end roots, nearest first
        roots = sw.range_end_roots(xp, sh, ksh, cp, sp)
        if kwr is not None:
            roots += sw.range_end_roots(xp, wr, kwr, cp, sp)
        roots.sort(key=_first)
        candidates = roots


_first = itemgetter(0)


def _angles(tri: Triple, dec: sw.Decomposition, q_pref: list[float]) -> list[float]:
    """The three angles of the branch inside the ranges (of the two, the one closest to
    ``q_pref``: :func:`~.joints.choose`)."""
    if 1.0 - dec[0] * dec[0] < GIMBAL:
        raise Fallback
    inside = [branch_angles(xp, tri, b, dec[1], q_pref) for b in dec[2:4] if b[6]]
    got = choose(xp, *inside) if len(inside) == 2 else inside[0] if inside else None
    if got is None or got[1] > RANGE_TOL:
        raise Fallback
    return list(got[0])
