"""The swivel parametrisation: everything a target fixes, and what is linear in the swivel.

A target fixes the wrist point ``W = p - R_t d`` (``d`` the hand offset; for a position
target the end effector itself, the wrist held), hence ``t = W - S`` and by the law of
cosines the elbow ``q4 = alpha +- phi`` (:class:`~.geometry.Forearm`). What is left is
the swivel ``psi`` of the elbow about the unit line ``n = t / |t|``, measured in the
frame ``(n, r, k)`` with ``r`` the gravity direction made normal to ``n`` and
``k = n x r``.

For an elbow angle the arm at zero has its own frame ``(a, b, cv)``: ``a`` the unit
shoulder-to-forearm-point line, ``b`` the elbow's offset from it, ``cv = a x b``. The
shoulder rotation is ``R_sh(psi) = Rot(n, psi) R_ref`` with ``R_ref = [n r k][a b cv]'``,
and the wrist rotation ``R_w = R_el' R_sh' R_t R_ee0'``. So ``y = R u3`` and
``z = R' u1`` of each three-hinge joint (:class:`~.geometry.Triple`) are linear in
``(1, cos psi, sin psi)``; their five readings give 15 coefficients per joint, and from
them, at any swivel, both decompositions and the range tests (:func:`decompose`), and
the swivels where a hinge meets a range end (:func:`range_end_roots`, each
``k_c cos psi + k_s sin psi = d``).

Every function takes floats (one target) or arrays (a batch) with an arithmetic ``xp``
(:mod:`.numeric`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Literal, overload

from numpy.typing import ArrayLike

from humanoid_ik.core.chain import Chain
from humanoid_ik.solvers.analytic.closed_form.geometry import (
    ArmContext,
    Forearm,
    Gravity,
    Triple,
    arm_context,
    forearm,
)
from humanoid_ik.solvers.analytic.closed_form.numeric import (
    FLOATS,
    X_AXIS,
    Y_AXIS,
    Arithmetic,
    Real,
    Vec,
    cross,
    dot,
    into_range,
    perp_unit,
    proj,
    rot,
    sub,
    unit,
)

__all__ = [
    "Coefficients",
    "Decomposition",
    "wrist_target",
    "hand_forearm",
    "rest_direction",
    "elbow_branches",
    "swivel_frame",
    "shoulder_turn",
    "start_elbow",
    "start_swivel",
    "arm_frame",
    "limb_axes",
    "triple_target",
    "triple_coefficients",
    "hand_frames",
    "wrist_coefficients",
    "decompose",
    "feasible",
    "range_end_roots",
    "swivel_angle",
]

Coefficients = Any
"""15 numbers, ``(const, cos, sin)`` of ``y . e1``, ``y . e2``, ``C = y . u1``, ``z . f1``,
``z . f2`` of one joint (:class:`~.geometry.Triple`): a tuple of floats, or an array
whose first axis holds the 15."""

Decomposition = tuple[Real, ...]
"""``(C, decomposes, plus, minus)``: ``C = u1 . R u3``, whether the joint decomposes,
and per branch (``q2 = base +- delta``) the 7-tuple ``(x1, y1, c2, s2, x3, y3, inside)``
with ``q1 = atan2(y1, x1)``, ``q2 = atan2(s2, c2)``, ``q3 = atan2(y3, x3)`` and whether
all three lie inside their ranges. Plain tuples: one-target solves build many."""


# ------------------------------------------------------------------------------ the target
def wrist_target(ctx: ArmContext, p: Sequence[Real], R: Sequence[Sequence[Real]]) -> Vec:
    """``t = p - R_t d - S`` [m]: the wrist point a pose asks for, seen from the shoulder.

    Args:
        p: the target position.
        R: the target rotation's rows.
    """
    d0, d1, d2 = ctx.hand
    S = ctx.S
    return (
        p[0] - (R[0][0] * d0 + R[0][1] * d1 + R[0][2] * d2) - S[0],
        p[1] - (R[1][0] * d0 + R[1][1] * d1 + R[1][2] * d2) - S[1],
        p[2] - (R[2][0] * d0 + R[2][1] * d1 + R[2][2] * d2) - S[2],
    )


def hand_forearm(xp: Arithmetic, ctx: ArmContext, c: Vec, s: Vec) -> Forearm:
    """The :class:`Forearm` of the end effector with the wrist at angles ``q5..q7``:
    ``P = W0 + Rot(w1, q5) Rot(w2, q6) Rot(w3, q7) (p_ee0 - W0)`` (``c, s``: their
    cosines and sines)."""
    v = ctx.hand_rest
    for j in (2, 1, 0):
        v = rot(ctx.wrist_axes[j], c[j], s[j], v)
    W0 = ctx.W0
    return forearm(xp, ctx.S, ctx.E, ctx.ue, (W0[0] + v[0], W0[1] + v[1], W0[2] + v[2]))


def rest_direction(xp: Arithmetic, ctx: ArmContext, fa: Forearm) -> Vec:
    """Unit ``P(0) - S = Pc + Pa - S``: the arm's line at zero, which stands in for the
    target's direction when the target sits on the shoulder (world x if that vanishes)."""
    Pc, Pa, S = fa.Pc, fa.Pa, ctx.S
    d = (Pc[0] + Pa[0] - S[0], Pc[1] + Pa[1] - S[1], Pc[2] + Pa[2] - S[2])
    return unit(xp, d, X_AXIS)


def elbow_branches(xp: Arithmetic, ctx: ArmContext, fa: Forearm, cos_e: Real) -> tuple[Real, ...]:
    """Both elbow angles ``q4 = alpha +- acos(cos_e)`` [rad], each shifted by turns next to
    the middle of the elbow's range, and whether the two differ (``0 < phi < pi``).

    ``cos_e = (L2 - |t|^2) / den`` is clipped to ``[-1, 1]`` (a target beyond reach
    gives the stretched or folded arm).
    """
    phi = xp.acos(xp.clip(cos_e, -1.0, 1.0))
    plus = into_range(xp, fa.alpha + phi, ctx.elbow_center)
    minus = into_range(xp, fa.alpha - phi, ctx.elbow_center)
    return plus, minus, (phi > 1e-12) & (phi < math.pi - 1e-12)


def swivel_frame(
    xp: Arithmetic, ctx: Gravity, t: Vec, along: Vec | Callable[[], Vec]
) -> tuple[Vec, Vec, Vec]:
    """``(n, r, k)``: ``n = t / |t|`` (``along`` where ``t`` vanishes), ``r`` the unit
    part of gravity normal to ``n`` (world x, then y, where gravity is along ``n``),
    ``k = n x r``. The swivel ``psi = 0`` puts the elbow on the ``r`` side."""
    n = unit(xp, t, along)
    r = perp_unit(xp, ctx.down, n, lambda: (X_AXIS, Y_AXIS))
    k = (n[1] * r[2] - n[2] * r[1], n[2] * r[0] - n[0] * r[2], n[0] * r[1] - n[1] * r[0])
    return n, r, k


def shoulder_turn(axes: Sequence[Vec], c: Vec, s: Vec, v: Vec) -> Vec:
    """``Rot(u1, q1) Rot(u2, q2) Rot(u3, q3) v``: ``v`` carried by the shoulder hinges
    ``axes`` at angles whose cosines and sines are ``c, s``."""
    u1, u2, u3 = axes
    return rot(u1, c[0], s[0], rot(u2, c[1], s[1], rot(u3, c[2], s[2], v)))


def start_elbow(ctx: ArmContext, c: Vec, s: Vec) -> Vec:
    """``R_sh(q0) (E - S)``: the start's elbow seen from the shoulder (``c, s``: cosines
    and sines of the start's shoulder angles)."""
    return shoulder_turn(ctx.shoulder_axes, c, s, ctx.e_rest)


def start_swivel(xp: Arithmetic, e: Vec, r: Vec, k: Vec) -> tuple[Real, Real]:
    """``(cos, sin)`` of the swivel at which the elbow lies closest to ``e``: the angle of
    ``(e . r, e . k)`` (``(1, 0)`` where ``e`` lies along ``n``)."""
    x = e[0] * r[0] + e[1] * r[1] + e[2] * r[2]
    y = e[0] * k[0] + e[1] * k[1] + e[2] * k[2]
    norm = xp.sqrt(x * x + y * y)
    short = norm <= 1e-12
    if not xp.any(short):
        inv = 1.0 / norm
        return x * inv, y * inv
    inv = 1.0 / xp.where(short, 1.0, norm)
    return xp.where(short, 1.0, x * inv), xp.where(short, 0.0, y * inv)


# ------------------------------------------------------------------------------ an elbow branch
def arm_frame(
    xp: Arithmetic, ctx: ArmContext, fa: Forearm, n: Vec, ce: Real, se: Real
) -> tuple[Vec, Vec, Vec]:
    """:func:`limb_axes` of ``P(q4) - S`` at elbow ``(cos q4, sin q4) = (ce, se)``."""
    return limb_axes(xp, fa.at(ctx.S, ce, se), n, ctx.e_rest, ctx.ue)


def limb_axes(xp: Arithmetic, d: Vec, n: Vec, e_rest: Vec, ue: Vec) -> tuple[Vec, Vec, Vec]:
    """``(a, b, cv)`` of the limb ``d`` (the hand from the shoulder, shoulder at zero):
    ``a = unit(d)`` (``n`` if it vanishes), ``b`` the unit part of the elbow ``e_rest``
    normal to ``a`` (``a x u_e``, world x, then y, if that vanishes), ``cv = a x b``."""
    a = unit(xp, d, n)
    b = perp_unit(xp, e_rest, a, lambda: (cross(a, ue), X_AXIS, Y_AXIS))
    return a, b, cross(a, b)


def triple_target(tri: Triple, n: Vec, r: Vec, k: Vec) -> tuple[Real, ...]:
    """``n, r, k`` read with the triple's ``e1, e2, u1``: 9 numbers, per target."""
    return (*proj(tri.y_rows, n), *proj(tri.y_rows, r), *proj(tri.y_rows, k))


def triple_coefficients(
    tri: Triple, target: tuple[Real, ...], a: Vec, b: Vec, cv: Vec
) -> Coefficients:
    """The 15 twist-linear :data:`Coefficients` of a spherical triple of hinges (the
    shoulder's, or a two-link arm's three-hinge shoulder).

    With ``(al, be, ga) = (a, b, cv) . u3`` and ``(m1, m2, m3) = (n, r, k) . u1``:
    ``y = n al + r (be c - ga s) + k (ga c + be s)`` and
    ``z = a m1 + b (m2 c + m3 s) + cv (m3 c - m2 s)`` (``c, s = cos psi, sin psi``),
    read with ``e1, e2, u1`` and ``f1, f2``.

    Args:
        target: :func:`triple_target` of the target's frame.
    """
    ne1, ne2, m1, re1, re2, m2, ke1, ke2, m3 = target
    z_rows = tri.z_rows
    al, af1, af2 = proj(z_rows, a)
    be, bf1, bf2 = proj(z_rows, b)
    ga, cf1, cf2 = proj(z_rows, cv)
    return (
        *_linear(al, be, ga, ne1, re1, ke1),
        *_linear(al, be, ga, ne2, re2, ke2),
        *_linear(al, be, ga, m1, m2, m3),
        *_linear(af1, bf1, cf1, m1, m2, m3),
        *_linear(af2, bf2, cf2, m1, m2, m3),
    )


def _linear(x: Real, y: Real, z: Real, p: Real, q: Real, r: Real) -> tuple[Real, Real, Real]:
    """``(const, cos, sin)`` of ``x p + (y c - z s) q + (z c + y s) r``: one reading's
    three coefficients."""
    return x * p, y * q + z * r, y * r - z * q


def hand_frames(
    ctx: ArmContext, R: Sequence[Sequence[Real]], n: Vec, r: Vec, k: Vec
) -> tuple[Real, ...]:
    """The wrist's reading vectors carried to the target, in ``(n, r, k)``: 9 numbers,
    ``g = R_t R_ee0' u3``, ``R_t R_ee0' f1`` and ``R_t R_ee0' f2`` (``R``: the rows of
    the target rotation)."""
    nrk = (*n, *r, *k)
    rows = (*R[0], *R[1], *R[2])
    h = ctx.wr_hand
    return (
        *proj(nrk, proj(rows, (h[0], h[1], h[2]))),
        *proj(nrk, proj(rows, (h[3], h[4], h[5]))),
        *proj(nrk, proj(rows, (h[6], h[7], h[8]))),
    )


def wrist_coefficients(
    ctx: ArmContext, hand: tuple, ce: Real, se: Real, a: Vec, b: Vec, cv: Vec
) -> Coefficients:
    """The wrist's 15 :data:`Coefficients` at elbow ``(cos q4, sin q4) = (ce, se)``.

    ``y_w = R_el' (a G1 + b (G2 c + G3 s) + cv (G3 c - G2 s))`` read with the wrist's
    ``e1, e2, u1`` (so against ``Rot(u_e, q4)`` of them), and ``z_w . f = (n H1 +
    r (H2 c - H3 s) + k (H3 c + H2 s)) . (R_t R_ee0' f)`` with
    ``(H1, H2, H3) = (a, b, cv) . Rot(u_e, q4) u1``.

    Args:
        hand: :func:`hand_frames` of the target, ``(G1, G2, G3, F1.., F2..)``.
    """
    G1, G2, G3, nF1, rF1, kF1, nF2, rF2, kF2 = hand
    wr, ue = ctx.wr, ctx.ue
    rows = (*rot(ue, ce, se, wr.e1), *rot(ue, ce, se, wr.e2), *rot(ue, ce, se, wr.u1))
    aE1, aE2, H1 = proj(rows, a)
    bE1, bE2, H2 = proj(rows, b)
    cE1, cE2, H3 = proj(rows, cv)
    return (
        *_linear(aE1, bE1, cE1, G1, G2, G3),
        *_linear(aE2, bE2, cE2, G1, G2, G3),
        *_linear(H1, H2, H3, G1, G2, G3),
        *_linear(H1, H2, H3, nF1, rF1, kF1),
        *_linear(H1, H2, H3, nF2, rF2, kF2),
    )


# ------------------------------------------------------------------------------ at a swivel
@overload
def decompose(
    xp: Arithmetic, tri: Triple, k: Coefficients, c: Real, s: Real, lazy: Literal[False] = False
) -> Decomposition: ...


@overload
def decompose(
    xp: Arithmetic, tri: Triple, k: Coefficients, c: Real, s: Real, lazy: bool
) -> Decomposition | None: ...


def decompose(
    xp: Arithmetic, tri: Triple, k: Coefficients, c: Real, s: Real, lazy: bool = False
) -> Decomposition | None:
    """Both decompositions of a joint at swivel ``(c, s) = (cos psi, sin psi)``.

    ``cos(delta) = (C - dd) / K`` (the joint decomposes while it is within ``[-1, 1]``),
    ``sin(delta) = sqrt(1 - cos^2)`` (``|y|`` normal to ``u1`` for orthogonal axes,
    exact next to the outer axes' alignment); ``(cos q2, sin q2)`` turns ``base`` by
    ``+-delta``; ``q1 = angle(y) - angle(v)`` in ``(e1, e2)`` and
    ``q3 = angle(b) - angle(z)`` in ``(f1, f2)`` are read as the ``(x, y)`` of
    ``(y1 + i y2) conj(v1 + i v2)`` and ``(b1 + i b2) conj(z1 + i z2)``.

    Args:
        lazy: floats only: leave a branch (numbers ``None``, not inside) as soon as
            one of its hinges is outside its range, and return ``None`` when no branch
            is inside (the joint is not feasible at this swivel): most of the work at
            an infeasible swivel is skipped.

    Returns:
        A :data:`Decomposition`, every number of the shape of ``c * k[0]``, or ``None``.
    """
    y10, y1c, y1s, y20, y2c, y2s, c0, cc, cs, z10, z1c, z1s, z20, z2c, z2s = k
    stop = lazy
    C = c0 + cc * c + cs * s
    cd = (C - tri.dd) * tri.invK
    if tri.always:
        ok = True
    else:
        ok = (cd <= 1.0 + 1e-12) & (cd >= -1.0 - 1e-12)
        if stop and not ok:
            return None
    y1 = y10 + y1c * c + y1s * s
    y2 = y20 + y2c * c + y2s * s
    if tri.ortho:
        sd = xp.sqrt(y1 * y1 + y2 * y2)
    else:
        cd = xp.clip(cd, -1.0, 1.0)
        sd = xp.sqrt(1.0 - cd * cd)
    V01, Va1, Vb1, V02, Va2, Vb2 = tri.v
    in1, in2, in3 = tri.inside
    lim1, lim2, lim3 = tri.kind
    cb, sb = tri.cb, tri.sb
    z1 = z2 = None
    plus = minus = _LEFT
    for sign in (1.0, -1.0):
        cq = cb * cd - sign * sb * sd
        sq = sb * cd + sign * cb * sd
        inside = in2(cq, sq) if lim2 else True
        if stop and not inside:
            continue
        v1 = V01 + cq * Va1 + sq * Vb1
        v2 = V02 + cq * Va2 + sq * Vb2
        x1, w1 = y1 * v1 + y2 * v2, y2 * v1 - y1 * v2
        if lim1:
            inside = inside & in1(x1, w1)
            if stop and not inside:
                continue
        if z1 is None:
            z1 = z10 + z1c * c + z1s * s
            z2 = z20 + z2c * c + z2s * s
        B01, Ba1, Bb1, B02, Ba2, Bb2 = tri.b
        b1 = B01 + cq * Ba1 + sq * Bb1
        b2 = B02 + cq * Ba2 + sq * Bb2
        x3, w3 = b1 * z1 + b2 * z2, b2 * z1 - b1 * z2
        if lim3:
            inside = inside & in3(x3, w3)
            if stop and not inside:
                continue
        if sign > 0.0:
            plus = (x1, w1, cq, sq, x3, w3, inside)
        else:
            minus = (x1, w1, cq, sq, x3, w3, inside)
    if stop and plus is _LEFT and minus is _LEFT:
        return None
    return C, ok, plus, minus


_LEFT = (None, None, None, None, None, None, False)
"""A branch :func:`decompose` left: outside a range."""


def feasible(dec: Decomposition) -> Real:
    """Some branch of the joint lies inside its ranges (``decomposes & (in+ | in-)``)."""
    return dec[1] & (dec[2][6] | dec[3][6])


def range_end_roots(
    xp: Arithmetic, tri: Triple, k: Coefficients, cp: Real, sp: Real
) -> list[tuple[Real, Real, Real, Real]]:
    """The swivels where a hinge of the joint meets a range end (or the joint stops
    decomposing): per equation of :attr:`Triple.eqs`, ``k0 + kc cos + ks sin = rhs``,
    the two roots ``(kc d -+ ks q, ks d +- kc q) / rho^2`` with ``d = rhs - k0``,
    ``rho^2 = kc^2 + ks^2`` and ``q = sqrt(rho^2 - d^2)``.

    Args:
        cp, sp: ``cos, sin`` of the preferred swivel, to which the distance is taken.

    Returns:
        ``(1 - cos(psi - psi_pref), cos, sin, valid)`` per root (``valid``: the root
        exists), two per equation with a root somewhere; on floats every root
        returned is valid.
    """
    y10, y1c, y1s, y20, y2c, y2s, c0, cc, cs, z10, z1c, z1s, z20, z2c, z2s = k
    floats = xp.floats
    out = []
    for source, pa, pb, pc, rhs in tri.eqs:
        if source == 0:
            k0 = pa * y10 + pb * y20 + pc * c0
            kc = pa * y1c + pb * y2c + pc * cc
            ks = pa * y1s + pb * y2s + pc * cs
        elif source == 1:
            k0, kc, ks = c0, cc, cs
        else:
            k0 = pa * z10 + pb * z20 + pc * c0
            kc = pa * z1c + pb * z2c + pc * cc
            ks = pa * z1s + pb * z2s + pc * cs
        d = rhs - k0
        rho2 = kc * kc + ks * ks
        disc = rho2 - d * d
        if floats:
            if disc < 0.0 or rho2 <= 1e-24:  # no root
                continue
            valid, sq, inv = True, xp.sqrt(disc), 1.0 / rho2
        else:
            valid = (disc >= 0.0) & (rho2 > 1e-24)
            if not xp.any(valid):
                continue
            sq = xp.sqrt(xp.maximum(disc, 0.0))
            inv = 1.0 / xp.where(valid, rho2, 1.0)
        c1, s1 = (kc * d - ks * sq) * inv, (ks * d + kc * sq) * inv
        c2, s2 = (kc * d + ks * sq) * inv, (ks * d - kc * sq) * inv
        out.append((1.0 - (c1 * cp + s1 * sp), c1, s1, valid))
        out.append((1.0 - (c2 * cp + s2 * sp), c2, s2, valid))
    return out


# ------------------------------------------------------------------------------ a posture's swivel
def swivel_angle(chain: Chain, q: ArrayLike) -> float:
    """The swivel [rad] of posture ``q (7,)``: its elbow about its own shoulder-wrist line.

    ``e = R_sh(q) (E - S)`` and ``t = R_sh(q) (E - S + Rot(u_e, q4) (W0 - E))`` give the
    frame ``(n, r, k)`` of ``t`` (:func:`swivel_frame`) and ``psi = atan2(e . k, e . r)``.
    Solving the pose of ``q`` with this as the preferred swivel returns ``q``'s elbow
    position (and ``q`` itself when its branches are the ones closest to the start).

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: ``q`` is not 7 finite values.
    """
    ctx = arm_context(chain)
    q1, q2, q3, q4 = chain.check_q(q).tolist()[:4]
    c = (math.cos(q1), math.cos(q2), math.cos(q3))
    s = (math.sin(q1), math.sin(q2), math.sin(q3))
    e = start_elbow(ctx, c, s)
    fore = rot(ctx.ue, math.cos(q4), math.sin(q4), sub(ctx.W0, ctx.E))
    v = (ctx.e_rest[0] + fore[0], ctx.e_rest[1] + fore[1], ctx.e_rest[2] + fore[2])
    t = shoulder_turn(ctx.shoulder_axes, c, s, v)
    _, r, k = swivel_frame(FLOATS, ctx, t, X_AXIS)
    return math.atan2(dot(e, k), dot(e, r))
