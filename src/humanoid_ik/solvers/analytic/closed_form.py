"""Closed-form IK of a 7-hinge arm: spherical shoulder, elbow, spherical wrist.

The method of Tolani, Goswami and Badler (2000) for anthropomorphic limbs, on the
model's own hinge axes. A hand pose fixes the wrist point ``W``; the distance from the
shoulder ``S`` to ``W`` fixes the elbow by the law of cosines (two branches); what is
left is the *swivel* ``psi`` of the elbow about the line ``S -> W``. For each swivel the
shoulder rotation is ``R_sh(psi) = Rot(n, psi) R_ref`` (``n`` the unit ``S -> W``) and
the wrist rotation follows from the hand orientation; each is decomposed onto its three
hinge axes (two branches each, so up to eight joint vectors per swivel).

Every geometric quantity is read from MuJoCo at the zero configuration: the point where
the three shoulder axes meet, the elbow anchor and axis, the point where the three
wrist axes meet, and the hand's offset from it. The joint ranges are exact in the
swivel: ``R_sh(psi)`` and the wrist rotation are linear in ``(cos psi, sin psi)``, and a
hinge of a three-axis joint stands at a range end ``L`` exactly when a linear form of
the rotation meets a constant (for ``R = Rot(u1, q1) Rot(u2, q2) Rot(u3, q3)``:
``q1 = L`` iff ``(Rot(u1, L) u2) . R u3 = u2 . u3``; ``q2 = L`` iff
``u1 . R u3 = u1 . Rot(u2, L) u3``; ``q3 = L`` iff ``u1 . R Rot(u3, -L) u2 = u1 . u2``).
Each is ``k_c cos psi + k_s sin psi = d``, with at most two roots, so the feasible
swivel set is bounded by at most 24 roots per elbow branch (plus, for three-axis
joints that cannot reach every rotation, the swivels where the middle angle meets the
end of its reach). The solver returns the feasible swivel closest to a preferred one:
the preferred swivel itself when feasible, otherwise the nearest feasible root.

Swivel convention: ``psi = 0`` puts the elbow on the side of the ``S -> W`` line that
faces the model's gravity (straight down for ``gravity = 0 0 -9.81``; world ``-z`` when
gravity is zero; world ``x`` when the line is vertical); ``psi`` turns the elbow
right-handed about ``S -> W``. By default the preferred swivel is the current elbow's:
the swivel at which the elbow lies closest to where it is at the starting posture.

Position-only targets: the wrist keeps its starting angles, so the hand is a rigid
extension of the forearm; the same closed form then solves the shoulder and elbow for
the end effector's position (the swivel turns about ``S -> target``).
"""

from __future__ import annotations

import math
import weakref
from typing import Any, ClassVar, NamedTuple

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError, TargetError
from humanoid_ik.solvers.analytic.two_link import _meeting_point
from humanoid_ik.solvers.base import Solver

__all__ = [
    "ClosedForm",
    "ArmGeometry",
    "Branch",
    "SwivelInterval",
    "BatchSolution",
    "arm_geometry",
    "structure_problem",
    "solutions",
    "swivel_intervals",
    "solve_batch",
    "swivel_angle",
]

TWO_PI = 2.0 * math.pi
RANGE_TOL = 1e-9
"""Slack [rad] on the joint ranges when a swivel is tested (a range end is feasible)."""
_CHUNK = 2048


# ------------------------------------------------------------------------------ geometry
class _Triple:
    """Constants of a three-hinge joint whose axes ``u1, u2, u3`` (world, at zero) meet.

    ``R = Rot(u1, q1) Rot(u2, q2) Rot(u3, q3)`` is read back from ``y = R u3`` and
    ``z = R' u1``: ``C = u1 . y = d12 d23 + K cos(q2 - base)`` gives ``q2 = base +- delta``;
    ``q1`` turns ``v = Rot(u2, q2) u3`` onto ``y`` about ``u1``, and ``q3`` turns ``z``
    onto ``b = Rot(u2, -q2) u1`` about ``u3``. In the frames ``(e1, e2, u1)`` and
    ``(f1, f2, u3)`` these are differences of plane angles:
    ``q1 = angle(y1, y2) - angle(v1, v2)`` and ``q3 = angle(b1, b2) - angle(z1, z2)``.
    ``gy = [u1, e1, e2, ...]`` and ``gz = [f1, f2, ...]`` are the rows dotted with ``y``
    and ``z``; the rows after those belong to the range-end equations.
    """

    def __init__(self, axes: NDArray[np.float64], lower: NDArray, upper: NDArray):
        u1, u2, u3 = (a / np.linalg.norm(a) for a in axes)
        self.u1, self.u2, self.u3 = u1, u2, u3
        d12, d23, d13 = float(u1 @ u2), float(u2 @ u3), float(u1 @ u3)
        A = d13 - d12 * d23
        B = float(u1 @ np.cross(u2, u3))
        self.K = math.hypot(A, B)
        self.dd = d12 * d23
        base = math.atan2(B, A)
        self.cb, self.sb = math.cos(base), math.sin(base)
        e1 = u2 - d12 * u1
        e1 /= np.linalg.norm(e1)
        f1 = u2 - d23 * u3
        f1 /= np.linalg.norm(f1)
        self.e1, self.e2 = e1, np.cross(u1, e1)
        self.f1, self.f2 = f1, np.cross(u3, f1)
        # Rot(u2, q) u3 = v0 + cos q va + sin q vb; Rot(u2, -q) u1 = b0 + cos q ba + sin q bb
        v0, va, vb = d23 * u2, u3 - d23 * u2, np.cross(u2, u3)
        b0, ba, bb = d12 * u2, u1 - d12 * u2, np.cross(u1, u2)
        self.v = tuple(float(x @ e) for e in (self.e1, self.e2) for x in (v0, va, vb))
        self.b = tuple(float(x @ f) for f in (self.f1, self.f2) for x in (b0, ba, bb))
        self.lower = np.asarray(lower, dtype=np.float64)
        self.upper = np.asarray(upper, dtype=np.float64)
        # range tests: kind 0 always inside, 1 a sector of at most pi, 2 wider
        self.kind = np.zeros(3, dtype=np.int64)
        self.ends = np.zeros((3, 4))  # cos lo, sin lo, cos hi, sin hi (widened by the slack)
        self.center = np.zeros(3)
        for j in range(3):
            lo, hi = self.lower[j], self.upper[j]
            if not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo + 2 * RANGE_TOL >= TWO_PI:
                self.kind[j] = 0
                self.center[j] = 0.5 * (lo + hi) if np.isfinite(lo + hi) else 0.0
                continue
            self.kind[j] = 1 if hi - lo + 2 * RANGE_TOL <= math.pi else 2
            a, b = lo - RANGE_TOL, hi + RANGE_TOL
            self.ends[j] = (math.cos(a), math.sin(a), math.cos(b), math.sin(b))
            self.center[j] = 0.5 * (lo + hi)
        rows_y = [u1, self.e1, self.e2]
        rows_z = [self.f1, self.f2]
        # range-end equations: (source, row, rhs); source 0 reads y, 1 reads z
        eqs: list[tuple[int, int, float]] = []
        ends = [(j, L) for j in range(3) if self.kind[j] for L in (lower[j], upper[j])]
        for j, L in ends:
            if j == 0:  # (Rot(u1, L) u2) . y = u2 . u3
                rows_y.append(_rodrigues(u1, L) @ u2)
                eqs.append((0, len(rows_y) - 1, d23))
            elif j == 1:  # u1 . y = u1 . Rot(u2, L) u3
                eqs.append((0, 0, float(u1 @ _rodrigues(u2, L) @ u3)))
            else:  # (Rot(u3, -L) u2) . z = u1 . u2
                rows_z.append(_rodrigues(u3, -L) @ u2)
                eqs.append((1, len(rows_z) - 1, d12))
        # a joint that cannot reach every rotation: where q2 meets the end of its reach
        self.always = self.dd - self.K <= -1.0 + 1e-12 and self.dd + self.K >= 1.0 - 1e-12
        # u1 _|_ u2 _|_ u3: then C = cos(delta) and sin(delta) is the length of y normal to u1
        self.ortho = abs(d12) < 1e-12 and abs(d23) < 1e-12
        if not self.always:
            eqs += [(0, 0, self.dd + self.K), (0, 0, self.dd - self.K)]
        self.gy = np.array(rows_y)  # (Ry, 3)
        self.gz = np.array(rows_z)  # (Rz, 3)
        self.eq_src = np.array([e[0] for e in eqs], dtype=np.int64)
        self.eq_row = np.array([e[1] for e in eqs], dtype=np.int64)
        self.eq_rhs = np.array([e[2] for e in eqs], dtype=np.float64)


class ArmGeometry(NamedTuple):
    """What the closed form reads from MuJoCo, in the world frame at the zero configuration."""

    shoulder: NDArray[np.float64]
    """Point where the three shoulder axes meet ``(3,)`` [m]."""
    shoulder_axes: NDArray[np.float64]
    """Unit shoulder axes ``(3, 3)``, one per row, proximal first."""
    elbow: NDArray[np.float64]
    """Elbow anchor ``(3,)`` [m]."""
    elbow_axis: NDArray[np.float64]
    """Unit elbow axis ``(3,)``."""
    wrist: NDArray[np.float64]
    """Point where the three wrist axes meet ``(3,)`` [m]."""
    wrist_axes: NDArray[np.float64]
    """Unit wrist axes ``(3, 3)``, one per row, proximal first."""
    hand_offset: NDArray[np.float64]
    """End effector minus wrist point in the end-effector frame ``(3,)`` [m]."""
    R_ee0: NDArray[np.float64]
    """End-effector rotation ``(3, 3)`` at the zero configuration."""
    p_ee0: NDArray[np.float64]
    """End-effector position ``(3,)`` [m] at the zero configuration."""
    down: NDArray[np.float64]
    """Unit direction of gravity ``(3,)`` (the swivel's zero)."""


class _Context:
    """An :class:`ArmGeometry` and the constants derived from it, for one chain."""

    def __init__(self, geo: ArmGeometry, chain: Chain, watch: NDArray, snapshot: NDArray):
        self.geo = geo
        self.watch = watch
        self.snapshot = snapshot
        self.lower, self.upper = chain.lower.copy(), chain.upper.copy()
        self.sh = _Triple(geo.shoulder_axes, chain.lower[:3], chain.upper[:3])
        self.wr = _Triple(geo.wrist_axes, chain.lower[4:], chain.upper[4:])
        self.S, self.Ea, self.ue = geo.shoulder, geo.elbow, geo.elbow_axis
        self.W0 = geo.wrist
        self.elbow_lo, self.elbow_hi = float(chain.lower[3]), float(chain.upper[3])
        lo, hi = self.elbow_lo, self.elbow_hi
        self.elbow_center = 0.5 * (lo + hi) if np.isfinite(lo + hi) else 0.0
        self.shell = _shell(self.S, self.Ea, self.ue, self.W0[None])
        self.ke = _cross_matrix(self.ue)
        self.ke2 = self.ke @ self.ke
        self._scalar: _Scalar | None | bool = False

    @property
    def scalar(self) -> _Scalar | None:
        """Float constants for one-target solves (``None`` when a joint cannot reach every
        rotation: those chains take the vectorised path)."""
        if self._scalar is False:
            self._scalar = _Scalar(self) if self.sh.always and self.wr.always else None
        return self._scalar  # type: ignore[return-value]


_CACHE: weakref.WeakKeyDictionary[Chain, _Context] = weakref.WeakKeyDictionary()


def structure_problem(chain: Chain) -> str | None:
    """Why the chain is not a spherical shoulder + elbow + spherical wrist, or ``None``.

    The chain needs 7 hinges: the first three axes meet at one point, the last three
    meet at another, the fourth (the elbow) passes through neither, and each
    three-hinge group has three independent axes.
    """
    if chain.n != 7:
        return (
            f"closed_form needs 7 hinges (3 shoulder, elbow, 3 wrist); the chain has "
            f"{chain.n} joint(s)"
        )
    anchors, axes = _zero_axes(chain)
    S = _meeting_point(anchors[:3], axes[:3])
    if S is None:
        return "closed_form needs the first three hinge axes to meet at one point (a shoulder)"
    W = _meeting_point(anchors[4:], axes[4:])
    if W is None:
        return "closed_form needs the last three hinge axes to meet at one point (a wrist)"
    E, u = anchors[3], axes[3]
    for name, point in (("shoulder", S), ("wrist", W)):
        if float(np.linalg.norm(np.cross(point - E, u))) < 1e-9:
            return f"closed_form needs an elbow axis that does not pass through the {name} point"
    for name, ax in (("shoulder", axes[:3]), ("wrist", axes[4:])):
        if abs(float(ax[0] @ ax[1])) > 1 - 1e-9 or abs(float(ax[1] @ ax[2])) > 1 - 1e-9:
            return f"closed_form needs {name} axes whose neighbours are not parallel"
    return None


def arm_geometry(chain: Chain) -> ArmGeometry:
    """The chain's geometry as the closed form uses it (read once, then cached).

    Raises:
        SolverError: the chain has no spherical shoulder, elbow and spherical wrist.
    """
    return _context(chain).geo


def _context(chain: Chain) -> _Context:
    ctx = _CACHE.get(chain)
    if ctx is not None and (
        ctx.watch.size == 0 or np.array_equal(chain.data.qpos[ctx.watch], ctx.snapshot)
    ):
        return ctx
    reason = structure_problem(chain)
    if reason is not None:
        raise SolverError(reason)
    m, d = chain.model, chain.data
    q_keep = chain.q
    anchors, axes = _zero_axes(chain)
    chain.set_q(np.zeros(chain.n))
    p0, R0 = chain.position.copy(), chain.rotation.copy()
    chain.set_q(q_keep)
    S = _meeting_point(anchors[:3], axes[:3])
    W = _meeting_point(anchors[4:], axes[4:])
    assert S is not None and W is not None
    g = np.asarray(m.opt.gravity, dtype=np.float64)
    down = g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 0.0, -1.0])
    geo = ArmGeometry(
        shoulder=S,
        shoulder_axes=axes[:3].copy(),
        elbow=anchors[3].copy(),
        elbow_axis=axes[3].copy(),
        wrist=W,
        wrist_axes=axes[4:].copy(),
        hand_offset=R0.T @ (p0 - W),
        R_ee0=R0,
        p_ee0=p0,
        down=down,
    )
    # joints on the end effector's path that are not in the chain move the whole arm
    ee_body = int(m.site_bodyid[chain.ee_id]) if chain.ee_kind == "site" else chain.ee_id
    others = [j for j in chain._path_joints(ee_body) if j not in set(chain.joint_ids.tolist())]
    watch = np.concatenate(
        [np.arange(m.jnt_qposadr[j], m.jnt_qposadr[j] + _qpos_size(m, j)) for j in others]
        or [np.zeros(0, dtype=np.int64)]
    ).astype(np.int64)
    ctx = _Context(geo, chain, watch, d.qpos[watch].copy())
    _CACHE[chain] = ctx
    return ctx


def _qpos_size(m: mujoco.MjModel, j: int) -> int:
    return {0: 7, 1: 4}.get(int(m.jnt_type[j]), 1)


def _zero_axes(chain: Chain) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World anchors and axes of the chain's hinges with every chain joint at zero."""
    q_keep = chain.q
    chain.set_q(np.zeros(chain.n))
    anchors, axes = chain.joint_axes()
    chain.set_q(q_keep)
    return anchors, axes / np.linalg.norm(axes, axis=1, keepdims=True)


def _shell(S, Ea, ue, P):
    """Elbow geometry for forearm points ``P (N, 3)`` at zero: ``l1, l2, h, alpha``.

    ``|S - P(q)|^2 = l1^2 + l2^2 + h^2 - 2 l1 l2 cos(q - alpha)`` (as in ``two_link``).
    """
    a = S - Ea
    b0 = P - Ea
    au = float(a @ ue)
    bu = b0 @ ue
    ap = a - au * ue
    bp = b0 - bu[:, None] * ue
    A = bp @ ap
    B = np.cross(ue, bp) @ ap
    l1 = float(np.linalg.norm(ap))
    l2 = np.linalg.norm(bp, axis=1)
    return l1, l2, np.abs(au - bu), np.arctan2(B, A)


def _cross_matrix(u: NDArray) -> NDArray[np.float64]:
    return np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])


def _rodrigues(u: NDArray, angle: float) -> NDArray[np.float64]:
    K = _cross_matrix(u)
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def _rotate(u: NDArray, c: NDArray, s: NDArray, v: NDArray) -> NDArray[np.float64]:
    """``Rot(u, t) v`` for unit ``u (3,)``, ``cos t, sin t (N,)`` and ``v (N, 3)``."""
    par = (v @ u)[:, None] * u
    return par + c[:, None] * (v - par) + s[:, None] * np.cross(u, v)


def _unit(v: NDArray, fallback: NDArray, eps: float = 1e-12) -> NDArray[np.float64]:
    """Rows of ``v (N, 3)`` normalised; rows shorter than ``eps`` take ``fallback``'s."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    small = n < eps
    out = v / np.where(small, 1.0, n)
    return np.where(small, fallback, out) if np.any(small) else out


def _perp_unit(v: NDArray, n: NDArray, fallbacks: list[NDArray]) -> NDArray[np.float64]:
    """Unit component of ``v`` normal to unit ``n`` (rows); fallbacks where it vanishes.

    A short component is projected twice: once normalised it is normal to ``n`` to
    rounding, which keeps the frames built from it orthonormal.
    """
    out = v - np.sum(v * n, axis=-1, keepdims=True) * n
    norm = np.linalg.norm(out, axis=-1, keepdims=True)
    bad = norm[..., 0] < 1e-9
    out = out / np.where(bad[..., None], 1.0, norm)
    out = out - np.sum(out * n, axis=-1, keepdims=True) * n
    norm = np.linalg.norm(out, axis=-1, keepdims=True)
    out = out / np.where(norm > 0.0, norm, 1.0)
    for fb in fallbacks:
        if not np.any(bad):
            break
        alt = np.broadcast_to(fb, v.shape)
        alt = alt - np.sum(alt * n, axis=-1, keepdims=True) * n
        an = np.linalg.norm(alt, axis=-1, keepdims=True)
        ok = bad & (an[..., 0] >= 1e-9)
        out = np.where(ok[..., None], alt / np.where(an < 1e-12, 1.0, an), out)
        bad = bad & ~ok
    return out


# ------------------------------------------------------------------------------ the problem
class _Rows(NamedTuple):
    """One row per (target, elbow branch): everything linear in ``(1, cos psi, sin psi)``."""

    full: NDArray[np.int64]  # (M,) 2 * target + elbow branch
    target: NDArray[np.int64]  # (M,) index of the target
    q4: NDArray[np.float64]  # (M,) elbow angle [rad]
    usable: NDArray[np.bool_]  # (M,) elbow inside its range and branch not a duplicate
    sh_y: NDArray[np.float64]  # (3, Ry, M) coefficients of gy . y for the shoulder
    sh_z: NDArray[np.float64]  # (3, Rz, M)
    wr_y: NDArray[np.float64] | None  # wrist, None for position-only targets
    wr_z: NDArray[np.float64] | None
    cp: NDArray[np.float64]  # (M,) cos of the preferred swivel
    sp: NDArray[np.float64]  # (M,) sin of the preferred swivel


class _Setup(NamedTuple):
    rows: _Rows
    reach: NDArray[np.float64]  # (N,) distance [m] beyond the reachable shell (0 inside)
    inner: NDArray[np.bool_]  # (N,) the miss is inside the inner hole
    q_wrist: NDArray[np.float64] | None  # (N, 3) wrist angles for position-only targets
    n: NDArray[np.float64]  # (N, 3) unit shoulder-to-wrist direction
    shell: tuple[NDArray, NDArray]  # (N,) inner and outer radius [m] of the reachable shell
    R_ref: NDArray[np.float64]  # (M, 3, 3) shoulder rotation at swivel 0
    R_t: NDArray[np.float64] | None  # (N, 3, 3) target rotations
    q4: NDArray[np.float64]  # (N, 2) both elbow branches [rad]
    usable: NDArray[np.bool_]  # (N, 2) elbow inside its range, branch not a repeat
    elbow_key: NDArray[np.float64]  # (N, 2) range violation, then distance from the start


def _setup(
    ctx: _Context,
    positions: NDArray[np.float64],
    R_t: NDArray[np.float64] | None,
    q0: NDArray[np.float64],
    swivel: NDArray[np.float64] | None,
    keep: str = "best",
) -> _Setup:
    """Elbow branches, reference shoulder rotations and the swivel-linear coefficients.

    Rows are made for the elbow branches inside their range (``keep="best"``; a target
    with none keeps its least violating one) or for every distinct branch (``"all"``).

    Args:
        positions: end-effector targets ``(N, 3)`` [m].
        R_t: target rotations ``(N, 3, 3)``, or ``None`` (wrist kept at ``q0``).
        q0: starting postures ``(N, 7)`` [rad].
        swivel: preferred swivels ``(N,)`` [rad], or ``None`` for the starting elbow's.
    """
    g = ctx.geo
    N = positions.shape[0]
    S, Ea, ue = ctx.S, ctx.Ea, ctx.ue
    if R_t is not None:
        W = positions - R_t @ g.hand_offset  # (N, 3)
        P = np.broadcast_to(ctx.W0, (N, 3))
        l1, l2, h, alpha = ctx.shell
        q_wrist = None
    else:
        W = positions
        q_wrist = np.clip(q0[:, 4:], ctx.lower[4:], ctx.upper[4:])
        # the end effector with the wrist at its starting angles, shoulder and elbow at zero
        v = np.broadcast_to(g.p_ee0 - ctx.W0, (N, 3))
        for k in (2, 1, 0):
            v = _rotate(g.wrist_axes[k], np.cos(q_wrist[:, k]), np.sin(q_wrist[:, k]), v)
        P = ctx.W0 + v
        l1, l2, h, alpha = _shell(S, Ea, ue, P)
    t = W - S
    r = np.linalg.norm(t, axis=1)
    # the direction of the current arm stands in when the target sits on the shoulder
    n = _unit(t, _unit(P - S, np.array([1.0, 0.0, 0.0])))
    # elbow by the law of cosines
    num = l1 * l1 + l2 * l2 + h * h - r * r
    den = 2.0 * l1 * l2
    cos_e = num / np.where(den > 1e-300, den, 1e-300)
    r_min, r_max = np.hypot(l1 - l2, h), np.hypot(l1 + l2, h)
    reach = np.maximum(np.maximum(r - r_max, r_min - r), 0.0)
    reach = np.where(np.abs(cos_e) > 1.0, reach, 0.0)
    inner = r < r_min
    phi = np.arccos(np.clip(cos_e, -1.0, 1.0))
    q4 = np.stack([alpha + phi, alpha - phi], axis=1)  # (N, 2)
    q4 = _into_range(q4, ctx.elbow_lo, ctx.elbow_hi, ctx.elbow_center)
    distinct = np.ones((N, 2), dtype=bool)
    distinct[:, 1] = (phi > 1e-12) & (phi < math.pi - 1e-12)
    usable = (q4 >= ctx.elbow_lo - RANGE_TOL) & (q4 <= ctx.elbow_hi + RANGE_TOL) & distinct
    el_viol = np.maximum(ctx.elbow_lo - q4, 0.0) + np.maximum(q4 - ctx.elbow_hi, 0.0)
    el_key = el_viol * 1e3 + np.abs(q4 - q0[:, 3:4]) + np.where(distinct, 0.0, 1e9)
    if keep == "all":
        kept = distinct
    else:
        kept = usable | (
            ~usable.any(axis=1, keepdims=True)
            & (np.arange(2) == np.argmin(el_key, axis=1)[:, None])
        )
    full = np.flatnonzero(kept.reshape(2 * N))
    M = full.size
    target = full // 2
    q4f = q4.reshape(2 * N)[full]
    nn = n[target]
    # the forearm point with the elbow bent, shoulder at zero, and the arm's frame there
    ce, se = np.cos(q4f), np.sin(q4f)
    Pe = Ea + _rotate(ue, ce, se, (P - Ea)[target])
    a = _unit(Pe - S, nn)
    b = _perp_unit(
        np.broadcast_to(Ea - S, (M, 3)), a, [np.cross(a, ue), np.eye(3)[0], np.eye(3)[1]]
    )
    F0 = np.stack([a, b, np.cross(a, b)], axis=2)  # (M, 3, 3), columns
    ref = _perp_unit(np.broadcast_to(g.down, (N, 3)), n, [np.eye(3)[0], np.eye(3)[1]])
    rr = ref[target]
    Ft = np.stack([nn, rr, np.cross(nn, rr)], axis=2)
    R_ref = Ft @ F0.transpose(0, 2, 1)  # (M, 3, 3)
    # shoulder: y = Rot(n, psi) R_ref u3 ; z = R_ref' Rot(n, -psi) u1
    sh = ctx.sh
    gv = R_ref @ sh.u3
    y0 = nn * np.sum(nn * gv, axis=1, keepdims=True)
    ycoef = np.stack([y0, gv - y0, np.cross(nn, gv)], axis=1)  # (M, 3, 3)
    u1n = nn @ sh.u1
    zr = np.stack([nn * u1n[:, None], sh.u1 - nn * u1n[:, None], -np.cross(nn, sh.u1)], axis=1)
    zcoef = zr @ R_ref  # rows: R_ref' v  ==  v' R_ref
    sh_y = (ycoef @ sh.gy.T).transpose(1, 2, 0)  # (3, Ry, M)
    sh_z = (zcoef @ sh.gz.T).transpose(1, 2, 0)
    wr_y = wr_z = None
    if R_t is not None:
        wr = ctx.wr
        R_el = np.eye(3) + se[:, None, None] * ctx.ke + (1.0 - ce)[:, None, None] * ctx.ke2
        X = R_el.transpose(0, 2, 1) @ R_ref.transpose(0, 2, 1)  # (M, 3, 3)
        Y = (R_t @ g.R_ee0.T)[target]  # (M, 3, 3)
        # y = X Rot(n, -psi) Y u3 ; z = Y' Rot(n, psi) X' u1
        gw = Y @ wr.u3
        gn = np.sum(nn * gw, axis=1, keepdims=True)
        yr = np.stack([nn * gn, gw - nn * gn, -np.cross(nn, gw)], axis=1)  # (M, 3, 3)
        ycoef = yr @ X.transpose(0, 2, 1)
        hw = wr.u1 @ X  # X' u1 as rows
        hn = np.sum(nn * hw, axis=1, keepdims=True)
        zr = np.stack([nn * hn, hw - nn * hn, np.cross(nn, hw)], axis=1)
        zcoef = zr @ Y
        wr_y = (ycoef @ wr.gy.T).transpose(1, 2, 0)
        wr_z = (zcoef @ wr.gz.T).transpose(1, 2, 0)
    # the preferred swivel
    if swivel is None:
        e = np.broadcast_to(Ea - S, (N, 3))
        for k in (2, 1, 0):
            e = _rotate((sh.u1, sh.u2, sh.u3)[k], np.cos(q0[:, k]), np.sin(q0[:, k]), e)
        e = e - n * np.sum(e * n, axis=1, keepdims=True)
        x_, y_ = np.sum(e * ref, axis=1), np.sum(e * np.cross(n, ref), axis=1)
        norm = np.hypot(x_, y_)
        ok = norm > 1e-12
        cp = np.where(ok, x_ / np.where(ok, norm, 1.0), 1.0)
        sp = np.where(ok, y_ / np.where(ok, norm, 1.0), 0.0)
    else:
        cp, sp = np.cos(swivel), np.sin(swivel)
    rows = _Rows(
        full,
        target,
        q4f,
        usable.reshape(2 * N)[full],
        sh_y,
        sh_z,
        wr_y,
        wr_z,
        cp[target],
        sp[target],
    )
    shell = (np.broadcast_to(r_min, (N,)), np.broadcast_to(r_max, (N,)))
    return _Setup(rows, reach, inner, q_wrist, n, shell, R_ref, R_t, q4, usable, el_key)


def _take(rows: _Rows, idx: NDArray[np.int64]) -> _Rows:
    """The rows ``idx``."""
    return _Rows(
        rows.full[idx],
        rows.target[idx],
        rows.q4[idx],
        rows.usable[idx],
        rows.sh_y[:, :, idx],
        rows.sh_z[:, :, idx],
        None if rows.wr_y is None else rows.wr_y[:, :, idx],
        None if rows.wr_z is None else rows.wr_z[:, :, idx],
        rows.cp[idx],
        rows.sp[idx],
    )


# ------------------------------------------------------------------------------ evaluation
def _lin(coef: NDArray, c: NDArray, s: NDArray) -> NDArray[np.float64]:
    """``coef[0] + coef[1] cos + coef[2] sin`` for every row: ``(R, M, K)``."""
    return coef[0][:, :, None] + coef[1][:, :, None] * c + coef[2][:, :, None] * s


def _inside(tri: _Triple, j: int, x: NDArray, y: NDArray) -> NDArray[np.bool_] | None:
    """Is the angle of ``(x, y)`` inside joint ``j``'s range? ``None`` means always."""
    kind = tri.kind[j]
    if kind == 0:
        return None
    cl, sl, ch, sh = tri.ends[j]
    if kind == 1:
        return (cl * y - sl * x >= 0.0) & (x * sh - y * ch >= 0.0)
    return ~((ch * y - sh * x > 0.0) & (x * sl - y * cl > 0.0))


def _and(a, b):
    if a is None:
        return b
    if b is None:
        return a
    return a & b


class _Eval(NamedTuple):
    """One three-hinge joint at a batch of swivels; index 0/1 of the lists: branch +/-."""

    C: NDArray[np.float64]  # u1 . R u3 (1 - C^2 -> 0 where the outer axes align)
    decomposable: NDArray[np.bool_]
    ok: list  # per branch (M, K) bool (or None: always inside)
    c2: list  # per branch cos q2, sin q2, and the (x, y) of q1 and q3
    s2: list
    x1: list
    y1: list
    x3: list
    y3: list


def _evaluate(tri: _Triple, cy: NDArray, cz: NDArray, c: NDArray, s: NDArray) -> _Eval:
    """Both decompositions of the joint at swivels ``(cos, sin)`` of shape ``(M, K)``."""
    C, y1, y2 = _lin(cy[:, :3], c, s)
    z1, z2 = _lin(cz[:, :2], c, s)
    cd = (C - tri.dd) * (1.0 / tri.K)
    if tri.always:
        dec = np.ones(C.shape, dtype=bool)
    else:
        dec = np.abs(cd) <= 1.0 + 1e-12
    if tri.ortho:  # sin(delta) = |y normal to u1|: exact next to the axis alignment
        sd = np.sqrt(y1 * y1 + y2 * y2)
    else:
        sd = np.sqrt(np.maximum(1.0 - cd * cd, 0.0))
    V01, Va1, Vb1, V02, Va2, Vb2 = tri.v
    B01, Ba1, Bb1, B02, Ba2, Bb2 = tri.b
    out = _Eval(C, dec, [], [], [], [], [], [], [])
    for sign in (1.0, -1.0):
        cq = tri.cb * cd - sign * tri.sb * sd
        sq = tri.sb * cd + sign * tri.cb * sd
        v1 = V01 + cq * Va1 + sq * Vb1
        v2 = V02 + cq * Va2 + sq * Vb2
        x1 = y1 * v1 + y2 * v2
        w1 = y2 * v1 - y1 * v2
        b1 = B01 + cq * Ba1 + sq * Bb1
        b2 = B02 + cq * Ba2 + sq * Bb2
        x3 = b1 * z1 + b2 * z2
        w3 = b2 * z1 - b1 * z2
        ok = _and(_and(_inside(tri, 0, x1, w1), _inside(tri, 1, cq, sq)), _inside(tri, 2, x3, w3))
        for lst, val in zip(out[2:], (ok, cq, sq, x1, w1, x3, w3), strict=True):
            lst.append(val)
    return out


def _triple_ok(tri: _Triple, cy, cz, c, s) -> NDArray[np.bool_]:
    ev = _evaluate(tri, cy, cz, c, s)
    a, b = ev.ok
    if a is None:
        return ev.decomposable
    return ev.decomposable & (a | b)


def _feasible(rows: _Rows, ctx: _Context, c: NDArray, s: NDArray) -> NDArray[np.bool_]:
    """Every joint inside its range at swivels ``(M, K)`` (some branch of each joint)."""
    ok = _triple_ok(ctx.sh, rows.sh_y, rows.sh_z, c, s) & rows.usable[:, None]
    if rows.wr_y is not None:
        ok &= _triple_ok(ctx.wr, rows.wr_y, rows.wr_z, c, s)
    return ok


def _roots(tri: _Triple, cy: NDArray, cz: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Swivels where a joint meets a range end: ``cos, sin, valid`` each ``(M, 2 E)``."""
    M = cy.shape[2]
    if tri.eq_row.size == 0:
        z = np.zeros((M, 0))
        return z, z, z.astype(bool)
    k = np.empty((3, tri.eq_row.size, M))  # (const, cos, sin) of each equation's left side
    on_y, on_z = tri.eq_src == 0, tri.eq_src == 1
    k[:, on_y] = cy[:, tri.eq_row[on_y]]
    k[:, on_z] = cz[:, tri.eq_row[on_z]]
    d = tri.eq_rhs[:, None] - k[0]
    kc, ks = k[1], k[2]
    rho2 = kc * kc + ks * ks
    disc = rho2 - d * d
    valid = (disc >= 0.0) & (rho2 > 1e-24)
    sq = np.sqrt(np.maximum(disc, 0.0))
    inv = 1.0 / np.where(valid, rho2, 1.0)
    c = np.concatenate([(kc * d - ks * sq) * inv, (kc * d + ks * sq) * inv]).T
    s = np.concatenate([(ks * d + kc * sq) * inv, (ks * d - kc * sq) * inv]).T
    v = np.concatenate([valid, valid]).T
    return c, s, v


def _candidates(rows: _Rows, ctx: _Context) -> tuple[NDArray, NDArray, NDArray]:
    """Every swivel where some joint meets a range end: ``cos, sin, valid`` ``(M, K)``."""
    parts = [_roots(ctx.sh, rows.sh_y, rows.sh_z)]
    if rows.wr_y is not None:
        parts.append(_roots(ctx.wr, rows.wr_y, rows.wr_z))
    c = np.concatenate([p[0] for p in parts], axis=1)
    s = np.concatenate([p[1] for p in parts], axis=1)
    v = np.concatenate([p[2] for p in parts], axis=1)
    return c, s, v


# ------------------------------------------------------------------------------ angles
def _into_range(q: NDArray, lo, hi, center) -> NDArray[np.float64]:
    """``q`` shifted by multiples of 2 pi next to ``center`` (inside ``[lo, hi]`` if it fits)."""
    return q + TWO_PI * np.round((center - q) / TWO_PI)


def _triple_angles(
    tri: _Triple, ev: _Eval, q_pref: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Both branches' angles ``(2, M, K, 3)``, largest range violation ``(2, M, K)`` [rad]
    and validity (the joint decomposes there).

    Each angle is shifted by 2 pi next to the middle of its range; unlimited joints next
    to ``q_pref (M, 3)``.
    """
    shape = ev.C.shape
    out = np.empty((2, *shape, 3))
    for b in range(2):
        out[b, ..., 0] = np.arctan2(ev.y1[b], ev.x1[b])
        out[b, ..., 1] = np.arctan2(ev.s2[b], ev.c2[b])
        out[b, ..., 2] = np.arctan2(ev.y3[b], ev.x3[b])
    center = np.where(tri.kind > 0, tri.center, q_pref[:, None, :])
    out = _into_range(out, tri.lower, tri.upper, center)
    viol = np.max(np.maximum(tri.lower - out, 0.0) + np.maximum(out - tri.upper, 0.0), axis=-1)
    valid = np.broadcast_to(ev.decomposable, viol.shape)
    return out, viol, valid


def _pick_branch(ang, viol, valid, q_pref) -> tuple[NDArray, NDArray]:
    """Per row the branch inside the ranges closest to ``q_pref``, else the least violating."""
    dist = np.sum(np.abs(ang - q_pref), axis=2)  # (2, M)
    key = np.where(valid, dist + np.where(viol > RANGE_TOL, 1e6 * (1.0 + viol), 0.0), np.inf)
    pick = np.argmin(key, axis=0)
    rows = np.arange(ang.shape[1])
    return ang[pick, rows], viol[pick, rows]


_GIMBAL = 1e-7
"""Below this ``1 - (u1 . R u3)^2`` the outer axes of a joint nearly align and its angles
are taken from the explicit rotation (:func:`_gimbal_splits`)."""


def _explicit(ctx: _Context, setup: _Setup, m: int, c: float, s: float, wrist: bool):
    """The shoulder (or wrist) rotation ``(3, 3)`` of row ``m`` at swivel ``(c, s)``."""
    n = setup.n[setup.rows.target[m]]
    K = _cross_matrix(n)
    R_sh = (np.eye(3) + s * K + (1.0 - c) * (K @ K)) @ setup.R_ref[m]
    if not wrist:
        return R_sh
    R_el = _rodrigues(ctx.ue, float(setup.rows.q4[m]))
    R_t = setup.R_t[setup.rows.target[m]]
    return R_el.T @ R_sh.T @ R_t @ ctx.geo.R_ee0.T


def _joint_angles(
    ctx: _Context,
    setup: _Setup,
    m: NDArray[np.int64],
    c: NDArray,
    s: NDArray,
    q_pref: NDArray,
    wrist: bool,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Angles ``(N, 3)`` of one three-hinge joint at the chosen rows and swivels, the
    branch inside the ranges closest to ``q_pref (N, 3)``; and their range violation."""
    rows = setup.rows
    tri = ctx.wr if wrist else ctx.sh
    cy = (rows.wr_y if wrist else rows.sh_y)[:, :, m]
    cz = (rows.wr_z if wrist else rows.sh_z)[:, :, m]
    ev = _evaluate(tri, cy, cz, c[:, None], s[:, None])
    ang, viol, valid = _triple_angles(tri, ev, q_pref)
    q, v = _pick_branch(ang[:, :, 0], viol[:, :, 0], valid[:, :, 0], q_pref)
    for i in np.flatnonzero(1.0 - ev.C[:, 0] ** 2 < _GIMBAL):
        R = _explicit(ctx, setup, int(m[i]), float(c[i]), float(s[i]), wrist)
        best = None
        for b in (0, 1) if ev.decomposable[i, 0] else ():
            q2 = math.atan2(float(ev.s2[b][i, 0]), float(ev.c2[b][i, 0]))
            for qq in _gimbal_splits(tri, R, q2, ang[b, i, 0], q_pref[i]):
                vv = float(
                    np.max(np.maximum(tri.lower - qq, 0.0) + np.maximum(qq - tri.upper, 0.0))
                )
                key = (vv > RANGE_TOL, vv, float(np.sum(np.abs(qq - q_pref[i]))))
                if best is None or key < best[0]:
                    best = (key, qq, vv)
        if best is not None:
            q[i], v[i] = best[1], best[2]
    return q, v


def _gimbal_splits(
    tri: _Triple, R: NDArray, q2: float, plain: NDArray, q_pref: NDArray
) -> list[NDArray[np.float64]]:
    """Angles of ``R`` with the middle one ``q2`` when the outer axes nearly align.

    ``q3`` is read from the remainder ``Rot(u2, -q2) Rot(u1, -q1) R``, which absorbs the
    error of a poorly conditioned ``q1``. In the lock itself (``R u3`` within 1e-10 of
    ``+-u1``) only ``q1 +- q3`` is fixed and several ``q1`` are tried: the preferred one,
    the ends of its range, and those that put ``q3`` on the ends of its range.
    """
    y = R @ tri.u3
    yp = y - float(y @ tri.u1) * tri.u1
    R2t = _rodrigues(tri.u2, -q2)
    center = np.where(tri.kind > 0, tri.center, q_pref)

    def split(q1: float) -> NDArray[np.float64]:
        R3 = R2t @ _rodrigues(tri.u1, -q1) @ R
        r = R3 @ tri.f1
        q3 = math.atan2(float(tri.f2 @ r), float(tri.f1 @ r))
        return _into_range(np.array([q1, q2, q3]), tri.lower, tri.upper, center)

    if float(np.linalg.norm(yp)) > 1e-10:
        return [split(float(plain[0]))]
    sigma = 1.0 if float(y @ tri.u1) > 0 else -1.0
    total = float(split(0.0)[2]) * sigma  # q1 + sigma q3
    q1s = [float(q_pref[0])]
    if tri.kind[0]:
        q1s += [float(tri.lower[0]), float(tri.upper[0])]
    if tri.kind[2]:
        q1s += [total - sigma * float(L) for L in (tri.lower[2], tri.upper[2])]
    return [split(q1) for q1 in q1s]


class _Solved(NamedTuple):
    q: NDArray[np.float64]  # (N, 7)
    feasible: NDArray[np.bool_]  # (N,) every joint inside its range
    reach: NDArray[np.float64]  # (N,) distance beyond the shell [m]
    inner: NDArray[np.bool_]  # (N,) inside the inner hole
    elbow_ok: NDArray[np.bool_]  # (N,) some elbow branch inside its range
    swivel: NDArray[np.float64]  # (N,) chosen swivel [rad]
    setup: _Setup


def _solve_chunk(
    ctx: _Context,
    positions: NDArray[np.float64],
    R_t: NDArray[np.float64] | None,
    q0: NDArray[np.float64],
    swivel: NDArray[np.float64] | None,
) -> _Solved:
    """Closest feasible swivel to the preferred one, then the joint angles, for N targets."""
    setup = _setup(ctx, positions, R_t, q0, swivel)
    rows = setup.rows
    N = positions.shape[0]
    # per (target, elbow branch): distance key of the best swivel and its cos, sin
    dist = np.full(2 * N, np.inf)
    bc, bs = np.ones(2 * N), np.zeros(2 * N)
    bc[rows.full], bs[rows.full] = rows.cp, rows.sp
    # 1. the preferred swivel itself
    ok0 = _feasible(rows, ctx, rows.cp[:, None], rows.sp[:, None])[:, 0]
    dist[rows.full[ok0]] = 0.0
    # 2. otherwise the nearest swivel where a joint meets a range end and all are inside,
    #    trying the nearest few candidates first
    done = np.isfinite(dist.reshape(N, 2)).any(axis=1)
    need = np.flatnonzero(~done[rows.target] & rows.usable)
    if need.size:
        sub = _take(rows, need)
        c, s, v = _candidates(sub, ctx)
        d = np.where(v, 1.0 - (c * sub.cp[:, None] + s * sub.sp[:, None]), np.inf)
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
            part = _take(sub, todo)
            cc, ss, dd = c[todo, start:stop], s[todo, start:stop], d[todo, start:stop]
            f = _feasible(part, ctx, cc, ss) & np.isfinite(dd)
            hit = f.any(axis=1)
            k = np.argmax(f, axis=1)
            rows_hit, k = np.flatnonzero(hit), k[hit]
            idx = rows.full[need[todo[rows_hit]]]
            dist[idx], bc[idx], bs[idx] = dd[rows_hit, k], cc[rows_hit, k], ss[rows_hit, k]
            todo = todo[~hit & np.isfinite(d[todo, stop - 1])]
            start = stop
    # 3. the elbow branch with the closer swivel (then the closer elbow angle)
    d2 = dist.reshape(N, 2)
    pick = np.where(
        d2[:, 0] < d2[:, 1] - 1e-12,
        0,
        np.where(d2[:, 1] < d2[:, 0] - 1e-12, 1, np.argmin(setup.elbow_key, axis=1)),
    )
    idx = np.arange(N)
    feasible = np.isfinite(d2[idx, pick])
    where = np.full(2 * N, -1)
    where[rows.full] = np.arange(rows.full.size)
    full = 2 * idx + pick
    m = where[full]
    c, s = bc[full], bs[full]
    q = np.empty((N, 7))
    q[:, 3] = setup.q4[idx, pick]
    q[:, :3], _ = _joint_angles(ctx, setup, m, c, s, q0[:, :3], wrist=False)
    if R_t is None:
        q[:, 4:] = setup.q_wrist
    else:
        q[:, 4:], _ = _joint_angles(ctx, setup, m, c, s, q0[:, 4:], wrist=True)
    # infeasible targets keep their least violating branch, moved inside the ranges
    q = np.clip(q, ctx.lower, ctx.upper)
    elbow_ok = setup.usable.any(axis=1)
    return _Solved(q, feasible, setup.reach, setup.inner, elbow_ok, np.arctan2(s, c), setup)


# ------------------------------------------------------------------------------ public API
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


class BatchSolution(NamedTuple):
    """What :func:`solve_batch` returns (unpacks as ``q, ok``)."""

    q: NDArray[np.float64]
    """Joint values ``(N, 7)`` [rad]; for a failed target the closest sensible pose."""
    ok: NDArray[np.bool_]
    """``(N,)`` True where the pose is reached with every joint inside its range."""


def _target_arrays(
    positions: ArrayLike, quats: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise TargetError(f"positions must have shape (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise TargetError("positions contain NaN or inf")
    if quats is None:
        return p, None
    qt = np.asarray(quats, dtype=np.float64)
    if qt.shape != (p.shape[0], 4):
        raise TargetError(f"quats must have shape ({p.shape[0]}, 4) (w, x, y, z), got {qt.shape}")
    if not np.all(np.isfinite(qt)):
        raise TargetError("quats contain NaN or inf")
    norm = np.linalg.norm(qt, axis=1)
    if np.any(np.abs(norm - 1.0) > 1e-3):
        i = int(np.argmax(np.abs(norm - 1.0)))
        raise TargetError(
            f"quaternion {qt[i].tolist()} has norm {norm[i]:.6g}; expected unit (w, x, y, z)"
        )
    w, x, y, z = (qt / norm[:, None]).T
    R = np.empty((p.shape[0], 3, 3))
    R[:, 0, 0] = 1 - 2 * (y * y + z * z)
    R[:, 0, 1] = 2 * (x * y - w * z)
    R[:, 0, 2] = 2 * (x * z + w * y)
    R[:, 1, 0] = 2 * (x * y + w * z)
    R[:, 1, 1] = 1 - 2 * (x * x + z * z)
    R[:, 1, 2] = 2 * (y * z - w * x)
    R[:, 2, 0] = 2 * (x * z - w * y)
    R[:, 2, 1] = 2 * (y * z + w * x)
    R[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return p, R


def _starts(chain: Chain, q0: ArrayLike | None, N: int) -> NDArray[np.float64]:
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
        chain: a 7-hinge arm (see :func:`structure_problem`).
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
    ctx = _context(chain)
    p, R = _target_arrays(positions, quats)
    N = p.shape[0]
    q_start = _starts(chain, q0, N)
    psi = _swivels(swivel, N)
    q = np.empty((N, 7))
    ok = np.empty(N, dtype=bool)
    for a in range(0, N, _CHUNK):
        b = min(a + _CHUNK, N)
        res = _solve_chunk(
            ctx,
            p[a:b],
            None if R is None else R[a:b],
            np.ascontiguousarray(q_start[a:b]),
            None if psi is None else psi[a:b],
        )
        q[a:b] = res.q
        ok[a:b] = res.feasible & (res.reach == 0.0)
    return BatchSolution(q, ok)


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
        chain: a 7-hinge arm (see :func:`structure_problem`).
        target: a :class:`Target` or a position ``(3,)`` [m].
        swivel: one swivel or ``(K,)`` of them [rad].
        q0: starting posture ``(7,)`` (the wrist of a position target, and the 2 pi
            shift of unlimited joints); default the chain's joints.

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: a bad target, ``q0`` or swivel.
    """
    ctx = _context(chain)
    tgt = Target.of(target)
    q_start = np.ascontiguousarray(_starts(chain, q0, 1))
    psi = np.atleast_1d(np.asarray(swivel, dtype=np.float64))
    if psi.ndim != 1 or not np.all(np.isfinite(psi)):
        raise TargetError(f"swivel must be finite angles, one or (K,), got {swivel!r}")
    R = None if tgt.rotation is None else tgt.rotation[None]
    setup = _setup(ctx, tgt.position[None], R, q_start, np.zeros(1), keep="all")
    if setup.reach[0] > 0.0:
        return []
    rows = setup.rows
    c, s = np.cos(psi)[None], np.sin(psi)[None]  # (1, K)
    lo, hi = ctx.lower - RANGE_TOL, ctx.upper + RANGE_TOL
    out: list[Branch] = []
    for m in range(rows.full.size):
        parts = []  # per joint: list of (branch, angles (K, 3), decomposable (K,))
        for wrist in (False, True) if R is not None else (False,):
            tri = ctx.wr if wrist else ctx.sh
            cy = (rows.wr_y if wrist else rows.sh_y)[:, :, [m]]
            cz = (rows.wr_z if wrist else rows.sh_z)[:, :, [m]]
            ev = _evaluate(tri, cy, cz, c, s)
            ang, _, dec = _triple_angles(tri, ev, q_start[:, 4:] if wrist else q_start[:, :3])
            parts.append([(b, ang[b, 0], dec[b, 0]) for b in (0, 1)])
        if R is None:
            parts.append([(0, np.broadcast_to(setup.q_wrist[0], (psi.size, 3)), True)])
        for i, qs, ds in parts[0]:
            for j, qw, dw in parts[1]:
                q = np.empty((psi.size, 7))
                q[:, :3], q[:, 3], q[:, 4:] = qs, rows.q4[m], qw
                valid = np.all((q >= lo) & (q <= hi), axis=1)
                ok = np.broadcast_to(ds & dw, (psi.size,))
                for k in np.flatnonzero(ok):
                    out.append(
                        Branch(q[k], bool(valid[k]), int(rows.full[m] % 2), i, j, float(psi[k]))
                    )
    return out


def swivel_intervals(
    chain: Chain, target: Target | ArrayLike, q0: ArrayLike | None = None
) -> list[SwivelInterval]:
    """The swivels at which ``target`` is reached with every joint inside its range.

    Interval ends are exact roots of ``k_c cos psi + k_s sin psi = d`` (a joint at a range
    end); between two consecutive roots feasibility is constant and is tested at the
    midpoint. A whole circle is returned as ``[-pi, pi]``. Empty when the target is
    beyond reach or nothing is feasible. ``q0`` only matters for a position target (the
    wrist keeps its angles).

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: a bad target or ``q0``.
    """
    ctx = _context(chain)
    tgt = Target.of(target)
    q_start = np.ascontiguousarray(_starts(chain, q0, 1))
    R = None if tgt.rotation is None else tgt.rotation[None]
    setup = _setup(ctx, tgt.position[None], R, q_start, np.zeros(1))
    if setup.reach[0] > 0.0:
        return []
    out: list[SwivelInterval] = []
    for m in np.flatnonzero(setup.rows.usable):
        sub = _take(setup.rows, np.array([m]))
        elbow, q4 = int(sub.full[0] % 2), float(sub.q4[0])
        c, s, v = _candidates(sub, ctx)
        roots = np.sort(np.arctan2(s[v], c[v]))
        if roots.size == 0:
            if _feasible(sub, ctx, np.ones((1, 1)), np.zeros((1, 1)))[0, 0]:
                out.append(SwivelInterval(elbow, q4, -math.pi, math.pi))
            continue
        ends = np.append(roots[1:], roots[0] + TWO_PI)
        mids = 0.5 * (roots + ends)
        f = _feasible(sub, ctx, np.cos(mids)[None], np.sin(mids)[None])[0]
        if f.all():
            out.append(SwivelInterval(elbow, q4, -math.pi, math.pi))
            continue
        # runs of feasible arcs, walking once round from the first infeasible one
        K, i0 = f.size, int(np.flatnonzero(~f)[0])
        run = None
        for j in range(1, K + 1):
            i = (i0 + j) % K
            wrap = TWO_PI if i0 + j >= K else 0.0
            if f[i]:
                run = (roots[i] + wrap if run is None else run[0], ends[i] + wrap)
            elif run is not None:
                shift = TWO_PI * math.floor((run[0] + math.pi) / TWO_PI)
                out.append(SwivelInterval(elbow, q4, float(run[0] - shift), float(run[1] - shift)))
                run = None
    return sorted(out, key=lambda iv: (iv.elbow, iv.start))


def swivel_angle(chain: Chain, q: ArrayLike) -> float:
    """The swivel [rad] of posture ``q (7,)``: its elbow about its own shoulder-wrist line.

    Solving the pose of ``q`` with this as the preferred swivel returns ``q``'s elbow
    position (and ``q`` itself when its branches are the ones closest to the start).

    Raises:
        SolverError: the chain is not a spherical shoulder + elbow + spherical wrist.
        TargetError: ``q`` is not 7 finite values.
    """
    ctx = _context(chain)
    qq = chain.check_q(q)
    sh = ctx.sh
    e = (ctx.Ea - ctx.S)[None]
    w = (ctx.Ea - ctx.S + _rodrigues(ctx.ue, float(qq[3])) @ (ctx.W0 - ctx.Ea))[None]
    for k, u in ((2, sh.u3), (1, sh.u2), (0, sh.u1)):
        c, s = np.cos(qq[k : k + 1]), np.sin(qq[k : k + 1])
        e, w = _rotate(u, c, s, e), _rotate(u, c, s, w)
    n = _unit(w, np.array([[1.0, 0.0, 0.0]]))
    ref = _perp_unit(ctx.geo.down[None], n, [np.eye(3)[0], np.eye(3)[1]])
    return float(np.arctan2(np.sum(e * np.cross(n, ref)), np.sum(e * ref)))


# ------------------------------------------------------------------------------ the solver
_REASONS: weakref.WeakKeyDictionary[Chain, str | None] = weakref.WeakKeyDictionary()


class ClosedForm(Solver):
    """Closed-form pose IK of a 7-hinge arm with the swivel as the free parameter.

    Exact (to rounding) on any chain of three hinges meeting at a shoulder point, an
    elbow hinge and three hinges meeting at a wrist point, with the axes read from
    MuJoCo. Among all joint vectors that reach the target inside the joint ranges it
    returns one at the swivel closest to ``swivel`` (default: the starting elbow's
    swivel), with the shoulder and wrist branches closest to the start.

    Position targets: the wrist keeps its starting angles and the shoulder and elbow
    place the end effector (the hand rides along as part of the forearm).

    A target beyond the shell the wrist point can reach, or one for which no swivel
    keeps every joint in range, is ``unreachable``: the arm is stretched (or folded)
    toward it, at the least violating branch moved inside the ranges.
    """

    name: ClassVar[str] = "closed_form"
    summary: ClassVar[str] = "closed form: law of cosines + elbow swivel, exact joint ranges"
    supports_orientation: ClassVar[bool] = True
    defaults: ClassVar[dict[str, Any]] = {"swivel": None}

    def __init__(self, **options: Any):
        super().__init__(**options)
        sw = self.options["swivel"]
        if sw is not None:
            if isinstance(sw, bool) or not isinstance(sw, (int, float)) or not math.isfinite(sw):
                raise SolverError(
                    f"option 'swivel' of solver '{self.name}' must be a finite angle in "
                    f"[rad] or None, got {sw!r}"
                )
            self.options["swivel"] = self.swivel = float(sw)
        self._psi = None if self.swivel is None else np.array([self.swivel])

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        try:
            return _REASONS[chain]
        except KeyError:
            reason = structure_problem(chain)
            _REASONS[chain] = reason
            return reason

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        ctx = _context(chain)
        fast = ctx.scalar
        if fast is not None:
            rot = None if target.rotation is None else target.rotation.tolist()
            try:
                q1, _ = _solve_one(fast, target.position.tolist(), rot, q0.tolist(), self.swivel)
                return self._result(chain, target, np.array(q1), 1)
            except _Fallback:
                pass
        R = None if target.rotation is None else target.rotation[None]
        res = _solve_chunk(ctx, target.position[None], R, q0[None], self._psi)
        q = res.q[0]
        if res.reach[0] > 0.0:
            where = "inside the inner hole of" if res.inner[0] else "beyond"
            point = "wrist point" if R is not None else "end effector (wrist kept)"
            r_min, r_max = res.setup.shell[0][0], res.setup.shell[1][0]
            msg = (
                f"the target puts the {point} {res.reach[0]:.6g} m {where} the reachable "
                f"shell [{r_min:.4f}, {r_max:.4f}] m around the shoulder"
            )
            return self._result(chain, target, q, 1, status="unreachable", message=msg)
        if not res.feasible[0]:
            if not res.elbow_ok[0]:
                msg = (
                    f"the elbow angle this target needs is outside its range "
                    f"[{ctx.elbow_lo:.4g}, {ctx.elbow_hi:.4g}] rad"
                )
            else:
                msg = "no swivel angle keeps every shoulder and wrist joint inside its range"
            return self._result(chain, target, q, 1, status="unreachable", message=msg)
        return self._result(chain, target, q, 1)


# ------------------------------------------------------------------------------ one target
# The same method as ``_solve_chunk`` for one pose target, in plain float arithmetic: numpy
# costs about a microsecond a call, so one target is solved without it. Vectors are
# expressed once per target in the frames where the joint angles are read: for a joint
# with axes u1, u2, u3, the frame (e1, e2, u1) for q1 and (f1, f2, u3) for q3, so that
# q1 = angle(y) - angle(v) and q3 = angle(b) - angle(z) in those planes. Anything
# unusual (a target out of reach or out of range, an axis alignment, a degenerate
# frame) is handed to the vectorised path.
class _Fallback(Exception):
    """The scalar path leaves this target to the vectorised one."""


def _tup(v) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _proj(rows, v) -> tuple[float, float, float]:
    """Dot products of ``v`` with three vectors given as 9 floats, row after row."""
    a0, a1, a2, b0, b1, b2, c0, c1, c2 = rows
    x, y, z = v
    return a0 * x + a1 * y + a2 * z, b0 * x + b1 * y + b2 * z, c0 * x + c1 * y + c2 * z


def _sector(tri: _Triple, j: int):
    """``inside(x, y)`` for joint ``j`` of ``tri`` (the test of :func:`_inside`)."""
    kind = int(tri.kind[j])
    cl, sl, ch, sh = (float(v) for v in tri.ends[j])
    if kind == 0:
        return lambda x, y: True
    if kind == 1:
        return lambda x, y: cl * y - sl * x >= 0.0 and x * sh - y * ch >= 0.0
    return lambda x, y: not (ch * y - sh * x > 0.0 and x * sl - y * cl > 0.0)


class _ScalarTriple:
    """A :class:`_Triple` as floats in its reading frames."""

    def __init__(self, tri: _Triple):
        u1, u2, u3 = tri.u1, tri.u2, tri.u3
        e1, e2, f1, f2 = tri.e1, tri.e2, tri.f1, tri.f2
        self.e1, self.e2, self.f1, self.f2 = e1, e2, f1, f2
        self.u1, self.u3 = _tup(u1), _tup(u3)
        self.dd, self.invK = tri.dd, 1.0 / tri.K
        self.cb, self.sb = tri.cb, tri.sb
        self.ortho = tri.ortho
        d12, d23 = float(u1 @ u2), float(u2 @ u3)
        self.v, self.b = tri.v, tri.b
        self.in1, self.in2, self.in3 = (_sector(tri, j) for j in range(3))
        self.lower = tuple(float(x) for x in tri.lower)
        self.upper = tuple(float(x) for x in tri.upper)
        self.center = tuple(float(x) for x in tri.center)
        self.kind = tuple(int(k) for k in tri.kind)
        # range-end equations: (kind, p_a, p_b, p_c, rhs)
        eqs = []
        for j in range(3):
            if not tri.kind[j]:
                continue
            for L in (tri.lower[j], tri.upper[j]):
                if j == 0:
                    p = _rodrigues(u1, L) @ u2
                    eqs.append((0, float(p @ e1), float(p @ e2), float(p @ u1), d23))
                elif j == 1:
                    rhs = float(u1 @ _rodrigues(u2, L) @ u3)
                    eqs.append((1, 0.0, 0.0, 1.0, rhs))
                else:
                    p = _rodrigues(u3, -L) @ u2
                    eqs.append((2, float(p @ f1), float(p @ f2), float(p @ u3), d12))
        self.eqs = tuple(eqs)

    def feasible(self, k, c: float, s: float) -> bool:
        """Some branch of the joint inside its ranges at swivel ``(c, s)``."""
        y10, y1c, y1s, y20, y2c, y2s, c0, cc, cs, z10, z1c, z1s, z20, z2c, z2s = k
        C = c0 + cc * c + cs * s
        y1 = y10 + y1c * c + y1s * s
        y2 = y20 + y2c * c + y2s * s
        cd = (C - self.dd) * self.invK
        if cd > 1.0 or cd < -1.0:
            if abs(cd) > 1.0 + 1e-12:
                return False
            cd = 1.0 if cd > 0 else -1.0
        sd = math.sqrt(y1 * y1 + y2 * y2) if self.ortho else math.sqrt(1.0 - cd * cd)
        cb, sb = self.cb, self.sb
        z1 = z10 + z1c * c + z1s * s
        z2 = z20 + z2c * c + z2s * s
        V01, Va1, Vb1, V02, Va2, Vb2 = self.v
        B01, Ba1, Bb1, B02, Ba2, Bb2 = self.b
        for sign in (1.0, -1.0):
            cq = cb * cd - sign * sb * sd
            sq = sb * cd + sign * cb * sd
            if not self.in2(cq, sq):
                continue
            v1 = V01 + cq * Va1 + sq * Vb1
            v2 = V02 + cq * Va2 + sq * Vb2
            if not self.in1(y1 * v1 + y2 * v2, y2 * v1 - y1 * v2):
                continue
            b1 = B01 + cq * Ba1 + sq * Bb1
            b2 = B02 + cq * Ba2 + sq * Bb2
            if self.in3(b1 * z1 + b2 * z2, b2 * z1 - b1 * z2):
                return True
        return False

    def angles(self, k, c: float, s: float, q_pref) -> list[float]:
        """The branch inside the ranges closest to ``q_pref``, as 3 angles [rad]."""
        y10, y1c, y1s, y20, y2c, y2s, c0, cc, cs, z10, z1c, z1s, z20, z2c, z2s = k
        C = c0 + cc * c + cs * s
        if 1.0 - C * C < _GIMBAL:
            raise _Fallback
        cd = min(max((C - self.dd) * self.invK, -1.0), 1.0)
        y1 = y10 + y1c * c + y1s * s
        y2 = y20 + y2c * c + y2s * s
        sd = math.sqrt(y1 * y1 + y2 * y2) if self.ortho else math.sqrt(1.0 - cd * cd)
        z1 = z10 + z1c * c + z1s * s
        z2 = z20 + z2c * c + z2s * s
        V01, Va1, Vb1, V02, Va2, Vb2 = self.v
        B01, Ba1, Bb1, B02, Ba2, Bb2 = self.b
        lo, hi, cen = self.lower, self.upper, self.center
        best, best_key = None, math.inf
        for sign in (1.0, -1.0):
            cq = self.cb * cd - sign * self.sb * sd
            sq = self.sb * cd + sign * self.cb * sd
            v1 = V01 + cq * Va1 + sq * Vb1
            v2 = V02 + cq * Va2 + sq * Vb2
            b1 = B01 + cq * Ba1 + sq * Bb1
            b2 = B02 + cq * Ba2 + sq * Bb2
            q = [
                math.atan2(y2 * v1 - y1 * v2, y1 * v1 + y2 * v2),
                math.atan2(sq, cq),
                math.atan2(b2 * z1 - b1 * z2, b1 * z1 + b2 * z2),
            ]
            key = 0.0
            for j in range(3):
                ctr = cen[j] if self.kind[j] else q_pref[j]
                q[j] += TWO_PI * round((ctr - q[j]) / TWO_PI)
                if q[j] < lo[j] - 1e-9 or q[j] > hi[j] + 1e-9:
                    key = math.inf
                key += abs(q[j] - q_pref[j])
            if key < best_key:
                best, best_key = q, key
        if best is None:
            raise _Fallback
        return best

    def roots(self, k, cp: float, sp: float, out: list) -> None:
        """Append ``(distance key, cos, sin)`` of every swivel where a joint meets a range end."""
        y10, y1c, y1s, y20, y2c, y2s, c0, cc, cs, z10, z1c, z1s, z20, z2c, z2s = k
        for kind, pa, pb, pc, rhs in self.eqs:
            if kind == 0:
                k0 = pa * y10 + pb * y20 + pc * c0
                kc = pa * y1c + pb * y2c + pc * cc
                ks = pa * y1s + pb * y2s + pc * cs
            elif kind == 1:
                k0, kc, ks = c0, cc, cs
            else:
                k0 = pa * z10 + pb * z20 + pc * c0
                kc = pa * z1c + pb * z2c + pc * cc
                ks = pa * z1s + pb * z2s + pc * cs
            d = rhs - k0
            rho2 = kc * kc + ks * ks
            disc = rho2 - d * d
            if disc < 0.0 or rho2 <= 1e-24:
                continue
            sq = math.sqrt(disc)
            inv = 1.0 / rho2
            c1, s1 = (kc * d - ks * sq) * inv, (ks * d + kc * sq) * inv
            c2, s2 = (kc * d + ks * sq) * inv, (ks * d - kc * sq) * inv
            out.append((1.0 - (c1 * cp + s1 * sp), c1, s1))
            out.append((1.0 - (c2 * cp + s2 * sp), c2, s2))


class _Scalar:
    """Float constants of a chain for :func:`_solve_one`."""

    def __init__(self, ctx: _Context):
        g = ctx.geo
        self.S = _tup(ctx.S)
        self.d = _tup(g.hand_offset)
        self.ctx = ctx
        self.elo, self.ehi, self.ecen = ctx.elbow_lo, ctx.elbow_hi, ctx.elbow_center
        self.wrist_point = self._forearm(ctx.W0)
        self.last_wrist: tuple = ((), self.wrist_point)  # (wrist angles, hand point)
        self.e = _tup(ctx.Ea - ctx.S)
        self.ue = _tup(ctx.ue)
        self.down = _tup(g.down)
        self.sh, self.wr = _ScalarTriple(ctx.sh), _ScalarTriple(ctx.wr)
        self.sh_axes = [_tup(a) for a in g.shoulder_axes]
        sh, wr = self.sh, self.wr
        self.sh_read = (*_tup(sh.e1), *_tup(sh.e2), *sh.u1)  # q1's frame (e1, e2, u1)
        self.sh_z_read = (*sh.u3, *_tup(sh.f1), *_tup(sh.f2))  # u3 and q3's (f1, f2)
        self.wr_e1, self.wr_e2, self.wr_u1 = _tup(wr.e1), _tup(wr.e2), wr.u1
        # wrist vectors taken into the end-effector frame at zero: R_ee0' v
        R0 = g.R_ee0
        self.wr_u3e = _tup(R0.T @ ctx.wr.u3)
        self.wr_f1e, self.wr_f2e = _tup(R0.T @ wr.f1), _tup(R0.T @ wr.f2)
        self.last_q0: tuple = ((), (0.0, 0.0, 0.0))  # (shoulder angles, elbow)

    def _forearm(self, P: NDArray) -> tuple:
        """Law-of-cosines constants and ``P(q4) = Pc + cos q4 Pa + sin q4 Pb`` for the
        forearm point ``P`` (at zero): ``(l1^2 + l2^2 + h^2, 2 l1 l2, alpha, Pc, Pa, Pb)``."""
        ctx = self.ctx
        l1, l2, h, alpha = _shell(ctx.S, ctx.Ea, ctx.ue, P[None])
        w = P - ctx.Ea
        par = (w @ ctx.ue) * ctx.ue
        return (
            float(l1 * l1 + l2[0] ** 2 + h[0] ** 2),
            float(2.0 * l1 * l2[0]),
            float(alpha[0]),
            _tup(ctx.Ea + par),
            _tup(w - par),
            _tup(np.cross(ctx.ue, w)),
        )

    def hand_point(self, qw: list[float]) -> tuple:
        """:meth:`_forearm` of the end effector with the wrist at ``qw`` (cached)."""
        key = tuple(qw)
        last = self.last_wrist
        if key == last[0]:
            return last[1]
        g = self.ctx.geo
        v = g.p_ee0 - self.ctx.W0
        for k in (2, 1, 0):
            v = _rodrigues(g.wrist_axes[k], qw[k]) @ v
        point = self._forearm(self.ctx.W0 + v)
        self.last_wrist = (key, point)
        return point

    def elbow_q0(self, q0: list[float]) -> tuple[float, float, float]:
        """``R_sh(q0) (E - S)``: the starting elbow relative to the shoulder (cached)."""
        key = (q0[0], q0[1], q0[2])
        last = self.last_q0
        if key == last[0]:
            return last[1]
        v = self.e
        for k in (2, 1, 0):
            v = _rot(self.sh_axes[k], math.cos(q0[k]), math.sin(q0[k]), v)
        self.last_q0 = (key, v)
        return v


def _rot(u, c: float, s: float, v):
    """``Rot(u, t) v`` with ``c, s = cos t, sin t``."""
    ux, uy, uz = u
    vx, vy, vz = v
    p = (ux * vx + uy * vy + uz * vz) * (1.0 - c)
    return (
        vx * c + (uy * vz - uz * vy) * s + ux * p,
        vy * c + (uz * vx - ux * vz) * s + uy * p,
        vz * c + (ux * vy - uy * vx) * s + uz * p,
    )


def _reproject(x: float, y: float, z: float, n) -> tuple[float, float, float]:
    """Unit ``(x, y, z)`` made normal to unit ``n`` once more (as in :func:`_perp_unit`)."""
    d = x * n[0] + y * n[1] + z * n[2]
    x, y, z = x - d * n[0], y - d * n[1], z - d * n[2]
    inv = 1.0 / math.sqrt(x * x + y * y + z * z)
    return x * inv, y * inv, z * inv


def _solve_one(
    F: _Scalar, position, rotation, q0: list[float], swivel: float | None
) -> tuple[list[float], float]:
    """Joint values and swivel for one feasible target (raises ``_Fallback`` otherwise).

    ``rotation`` is the target rotation as nested lists, or ``None`` for a position
    target (the wrist keeps ``q0``'s angles).
    """
    px, py, pz = position
    Sx, Sy, Sz = F.S
    pose = rotation is not None
    if pose:
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation
        d0, d1, d2 = F.d
        tx = px - (r00 * d0 + r01 * d1 + r02 * d2) - Sx
        ty = py - (r10 * d0 + r11 * d1 + r12 * d2) - Sy
        tz = pz - (r20 * d0 + r21 * d1 + r22 * d2) - Sz
        L2, den, alpha, Pc, Pa, Pb = F.wrist_point
    else:
        tx, ty, tz = px - Sx, py - Sy, pz - Sz
        L2, den, alpha, Pc, Pa, Pb = F.hand_point(q0[4:])
    r2 = tx * tx + ty * ty + tz * tz
    if r2 < 1e-18:
        raise _Fallback
    cos_e = (L2 - r2) / den
    if cos_e > 1.0 or cos_e < -1.0:
        raise _Fallback
    inv_r = 1.0 / math.sqrt(r2)
    n = (tx * inv_r, ty * inv_r, tz * inv_r)
    phi = math.acos(cos_e)
    elbows = []
    for q4 in (alpha + phi, alpha - phi) if 1e-12 < phi < math.pi - 1e-12 else (alpha + phi,):
        q4 += TWO_PI * round((F.ecen - q4) / TWO_PI)
        if F.elo - RANGE_TOL <= q4 <= F.ehi + RANGE_TOL:
            elbows.append(q4)
    if not elbows:
        raise _Fallback
    # swivel zero: gravity normal to n; k = n x r
    dn = _dot(F.down, n)
    rx, ry, rz = F.down[0] - dn * n[0], F.down[1] - dn * n[1], F.down[2] - dn * n[2]
    rn = math.sqrt(rx * rx + ry * ry + rz * rz)
    if rn < 1e-9:
        raise _Fallback
    r = _reproject(rx / rn, ry / rn, rz / rn, n)
    k = (n[1] * r[2] - n[2] * r[1], n[2] * r[0] - n[0] * r[2], n[0] * r[1] - n[1] * r[0])
    if swivel is None:
        e = F.elbow_q0(q0)
        x_, y_ = _dot(e, r), _dot(e, k)
        nrm = math.hypot(x_, y_)
        cp, sp = (x_ / nrm, y_ / nrm) if nrm > 1e-12 else (1.0, 0.0)
    else:
        cp, sp = math.cos(swivel), math.sin(swivel)
    # per target: n, r, k in the shoulder's reading frame; the hand's vectors in (n, r, k)
    sh, wr = F.sh, F.wr
    ne1, ne2, m1 = _proj(F.sh_read, n)
    re1, re2, m2 = _proj(F.sh_read, r)
    ke1, ke2, m3 = _proj(F.sh_read, k)
    if pose:
        hand = _hand_frames(F, rotation, n, r, k)
    Sx, Sy, Sz = F.S
    ex, ey, ez = F.e
    best = None  # (distance key, elbow key, q4, kshoulder, kwrist, c, s)
    for q4 in elbows:
        ce, se = math.cos(q4), math.sin(q4)
        ax = Pc[0] + ce * Pa[0] + se * Pb[0] - Sx
        ay = Pc[1] + ce * Pa[1] + se * Pb[1] - Sy
        az = Pc[2] + ce * Pa[2] + se * Pb[2] - Sz
        an = 1.0 / math.sqrt(ax * ax + ay * ay + az * az)
        a = (ax * an, ay * an, az * an)
        ea = ex * a[0] + ey * a[1] + ez * a[2]
        bx, by, bz = ex - ea * a[0], ey - ea * a[1], ez - ea * a[2]
        bn = math.sqrt(bx * bx + by * by + bz * bz)
        if bn < 1e-9:
            raise _Fallback
        b = _reproject(bx / bn, by / bn, bz / bn, a)
        cv = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        # shoulder: y = n al + r (be c - ga s) + k (ga c + be s); z = a m1 + b (..) + cv (..)
        al, af1, af2 = _proj(F.sh_z_read, a)
        be, bf1, bf2 = _proj(F.sh_z_read, b)
        ga, cf1, cf2 = _proj(F.sh_z_read, cv)
        ksh = (
            al * ne1, be * re1 + ga * ke1, be * ke1 - ga * re1,
            al * ne2, be * re2 + ga * ke2, be * ke2 - ga * re2,
            al * m1, be * m2 + ga * m3, be * m3 - ga * m2,
            m1 * af1, m2 * bf1 + m3 * cf1, m3 * bf1 - m2 * cf1,
            m1 * af2, m2 * bf2 + m3 * cf2, m3 * bf2 - m2 * cf2,
        )  # fmt: skip
        kwr = _wrist_coefficients(F, hand, ce, se, a, b, cv) if pose else None
        ekey = abs(q4 - q0[3])
        if sh.feasible(ksh, cp, sp) and (not pose or wr.feasible(kwr, cp, sp)):
            cand = (0.0, ekey, q4, ksh, kwr, cp, sp)
        else:
            found: list = []
            sh.roots(ksh, cp, sp, found)
            if pose:
                wr.roots(kwr, cp, sp, found)
            found.sort()
            cand = None
            for dist, c, s in found:
                if best is not None and dist > best[0] + 1e-12:
                    break
                if sh.feasible(ksh, c, s) and (not pose or wr.feasible(kwr, c, s)):
                    cand = (dist, ekey, q4, ksh, kwr, c, s)
                    break
        if cand is not None and (
            best is None
            or cand[0] < best[0] - 1e-12
            or (cand[0] <= best[0] + 1e-12 and cand[1] < best[1])
        ):
            best = cand
    if best is None:
        raise _Fallback
    _, _, q4, ksh, kwr, c, s = best
    q = sh.angles(ksh, c, s, q0[:3])
    q.append(q4)
    q += wr.angles(kwr, c, s, q0[4:]) if pose else q0[4:]
    return q, math.atan2(s, c)


def _hand_frames(F: _Scalar, rotation, n, r, k) -> tuple[float, ...]:
    """The hand's wrist vectors in the target frame ``(n, r, k)``: ``g = R_t R_ee0' u3`` and
    ``R_t R_ee0' f1``, ``R_t R_ee0' f2`` (the wrist's reading vectors carried to the target)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = rotation
    u3e, f1e, f2e = F.wr_u3e, F.wr_f1e, F.wr_f2e
    gw = (
        r00 * u3e[0] + r01 * u3e[1] + r02 * u3e[2],
        r10 * u3e[0] + r11 * u3e[1] + r12 * u3e[2],
        r20 * u3e[0] + r21 * u3e[1] + r22 * u3e[2],
    )
    nrk = (*n, *r, *k)
    G1, G2, G3 = _proj(nrk, gw)
    F1t = (
        r00 * f1e[0] + r01 * f1e[1] + r02 * f1e[2],
        r10 * f1e[0] + r11 * f1e[1] + r12 * f1e[2],
        r20 * f1e[0] + r21 * f1e[1] + r22 * f1e[2],
    )
    F2t = (
        r00 * f2e[0] + r01 * f2e[1] + r02 * f2e[2],
        r10 * f2e[0] + r11 * f2e[1] + r12 * f2e[2],
        r20 * f2e[0] + r21 * f2e[1] + r22 * f2e[2],
    )
    nF1, rF1, kF1 = _proj(nrk, F1t)
    nF2, rF2, kF2 = _proj(nrk, F2t)
    return (G1, G2, G3, nF1, rF1, kF1, nF2, rF2, kF2)


def _wrist_coefficients(F: _Scalar, hand, ce: float, se: float, a, b, cv) -> tuple[float, ...]:
    """The wrist's 15 swivel-linear coefficients for elbow ``(cos, sin) = (ce, se)``.

    ``y_w = R_el' (a G1 + b (G2 c + G3 s) + cv (G3 c - G2 s))`` and
    ``z_w = R_t R_ee0'``-image of ``n H1 + r (H2 c - H3 s) + k (H3 c + H2 s)``, read in the
    wrist's frames (``H = (a, b, cv) . R_el u1``).
    """
    G1, G2, G3, nF1, rF1, kF1, nF2, rF2, kF2 = hand
    E1 = _rot(F.ue, ce, se, F.wr_e1)
    E2 = _rot(F.ue, ce, se, F.wr_e2)
    Hv = _rot(F.ue, ce, se, F.wr_u1)
    rows = (*E1, *E2, *Hv)
    aE1, aE2, H1 = _proj(rows, a)
    bE1, bE2, H2 = _proj(rows, b)
    cE1, cE2, H3 = _proj(rows, cv)
    return (
        aE1 * G1, bE1 * G2 + cE1 * G3, bE1 * G3 - cE1 * G2,
        aE2 * G1, bE2 * G2 + cE2 * G3, bE2 * G3 - cE2 * G2,
        H1 * G1, H2 * G2 + H3 * G3, H2 * G3 - H3 * G2,
        H1 * nF1, H2 * rF1 + H3 * kF1, H2 * kF1 - H3 * rF1,
        H1 * nF2, H2 * rF2 + H3 * kF2, H2 * kF2 - H3 * rF2,
    )  # fmt: skip
