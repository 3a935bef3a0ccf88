"""Questions about one target beyond its answer: every branch at given swivels, and the
swivel intervals in which every joint stays inside its range."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import Target
from humanoid_ik.errors import TargetError
from humanoid_ik.solvers.analytic.closed_form.batch import (
    candidates,
    feasible_rows,
    setup,
    starts,
    take,
)
from humanoid_ik.solvers.analytic.closed_form.geometry import arm_context
from humanoid_ik.solvers.analytic.closed_form.joints import branch_angles
from humanoid_ik.solvers.analytic.closed_form.numeric import ARRAYS, RANGE_TOL, TWO_PI
from humanoid_ik.solvers.analytic.closed_form.swivel import decompose

__all__ = ["Branch", "SwivelInterval", "solutions", "swivel_intervals"]


class Branch(NamedTuple):
    """One joint vector reaching the target at a given swivel."""

    q: NDArray[np.float64]
    """Joint values ``(7,)`` [rad], each shifted by 2 pi next to the middle of its range."""
    valid: bool
    """Every joint inside its range (with 1e-9 rad slack)."""
    elbow: int
    """Elbow branch: 0 for ``alpha + phi``, 1 for ``alpha - phi``."""
    shoulder: int
    """Shoulder decomposition branch: 0 or 1 (``q2 = base +- delta``)."""
    wrist: int
    """Wrist decomposition branch: 0 or 1 (0 for a position-only target: wrist kept)."""
    swivel: float
    """The swivel [rad] this joint vector belongs to."""


class SwivelInterval(NamedTuple):
    """Swivels ``start <= psi <= end`` [rad] at which every joint stays inside its range."""

    elbow: int
    """Elbow branch (as in :class:`Branch`)."""
    q_elbow: float
    """Elbow angle [rad] of that branch."""
    start: float
    """First swivel [rad], in ``[-pi, pi]``."""
    end: float
    """Last swivel [rad], ``start <= end <= start + 2 pi`` (may pass ``pi``)."""


def solutions(
    chain: Chain,
    target: Target | ArrayLike,
    swivel: float | ArrayLike,
    q0: ArrayLike | None = None,
) -> list[Branch]:
    """Every joint vector that reaches ``target`` at the swivel(s) ``swivel`` [rad].

    Per swivel up to eight for a pose (two elbow, two shoulder and two wrist branches),
    up to four for a position (the wrist keeps ``q0``'s angles). Empty when the target
    is beyond reach. ``valid`` tells which stay inside the joint ranges.

    Args:
        chain: a 7-hinge arm (see :func:`~.geometry.structure_problem`).
        target: a :class:`Target` or a position ``(3,)`` [m].
        swivel: one swivel or ``(K,)`` of them [rad].
        q0: starting posture ``(7,)`` (the wrist of a position target, and the 2 pi
            shift of unlimited joints); default the chain's joints.

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: a bad target, ``q0`` or swivel.
    """
    ctx = arm_context(chain)
    tgt = Target.of(target)
    q_start = np.ascontiguousarray(starts(chain, q0, 1))
    psi = np.atleast_1d(np.asarray(swivel, dtype=np.float64))
    if psi.ndim != 1 or not np.all(np.isfinite(psi)):
        raise TargetError(f"swivel must be finite angles, one or (K,), got {swivel!r}")
    R = None if tgt.rotation is None else tgt.rotation[None]
    st = setup(ctx, tgt.position[None], R, q_start, np.zeros(1), keep="all")
    if st.miss[0] > 0.0:
        return []
    rows = st.rows
    c, s = np.cos(psi), np.sin(psi)
    lo, hi = ctx.lower - RANGE_TOL, ctx.upper + RANGE_TOL
    K = psi.size
    out: list[Branch] = []
    for m in range(rows.full.size):
        parts = []  # per joint: (branch, angles (K, 3), decomposes (K,)) for each branch
        for tri, k, pref in (
            (ctx.sh, rows.ksh, q_start[0, :3]),
            (ctx.wr, rows.kwr, q_start[0, 4:]),
        ):
            if k is None:
                assert st.q_wrist is not None
                parts.append([(0, np.broadcast_to(st.q_wrist[0], (K, 3)), True)])
                continue
            dec = decompose(ARRAYS, tri, k[:, m], c, s)
            branches = []
            for b in (0, 1):
                ang = branch_angles(ARRAYS, tri, dec[2 + b], dec[1], tuple(pref))
                qs = np.stack([np.broadcast_to(x, (K,)) for x in ang[0]], axis=1)
                branches.append((b, qs, dec[1]))
            parts.append(branches)
        for i, qs, ds in parts[0]:
            for j, qw, dw in parts[1]:
                q = np.empty((K, 7))
                q[:, :3], q[:, 3], q[:, 4:] = qs, rows.q4[m], qw
                valid = np.all((q >= lo) & (q <= hi), axis=1)
                ok = np.broadcast_to(ds & dw, (K,))
                elbow = int(rows.full[m] % 2)
                for n in np.flatnonzero(ok):
                    out.append(Branch(q[n], bool(valid[n]), elbow, i, j, float(psi[n])))
    return out


def swivel_intervals(
    chain: Chain, target: Target | ArrayLike, q0: ArrayLike | None = None
) -> list[SwivelInterval]:
    """The swivels at which ``target`` is reached with every joint inside its range.

    Interval ends are exact roots of ``k_c cos psi + k_s sin psi = d`` (a hinge at a
    range end); between two consecutive roots feasibility is constant and is tested at
    the midpoint. A whole circle is returned as ``[-pi, pi]``. Empty when the target is
    beyond reach or nothing is feasible. ``q0`` only matters for a position target (the
    wrist keeps its angles).

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: a bad target or ``q0``.
    """
    ctx = arm_context(chain)
    tgt = Target.of(target)
    q_start = np.ascontiguousarray(starts(chain, q0, 1))
    R = None if tgt.rotation is None else tgt.rotation[None]
    st = setup(ctx, tgt.position[None], R, q_start, np.zeros(1))
    if st.miss[0] > 0.0:
        return []
    out: list[SwivelInterval] = []
    for m in np.flatnonzero(st.rows.usable):
        row = take(st.rows, np.array([m]))
        elbow, q4 = int(row.full[0] % 2), float(row.q4[0])
        _, c, s, v = candidates(ctx, row)
        roots = np.sort(np.arctan2(s[v], c[v]))
        if roots.size == 0:
            if feasible_rows(ctx, row, np.ones((1, 1)), np.zeros((1, 1)))[0, 0]:
                out.append(SwivelInterval(elbow, q4, -math.pi, math.pi))
            continue
        ends = np.append(roots[1:], roots[0] + TWO_PI)
        mids = 0.5 * (roots + ends)
        f = feasible_rows(ctx, row, np.cos(mids)[None], np.sin(mids)[None])[0]
        if f.all():
            out.append(SwivelInterval(elbow, q4, -math.pi, math.pi))
            continue
        out += [SwivelInterval(elbow, q4, a, b) for a, b in _runs(roots, ends, f)]
    return sorted(out, key=lambda iv: (iv.elbow, iv.start))


def _runs(roots: NDArray, ends: NDArray, f: NDArray[np.bool_]) -> list[tuple[float, float]]:
    """Runs of feasible arcs ``[roots[i], ends[i]]``, walking once round the circle from
    the first infeasible arc; each start moved into ``[-pi, pi]``."""
    K, i0 = f.size, int(np.flatnonzero(~f)[0])
    out = []
    run = None
    for j in range(1, K + 1):
        i = (i0 + j) % K
        wrap = TWO_PI if i0 + j >= K else 0.0
        if f[i]:
            run = (roots[i] + wrap if run is None else run[0], ends[i] + wrap)
        elif run is not None:
            shift = TWO_PI * math.floor((run[0] + math.pi) / TWO_PI)
            out.append((float(run[0] - shift), float(run[1] - shift)))
            run = None
    return out
