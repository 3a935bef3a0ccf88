"""The shoulder's angles once the elbow is set, per shoulder kind, in closed form.

With the elbow at ``qe`` the limb is rigid and the hand sits at ``v = P(qe) - S`` from
the shoulder (shoulder at zero); the shoulder must turn ``v`` onto ``t = p_d - S``.

- **planar** (1 hinge, parallel to the elbow's): in the plane frame ``(x, y)`` of the
  upper arm at zero, the report's ``theta1 = theta_t1 -+ theta_t2`` with
  ``theta_t1 = atan2(t.y, t.x)`` and ``theta_t2 = acos((r^2 + l1^2 - l2^2) / (2 r l1))``
  (minus when the forearm turns positively about the shoulder axis), computed as the
  turn taking the hand onto the target.
- **two_hinge** (axes ``a1, a2`` meeting at ``S``): ``Rot(a1, q1) Rot(a2, q2) v = w``
  (``w`` the target's direction at ``|v|``) needs ``c = Rot(a2, q2) v = Rot(a1, -q1) w``,
  so ``a1.c = a1.w = p`` and ``a2.c = a2.v = m``: ``c = al a1 + be a2 +- g (a1 x a2)``
  with ``al = (p - d m) / s2``, ``be = (m - d p) / s2`` (``d = a1.a2``, ``s2 = 1 - d^2``)
  and ``g^2 = (|v|^2 - al^2 - be^2 - 2 al be d) / s2``; then ``q2`` turns ``v`` onto
  ``c`` about ``a2`` and ``q1`` turns ``c`` onto ``w`` about ``a1``. Two solutions,
  one on the band's edge (``g = 0``), none beyond it (``g^2 < 0``).
- **three_hinge**: ``R(psi) = Rot(n, psi) R_ref`` for every twist ``psi`` about
  ``n = t / |t|`` (``R_ref = [n r k][a b cv]'``: ``a`` the unit limb, ``b`` the elbow's
  offset from it, ``r`` gravity normal to ``n``); each hinge is linear in
  ``(cos psi, sin psi)`` and meets a range end where ``k_c cos psi + k_s sin psi = d``
  (the closed form's :class:`~humanoid_ik.solvers.analytic.closed_form.geometry.Triple`).
  The twist kept is the preferred one when every hinge is inside there, else the
  nearest range-end root at which one is; it is decomposed onto the three axes.

Everything here is Python floats (a numpy call costs about a microsecond).
"""

from __future__ import annotations

import math
from operator import itemgetter
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from humanoid_ik.core.rotations import wrap_angle
from humanoid_ik.solvers.analytic.closed_form.geometry import Triple
from humanoid_ik.solvers.analytic.closed_form.joints import (
    GIMBAL,
    branch_angles,
    gimbal_angles,
    shoulder_rotation,
)
from humanoid_ik.solvers.analytic.closed_form.numeric import (
    FLOATS,
    RANGE_TOL,
    TWO_PI,
    X_AXIS,
    Vec,
    cross,
    dot,
    rot,
    unit,
)
from humanoid_ik.solvers.analytic.closed_form.swivel import (
    decompose,
    limb_axes,
    range_end_roots,
    swivel_frame,
    triple_coefficients,
    triple_target,
)
from humanoid_ik.solvers.analytic.two_link.geometry import Limb, LimbContext, law_of_cosines, place

__all__ = [
    "Candidate",
    "elbow_branches",
    "hand",
    "planar",
    "two_hinge",
    "three_hinge",
    "twist_frame",
    "between",
    "Polar",
    "AngleAxis",
    "polar_method",
    "polar_angles",
    "angle_axis_method",
]

_EDGE = 1e-12  # relative g^2 (two-hinge) below which a target sits on the band's edge


class Candidate(NamedTuple):
    """One shoulder + elbow solution (before the riding joints are added)."""

    q: tuple[float, ...]
    """Shoulder and elbow angles ``(k + 1,)`` [rad], each shifted by turns into its
    range where it fits."""
    inside: bool
    """Every angle inside its range (1e-9 rad slack)."""
    violation: float
    """Sum of the range violations [rad] (0 inside)."""
    elbow: str
    """``negative`` (``qe = alpha + phi``, ``theta2 = phi - pi``), ``positive``
    (``qe = alpha - phi``) or ``both`` (straight or folded: the two meet)."""
    shoulder: str
    """Two- and three-hinge shoulders: ``plus`` or ``minus`` (``+-g`` for two hinges;
    ``q2 = base +- delta`` of the decomposition for three), ``both`` where they meet;
    ``""`` for a planar arm."""
    twist: float | None
    """Three-hinge shoulder: the twist [rad] about the shoulder-target line (0: the
    elbow on the gravity side), else ``None``."""
    gap: float
    """Two-hinge shoulder: how far [m] the hand stays from the target's direction
    because the target lies outside the shoulder's band (0 when inside)."""


def _make(ctx: LimbContext, q: list[float], q0: list[float], *labels: Any) -> Candidate:
    """A :class:`Candidate` of angles ``q`` placed into the ranges (an angle within the
    1e-9 rad slack of a range end is set on it; the violation counts beyond the slack)."""
    lo, hi = ctx.lower, ctx.upper
    for j, x in enumerate(q):
        if not (lo[j] <= x <= hi[j] and hi[j] - lo[j] < TWO_PI):
            break
    else:  # all inside ranges narrower than a turn (the usual case): nothing to shift
        return Candidate(tuple(q), True, 0.0, *labels)
    out, viol = [], 0.0
    for j, x in enumerate(q):
        y = place(x, lo[j], hi[j], q0[j])
        if y < lo[j]:
            viol += max(lo[j] - y - RANGE_TOL, 0.0)
            y = lo[j] if y >= lo[j] - RANGE_TOL else y
        elif y > hi[j]:
            viol += max(y - hi[j] - RANGE_TOL, 0.0)
            y = hi[j] if y <= hi[j] + RANGE_TOL else y
        out.append(y)
    return Candidate(tuple(out), viol == 0.0, viol, *labels)


def elbow_branches(ctx: LimbContext, limb: Limb, cos_e: float, q0: list[float]) -> list:
    """``[(qe, label, theta2)]``: ``qe = alpha +- phi`` with ``phi = acos(cos_e)`` (clipped
    to [-1, 1]: beyond reach the limb is straight or folded), each placed into the
    elbow's range; ``theta2 = qe - (alpha + pi)`` wrapped, the turn from the straight
    limb (``phi - pi`` for ``negative``, the worksheet's ``theta2z``)."""
    phi = math.acos(max(-1.0, min(1.0, cos_e)))
    k, alpha = ctx.k, float(limb.fa.alpha)
    lo, hi = ctx.lower[k], ctx.upper[k]
    pairs: tuple[tuple[float, str, float], ...]
    if 1e-12 < phi < math.pi - 1e-12:
        pairs = ((alpha + phi, "negative", phi - math.pi), (alpha - phi, "positive", math.pi - phi))
    else:
        pairs = ((alpha + phi, "both", wrap_angle(phi - math.pi)),)
    return [(place(qe, lo, hi, q0[k]), label, t2) for qe, label, t2 in pairs]


def hand(limb: Limb, qe: float) -> Vec:
    """``P(qe) - S``: the hand seen from the shoulder, shoulder at zero."""
    return limb.fa.at(limb.S, math.cos(qe), math.sin(qe))


# ------------------------------------------------------------------------------ planar
def planar(
    ctx: LimbContext, limb: Limb, t: Vec, q0: list[float], elbows: list
) -> tuple[list[Candidate], dict[str, Any]]:
    """Planar arm: the report's ``theta1 = theta_t1 -+ theta_t2`` per elbow branch.

    ``t`` is split along the shoulder axis ``a`` (``off_plane = |a . t|``, which no
    joint changes) and in the plane (``t_p``, ``r = |t_p|``). ``theta_t1`` and
    ``theta_t2`` are reported; the angle itself is computed as the turn about ``a``
    taking the hand ``v = P(qe) - S`` onto ``t_p``, ``atan2(a . (v x t_p), v . t_p)``
    (the same value, and exact where the limb is straight or folded, where ``acos``
    loses half the digits). Where ``r`` vanishes the shoulder angle is free and keeps
    the start's.

    Returns:
        The candidates, and ``theta_t1``, ``theta_t2``, ``off_plane`` [m], ``r`` [m].
    """
    a = ctx.axes[0]
    z = dot(a, t)
    tp = (t[0] - z * a[0], t[1] - z * a[1], t[2] - z * a[2])
    r = math.sqrt(dot(tp, tp))
    (x, y), sh = limb.frame, limb.shell
    t1 = t2 = 0.0
    if r > 1e-12:
        t1 = math.atan2(dot(tp, y), dot(tp, x))
        t2 = law_of_cosines(r, sh.l1, sh.l2)
    out = []
    for qe, label, _ in elbows:
        q1 = q0[0]
        if r > 1e-12:
            v = hand(limb, qe)
            q1 = math.atan2(dot(a, cross(v, tp)), dot(v, tp))
        out.append(_make(ctx, [q1, qe], q0, label, "", None, 0.0))
    return out, {"theta_t1": t1, "theta_t2": t2, "off_plane": abs(z), "r": r}


# ------------------------------------------------------------------------------ two hinges
def two_hinge(
    ctx: LimbContext, limb: Limb, t: Vec, q0: list[float], elbows: list
) -> tuple[list[Candidate], dict[str, Any]]:
    """Two-hinge shoulder: ``c = al a1 + be a2 +- g n`` (``n = a1 x a2``) per elbow
    branch (see the module's docstring), then
    ``q2 = atan2(a2 . (v x c), v . c - m^2)`` and ``q1 = atan2(a1 . (c x w), c . w - p^2)``,
    expanded on ``a1, a2, n`` (``a1 x n = d a1 - a2``) so that each sign costs a few
    products. A limb along ``a2`` (or a target along ``a1``) leaves ``q2`` (``q1``) free:
    it keeps the start's.

    The target's direction is reached exactly when its angle ``theta_t`` to ``a1``
    lies in the band ``[|eps - theta_v|, min(eps + theta_v, 2 pi - eps - theta_v)]``
    (``eps`` the angle between the axes, ``theta_v`` between ``a2`` and ``v``). Outside
    it the limb is turned to the band's nearer edge (``c = m a2 +- rho e`` in the plane
    of the axes, ``e`` the unit part of ``a1`` normal to ``a2``, ``rho`` that of ``v``)
    and the candidate's ``gap`` is the chord ``2 |t| sin(dtheta / 2)`` left.

    Returns:
        The candidates, and ``theta_t`` [rad], ``epsilon`` [rad] and ``bands`` (per
        elbow label, ``(low, high)`` [rad]).
    """
    a1, a2 = ctx.axes
    d = dot(a1, a2)
    s2 = 1.0 - d * d
    n = cross(a1, a2)
    eps = math.acos(max(-1.0, min(1.0, d)))
    rt = math.sqrt(dot(t, t))
    # the target's direction read on a1, a2, n (w = |v| th)
    th = (t[0] / rt, t[1] / rt, t[2] / rt) if rt > 1e-12 else None
    out: list[Candidate] = []
    bands: dict[str, tuple[float, float]] = {}
    theta_t = 0.0
    for qe, label, _ in elbows:
        v = hand(limb, qe)
        vv = dot(v, v)
        nv = math.sqrt(vv)
        u = th if th is not None else (v[0] / nv, v[1] / nv, v[2] / nv)
        p, wa2, wn = nv * dot(a1, u), nv * dot(a2, u), nv * dot(n, u)
        m, x1, xn = dot(a2, v), dot(a1, v), dot(n, v)
        a2v = cross(a2, v)
        y1, yn = dot(a1, a2v), dot(n, a2v)
        theta_t = math.acos(max(-1.0, min(1.0, p / nv)))
        theta_v = math.acos(max(-1.0, min(1.0, m / nv)))
        low, high = abs(eps - theta_v), min(eps + theta_v, 2.0 * math.pi - eps - theta_v)
        bands[label] = (low, high)
        q2_free = vv - m * m <= 1e-24 * vv
        q1_free = vv - p * p <= 1e-24 * vv
        al, be = (p - d * m) / s2, (m - d * p) / s2
        g2 = (vv - al * al - be * be - 2.0 * al * be * d) / s2
        if g2 >= -_EDGE * vv:
            g = math.sqrt(max(g2, 0.0))
            signs = ((g, "plus"), (-g, "minus")) if g > 1e-9 * nv else ((0.0, "both"),)
            for sg, tag in signs:
                # c . v, a2 . (v x c) = c . (a2 x v); c . w, a1 . (c x w) = w . (a1 x c)
                q2 = (
                    q0[1]
                    if q2_free
                    else math.atan2(al * y1 + sg * yn, al * x1 + be * m + sg * xn - m * m)
                )
                cw = al * p + be * wa2 + sg * wn
                q1 = q0[0] if q1_free else math.atan2(be * wn + sg * (d * p - wa2), cw - p * p)
                out.append(_make(ctx, [q1, q2, qe], q0, label, tag, None, 0.0))
            continue
        # beyond the band: c on the a2-cone in the plane of the axes, on the nearer side
        sgn = 1.0 if p > d * m else -1.0
        rho = math.sqrt(max(vv - m * m, 0.0))
        k = sgn * rho / math.sqrt(s2)  # c = m a2 + k (a1 - d a2)
        al, be = k, m - k * d
        q2 = q0[1] if q2_free else math.atan2(al * y1, al * x1 + be * m - m * m)
        cw = al * p + be * wa2
        cw1 = al + be * d  # a1 . c
        q1 = q0[0] if q1_free else math.atan2(be * wn, cw - cw1 * p)
        miss = min(abs(theta_t - low), abs(theta_t - high))
        gap = 2.0 * rt * math.sin(0.5 * miss)
        out.append(_make(ctx, [q1, q2, qe], q0, label, "both", None, gap))
    return out, {"theta_t": theta_t, "epsilon": eps, "bands": bands}


# ------------------------------------------------------------------------------ three hinges
def between(r: Vec, e: Vec) -> tuple[float, Vec]:
    """The lecture's angle/axis rotation turning ``r`` toward ``r + e``:
    ``phi = atan2(|r x e|, r.r + r.e)``, ``u = (r x e) / |r x e|`` (any axis normal to
    ``r`` when they are parallel), as :func:`~humanoid_ik.core.rotations.rotation_between`
    on floats."""
    c = cross(r, e)
    nc = math.sqrt(dot(c, c))
    phi = math.atan2(nc, dot(r, r) + dot(r, e))
    if nc > 1e-12 * max(1.0, math.sqrt(dot(r, r) * dot(e, e))):
        return phi, (c[0] / nc, c[1] / nc, c[2] / nc)
    i = min(range(3), key=lambda j: abs(r[j]))
    u = cross(r, (1.0 if i == 0 else 0.0, 1.0 if i == 1 else 0.0, 1.0 if i == 2 else 0.0))
    nu = math.sqrt(dot(u, u))
    return phi, (u[0] / nu, u[1] / nu, u[2] / nu)


class Polar(NamedTuple):
    """The worksheet's polar-coordinate method for a three-hinge shoulder (step 2)."""

    theta1z: float
    """Step 2a: the angle [rad] of the smallest rotation taking the limb onto world x."""
    align_axis: Vec
    """Its unit axis (``+z`` for the worksheet's limb in the xy plane)."""
    beta: float
    """Step 2b: the heading [rad], ``atan2(-t_z, t_x)`` (about y)."""
    gamma: float
    """Step 2b: the elevation [rad], ``asin(t_y / |t|)`` (about z)."""


class AngleAxis(NamedTuple):
    """The worksheet's angle/axis method for a three-hinge shoulder (step 2)."""

    phi: float
    """The angle [rad] turning the limb ``r0`` toward the target: ``atan2(|r0 x e0|,
    r0.r0 + r0.e0)``."""
    axis: Vec
    """Its unit axis ``r0 x e0 / |r0 x e0|``."""


def polar_method(v: Vec, t: Vec) -> Polar:
    """The worksheet's polar-coordinate method: ``(theta1z, align axis, beta, gamma)``.

    Step 2a: ``theta1z = atan2(|v x x|, v . x)``, the angle of the smallest rotation
    taking the limb ``v`` onto the world x axis, about ``v x x / |v x x|`` (``+z`` in the
    worksheet; any axis normal to ``v`` when ``v`` lies along x); step 2b: heading
    ``beta = atan2(-t_z, t_x)``, elevation ``gamma = asin(t_y / |t|)``, so that
    ``Ry(beta) Rz(gamma) Rot(axis, theta1z) v`` points along ``t``.
    """
    s = math.hypot(v[1], v[2])  # |v x x|, v x x = (0, v_z, -v_y)
    if s > 1e-12 * math.sqrt(dot(v, v)):
        theta, u = math.atan2(s, v[0]), (0.0, v[2] / s, -v[1] / s)
    else:
        nv = math.sqrt(dot(v, v))
        theta, u = between(v, (nv - v[0], -v[1], -v[2]))
    rt = math.sqrt(dot(t, t))
    beta = math.atan2(-t[2], t[0])
    gamma = math.asin(max(-1.0, min(1.0, t[1] / rt))) if rt > 0.0 else 0.0
    return Polar(theta, u, beta, gamma)


def polar_angles(v0: ArrayLike, t: ArrayLike) -> tuple[float, float, float]:
    """The polar-coordinate method: ``(theta_align, beta, gamma)`` of
    :func:`polar_method` for arrays (the limb ``v0 (3,)`` and the target ``t (3,)`` seen
    from the shoulder), so that ``Ry(beta) Rz(gamma) R_align v0`` is parallel to ``t``."""
    a = np.asarray(v0, dtype=np.float64).tolist()
    b = np.asarray(t, dtype=np.float64).tolist()
    theta, _, beta, gamma = polar_method((a[0], a[1], a[2]), (b[0], b[1], b[2]))
    return theta, beta, gamma


def angle_axis_method(v: Vec, t: Vec) -> AngleAxis:
    """The worksheet's angle/axis method (CCD with nudge 1, shoulder reset first):
    ``r0 = v``, ``e0 = t - v``, ``phi = atan2(|r0 x e0|, r0.r0 + r0.e0)``,
    ``u = r0 x e0 / |r0 x e0|`` (:func:`between`; here ``r0 x e0 = v x t`` and
    ``r0.r0 + r0.e0 = v . t``)."""
    c = cross(v, t)
    nc = math.sqrt(dot(c, c))
    if nc > 1e-12 * max(1.0, math.sqrt(dot(v, v) * dot(t, t))):
        return AngleAxis(math.atan2(nc, dot(v, t)), (c[0] / nc, c[1] / nc, c[2] / nc))
    return AngleAxis(*between(v, (t[0] - v[0], t[1] - v[1], t[2] - v[2])))


def _method_twist(method: str, v: Vec, t: Vec, b: Vec, r: Vec, k: Vec) -> tuple[float, float]:
    """``(cos, sin)`` of the twist of the worksheet method's shoulder rotation ``R_m``
    (which points ``v`` along ``t``): the angle of ``R_m b`` in ``(r, k)``."""
    if method == "polar":
        theta, u, beta, gamma = polar_method(v, t)
        x = rot(u, math.cos(theta), math.sin(theta), b)
        x = rot((0.0, 0.0, 1.0), math.cos(gamma), math.sin(gamma), x)
        x = rot((0.0, 1.0, 0.0), math.cos(beta), math.sin(beta), x)
    else:
        phi, u = angle_axis_method(v, t)
        x = rot(u, math.cos(phi), math.sin(phi), b)
    return _direction(dot(x, r), dot(x, k))


def _direction(x: float, y: float) -> tuple[float, float]:
    """``(cos, sin)`` of the angle of ``(x, y)``; ``(1, 0)`` where it vanishes."""
    n = math.hypot(x, y)
    return (x / n, y / n) if n > 1e-12 else (1.0, 0.0)


_first = itemgetter(0)


def _twist(tri: Triple, ksh: tuple, cp: float, sp: float, lazy: bool) -> tuple | None:
    """``(cos, sin, decomposition)`` at the twist nearest ``(cp, sp)`` where the three
    hinges are inside their ranges (``lazy``: :func:`decompose` stops at a hinge outside)
    or, not ``lazy``, where the joint decomposes (ranges aside): the preferred twist,
    else the range-end roots nearest first (the ends of the feasible arcs are among
    them); ``None`` when no twist does."""
    dec = decompose(FLOATS, tri, ksh, cp, sp, lazy)
    if dec is not None and dec[1]:
        return cp, sp, dec
    for _, c, s, _ in sorted(range_end_roots(FLOATS, tri, ksh, cp, sp), key=_first):
        dec = decompose(FLOATS, tri, ksh, c, s, lazy)
        if dec is not None and dec[1]:
            return c, s, dec
    return None


def twist_frame(ctx: LimbContext, limb: Limb, t: Vec) -> tuple[Vec, Vec, Vec]:
    """``(n, r, k)``: the unit shoulder-target line ``n``, gravity normal to it ``r``
    (the twist's zero) and ``k = n x r``; a twist ``psi`` puts the elbow at the angle
    ``psi`` from ``r`` about ``n``."""
    return swivel_frame(FLOATS, ctx, t, lambda: unit(FLOATS, hand(limb, 0.0), X_AXIS))


def three_hinge(
    ctx: LimbContext,
    limb: Limb,
    t: Vec,
    q0: list[float],
    elbows: list,
    method: str,
    every_branch: bool = False,
    prefer: float | None = None,
) -> tuple[list[Candidate], dict[str, Any]]:
    """Three-hinge shoulder: per elbow branch, the feasible twist nearest the preferred
    one (see the module's docstring) and its decomposition(s).

    The preferred twist: ``prefer`` when given (an elbow pole's); else ``nearest``
    keeps the elbow closest to the start's elbow (``psi = atan2(e . k, e . r)``,
    ``e = R_sh(q0) (E - S)``); ``polar`` and ``angle_axis`` take the worksheet
    method's rotation. With no feasible twist the preferred one is decomposed anyway
    (the candidates are outside the ranges).

    Args:
        every_branch: both decompositions at the kept twist (else the one inside
            closest to the start).
        prefer: the preferred twist [rad], or ``None``.

    Returns:
        The candidates, and per elbow label ``twist_preferred`` [rad] and ``hands``
        (``v`` [m]).
    """
    tri = ctx.tri
    assert tri is not None
    n, r, k = twist_frame(ctx, limb, t)
    nrk = triple_target(tri, n, r, k)
    e0 = ctx.start_elbow(q0) if method == "nearest" and prefer is None else None
    out: list[Candidate] = []
    preferred: dict[str, float] = {}
    hands: dict[str, Vec] = {}
    for qe, label, _ in elbows:
        v = hands[label] = hand(limb, qe)
        a, b, cv = limb_axes(FLOATS, v, n, ctx.e_rest, ctx.ue)
        ksh = triple_coefficients(tri, nrk, a, b, cv)
        if prefer is not None:
            cp, sp = math.cos(prefer), math.sin(prefer)
        elif e0 is not None:
            cp, sp = _direction(dot(e0, r), dot(e0, k))
        else:
            cp, sp = _method_twist(method, v, t, b, r, k)
        preferred[label] = math.atan2(sp, cp)
        found = _twist(tri, ksh, cp, sp, lazy=True)
        if found is not None and every_branch:  # both decompositions, not the inside one
            found = (found[0], found[1], decompose(FLOATS, tri, ksh, found[0], found[1]))
        found = found or _twist(tri, ksh, cp, sp, lazy=False)
        if found is None:
            continue
        c, s, dec = found
        twist = math.atan2(s, c)
        frame = (n, r, k, a, b, cv)
        for q3, tag in _shoulder_angles(ctx, dec, frame, c, s, q0, every_branch):
            out.append(_make(ctx, [*q3, qe], q0, label, tag, twist, 0.0))
    return out, {"twist_preferred": preferred, "hands": hands}


def _shoulder_angles(
    ctx: LimbContext,
    dec: tuple,
    frame: tuple,
    c: float,
    s: float,
    q0: list[float],
    every_branch: bool,
) -> list[tuple[tuple[float, float, float], str]]:
    """The decomposition's branches as angles with their labels: every branch that
    exists (``every_branch``), else the one inside the ranges closest to ``q0``, else
    the least violating. Near the gimbal lock (``1 - C^2 < GIMBAL``) the angles are read
    from the explicit rotation (the closed form's ``gimbal_angles``)."""
    tri = ctx.tri
    assert tri is not None
    pref = (q0[0], q0[1], q0[2])
    present = [(b, tag) for b, tag in ((dec[2], "plus"), (dec[3], "minus")) if b[0] is not None]
    if 1.0 - dec[0] * dec[0] < GIMBAL:
        R = shoulder_rotation(np.array(frame), c, s)
        pairs = [(math.atan2(b[3], b[2]), math.atan2(b[1], b[0])) for b, _ in present]
        got = gimbal_angles(tri, R, pairs, np.array(pref))
        if got is None:
            return []
        q = got[0].tolist()
        return [((q[0], q[1], q[2]), "both")]
    scored = []
    for b, tag in present:
        (x1, x2, x3), viol, _ = branch_angles(FLOATS, tri, b, True, pref)
        dist = (x1 - pref[0]) ** 2 + (x2 - pref[1]) ** 2 + (x3 - pref[2]) ** 2
        scored.append((viol > RANGE_TOL, viol, dist, (x1, x2, x3), tag))
    if every_branch:
        return [(x[3], x[4]) for x in scored]
    best = min(scored, key=lambda x: x[:3])
    return [(best[3], best[4])]
