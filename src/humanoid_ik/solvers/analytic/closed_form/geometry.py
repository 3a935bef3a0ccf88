"""The arm's structure as the closed form uses it, read from MuJoCo, and its constants.

Everything here is read at the zero configuration, in the world frame: the point ``S``
where the three shoulder axes meet, the elbow anchor ``E`` and axis ``u_e``, the point
``W0`` where the three wrist axes meet, and the hand's offset from it. A chain keeps
what is derived from it (:meth:`Chain.derived`): the structure check, and the
:class:`ArmContext` of numbers the solves use, rebuilt only when a joint off the chain
that moves the arm (a free base, a torso hinge) has moved since it was built.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Generic, NamedTuple, Protocol, TypeVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import axes_meeting_point, axis_angle_matrix
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.closed_form.numeric import (
    FLOATS,
    RANGE_TOL,
    TWO_PI,
    X_AXIS,
    Arithmetic,
    Real,
    Vec,
    cross,
    dot,
    sub,
    unit,
    vec,
)

__all__ = [
    "ArmGeometry",
    "Triple",
    "Forearm",
    "ArmContext",
    "StartMemo",
    "Kept",
    "ArmCache",
    "MEET_TOL",
    "meeting",
    "missed_by",
    "structure_problem",
    "forearm",
    "arm_cache",
    "arm_context",
    "arm_geometry",
]

T = TypeVar("T")
C = TypeVar("C")


MEET_TOL = 1e-7
"""How close [m] hinge axes must pass to one point to *meet* there: the one tolerance of
``closed_form``'s and ``two_link``'s structure checks (a spherical shoulder or wrist), so
of ``auto``'s choice of an exact solver. An exact solver's answer on axes that miss by
``d`` is off by up to about ``2 d``: ``1e-7`` m is a thousandth of the default position
tolerance (``1e-4`` m), and model files whose axes are meant to meet (Romeo, iCub, the
bundled humanoid) meet within ``1e-16`` m. Axes that miss by more get ``lm``: G1's
shoulder axes pass up to 7.5 mm from one point, Unitree H1's up to 9.1 mm (its pitch
and roll axes are 16.5 mm apart; ``docs/limbs.md``)."""


def meeting(anchors: NDArray, axes: NDArray) -> tuple[NDArray[np.float64] | None, float]:
    """The point where the hinge axes ``anchor_i + s axis_i`` meet (``None`` where they
    miss it by more than :data:`MEET_TOL`), and the miss [m]: how far the farthest axis
    passes from the point nearest to all (least squares; ``inf`` for parallel axes,
    which pin no point)."""
    S = axes_meeting_point(anchors, axes, tol=math.inf)
    if S is None:
        return None, math.inf
    off = np.cross(S - np.asarray(anchors), axes)  # each line's offset from S, normal to it
    miss = float(np.linalg.norm(off, axis=1).max())
    return (S if miss <= MEET_TOL else None), miss


def missed_by(miss: float, axes: str = "they") -> str:
    """``"they pass up to 9.06 mm from one point (more than 1e-07 m)"``: why ``axes``
    do not meet, for a refusal."""
    if not math.isfinite(miss):
        return f"{axes} are parallel"
    return f"{axes} pass up to {miss * 1e3:.3g} mm from one point (more than {MEET_TOL:g} m)"


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


# ------------------------------------------------------------------------------ structure
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
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    points = {}
    for name, which, part in (("shoulder", "first", slice(0, 3)), ("wrist", "last", slice(4, 7))):
        P, miss = meeting(anchors[part], axes[part])
        if P is None:
            return (
                f"closed_form needs the {which} three hinge axes to meet at one point (a "
                f"{name}): " + missed_by(miss)
            )
        points[name] = P
    for name, P in points.items():
        if off_line(P, anchors[3], axes[3]) < 1e-9:
            return f"closed_form needs an elbow axis that does not pass through the {name} point"
    for name, part in (("shoulder", slice(0, 3)), ("wrist", slice(4, 7))):
        if parallel_neighbours(axes[part]):
            return f"closed_form needs {name} axes whose neighbours are not parallel"
    return None


def off_line(point: NDArray, anchor: NDArray, axis: NDArray) -> float:
    """Distance [m] from ``point`` to the line ``anchor + s axis`` (unit ``axis``)."""
    return float(np.linalg.norm(np.cross(point - anchor, axis)))


def parallel_neighbours(axes: NDArray) -> bool:
    """Two neighbouring unit axes are parallel (``1 - |cos| < 1e-9``)."""
    return any(abs(float(axes[i] @ axes[i + 1])) > 1.0 - 1e-9 for i in range(len(axes) - 1))


def gravity_down(model: mujoco.MjModel) -> NDArray[np.float64]:
    """The model's unit gravity (world ``-z`` where it is zero): the swivel's zero."""
    g = np.asarray(model.opt.gravity, dtype=np.float64)
    gn = float(np.linalg.norm(g))
    return g / gn if gn > 0 else np.array([0.0, 0.0, -1.0])


def read_geometry(chain: Chain) -> ArmGeometry:
    """The chain's :class:`ArmGeometry` from MuJoCo (the chain must pass
    :func:`structure_problem`); the scratch data's joints are left as they were."""
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    q_keep = chain.q
    chain.set_q(np.zeros(chain.n))
    p0, R0 = chain.position.copy(), chain.rotation.copy()
    chain.set_q(q_keep)
    S, W = meeting(anchors[:3], axes[:3])[0], meeting(anchors[4:], axes[4:])[0]
    assert S is not None and W is not None
    return ArmGeometry(
        shoulder=S,
        shoulder_axes=axes[:3].copy(),
        elbow=anchors[3].copy(),
        elbow_axis=axes[3].copy(),
        wrist=W,
        wrist_axes=axes[4:].copy(),
        hand_offset=R0.T @ (p0 - W),
        R_ee0=R0,
        p_ee0=p0,
        down=gravity_down(chain.model),
    )


# ------------------------------------------------------------------------------ a joint
class Triple:
    """Constants of a three-hinge joint whose unit axes ``u1, u2, u3`` (world, at zero) meet.

    ``R = Rot(u1, q1) Rot(u2, q2) Rot(u3, q3)`` is read back from ``y = R u3`` and
    ``z = R' u1``: ``C = u1 . y = dd + K cos(q2 - base)`` (``dd = d12 d23``) gives
    ``q2 = base +- delta``; ``q1`` turns ``v = Rot(u2, q2) u3`` onto ``y`` about ``u1``
    and ``q3`` turns ``z`` onto ``b = Rot(u2, -q2) u1`` about ``u3``. In the reading
    frames ``(e1, e2, u1)`` and ``(f1, f2, u3)`` these are differences of plane angles,
    ``q1 = angle(y) - angle(v)`` and ``q3 = angle(b) - angle(z)``, so the joint is read
    from five numbers: ``y . e1, y . e2, C, z . f1, z . f2``.

    A hinge stands at a range end ``L`` exactly when a linear form of those numbers
    meets a constant (:attr:`eqs`): ``q1 = L`` iff ``(Rot(u1, L) u2) . y = u2 . u3``;
    ``q2 = L`` iff ``C = u1 . Rot(u2, L) u3``; ``q3 = L`` iff
    ``(Rot(u3, -L) u2) . z = u1 . u2`` (with ``z . u3 = C``). A joint that cannot reach
    every rotation (``|dd| + K < 1``) also stops decomposing where ``C = dd +- K``.

    Every number is a Python float (and every vector a tuple of them), so one-target
    solves stay off numpy.
    """

    def __init__(self, axes: NDArray[np.float64], lower: NDArray, upper: NDArray):
        u1, u2, u3 = (a / np.linalg.norm(a) for a in axes)
        self.u1, self.u2, self.u3 = vec(u1), vec(u2), vec(u3)
        d12, d23, d13 = float(u1 @ u2), float(u2 @ u3), float(u1 @ u3)
        A, B = d13 - d12 * d23, float(u1 @ np.cross(u2, u3))
        self.K = math.hypot(A, B)
        self.invK = 1.0 / self.K
        self.dd = d12 * d23
        base = math.atan2(B, A)
        self.cb, self.sb = math.cos(base), math.sin(base)
        e1 = (u2 - d12 * u1) / np.linalg.norm(u2 - d12 * u1)
        f1 = (u2 - d23 * u3) / np.linalg.norm(u2 - d23 * u3)
        e2, f2 = np.cross(u1, e1), np.cross(u3, f1)
        self.e1, self.e2, self.f1, self.f2 = vec(e1), vec(e2), vec(f1), vec(f2)
        self.y_rows = (*self.e1, *self.e2, *self.u1)
        """``e1, e2, u1``: the rows ``y`` is read with."""
        self.z_rows = (*self.u3, *self.f1, *self.f2)
        """``u3, f1, f2``: the rows ``z`` is read with (``z . u3 = C``)."""
        # Rot(u2, q) u3 = v0 + cos q va + sin q vb; Rot(u2, -q) u1 = b0 + cos q ba + sin q bb
        v0, va, vb = d23 * u2, u3 - d23 * u2, np.cross(u2, u3)
        b0, ba, bb = d12 * u2, u1 - d12 * u2, np.cross(u1, u2)
        self.v = tuple(float(x @ e) for e in (e1, e2) for x in (v0, va, vb))
        self.b = tuple(float(x @ f) for f in (f1, f2) for x in (b0, ba, bb))
        self.always = self.dd - self.K <= -1.0 + 1e-12 and self.dd + self.K >= 1.0 - 1e-12
        """The joint reaches every rotation (``C`` never leaves ``dd +- K``)."""
        self.ortho = abs(d12) < 1e-12 and abs(d23) < 1e-12
        """``u1 _|_ u2 _|_ u3``: then ``sin(delta)`` is ``|y|`` normal to ``u1``."""
        self._ranges(lower, upper)
        self._equations(u1, u2, u3, d12, d23)

    def _ranges(self, lower: NDArray, upper: NDArray) -> None:
        """Range tests: kind 0 always inside, 1 a sector of at most pi, 2 a wider one."""
        self.lower = tuple(float(x) for x in lower)
        self.upper = tuple(float(x) for x in upper)
        kind, ends, center = [], [], []
        for lo, hi in zip(self.lower, self.upper, strict=True):
            finite = math.isfinite(lo) and math.isfinite(hi)
            center.append(0.5 * (lo + hi) if finite else 0.0)
            if not finite or hi - lo + 2 * RANGE_TOL >= TWO_PI:
                kind.append(0)
                ends.append((1.0, 0.0, 1.0, 0.0))
                continue
            kind.append(1 if hi - lo + 2 * RANGE_TOL <= math.pi else 2)
            a, b = lo - RANGE_TOL, hi + RANGE_TOL  # the ends widened by the slack
            ends.append((math.cos(a), math.sin(a), math.cos(b), math.sin(b)))
        self.kind = tuple(kind)
        self.ends = tuple(ends)
        self.center = tuple(center)
        self.inside = tuple(_sector(k, e) for k, e in zip(kind, ends, strict=True))
        """Per hinge ``inside(x, y)``: is the angle of ``(x, y)`` inside the range?"""

    def _equations(self, u1: NDArray, u2: NDArray, u3: NDArray, d12: float, d23: float) -> None:
        """:attr:`eqs`: ``(source, p_a, p_b, p_c, rhs)`` per range end; the left side is
        ``p_a y.e1 + p_b y.e2 + p_c C`` (source 0), ``C`` (1) or
        ``p_a z.f1 + p_b z.f2 + p_c C`` (2)."""
        e1, e2, f1, f2 = (np.array(v) for v in (self.e1, self.e2, self.f1, self.f2))
        eqs: list[tuple[int, float, float, float, float]] = []
        for j in range(3):
            if not self.kind[j]:
                continue
            for L in (self.lower[j], self.upper[j]):
                if j == 0:
                    p = axis_angle_matrix(u1, L) @ u2
                    eqs.append((0, float(p @ e1), float(p @ e2), float(p @ u1), d23))
                elif j == 1:
                    eqs.append((1, 0.0, 0.0, 1.0, float(u1 @ axis_angle_matrix(u2, L) @ u3)))
                else:
                    p = axis_angle_matrix(u3, -L) @ u2
                    eqs.append((2, float(p @ f1), float(p @ f2), float(p @ u3), d12))
        if not self.always:
            eqs += [(1, 0.0, 0.0, 1.0, self.dd + self.K), (1, 0.0, 0.0, 1.0, self.dd - self.K)]
        self.eqs = tuple(eqs)


def _sector(kind: int, ends: tuple[float, float, float, float]) -> Callable[[Real, Real], Real]:
    """``inside(x, y)`` of one hinge: the angle of ``(x, y)`` lies between the widened ends
    (``(cos, sin)`` of the low and the high end): for a sector of at most pi, left of the
    low end and right of the high one; for a wider one, not inside the gap."""
    cl, sl, ch, sh = ends
    if kind == 0:
        return lambda x, y: True
    if kind == 1:
        return lambda x, y: (cl * y - sl * x >= 0.0) & (x * sh - y * ch >= 0.0)
    return lambda x, y: (ch * y - sh * x <= 0.0) | (x * sl - y * cl <= 0.0)


# ------------------------------------------------------------------------------ the forearm
class Forearm(NamedTuple):
    """A point ``P`` carried by the forearm, as the elbow angle ``q4`` moves it.

    ``P(q4) = Pc + cos q4 Pa + sin q4 Pb`` (shoulder at zero) and, by the law of
    cosines, ``|P(q4) - S|^2 = L2 - den cos(q4 - alpha)``. Fields are floats for a
    point fixed on the forearm (the wrist point), arrays for one point per target.
    """

    L2: Real
    """``l1^2 + l2^2 + h^2`` [m^2]."""
    den: Real
    """``2 l1 l2`` [m^2] (at least 1e-300)."""
    alpha: Real
    """Elbow angle [rad] at which the arm is folded (``P`` closest to ``S``)."""
    Pc: Vec
    Pa: Vec
    Pb: Vec
    r_min: Real
    """Inner radius [m] of the shell ``P`` reaches: ``sqrt((l1 - l2)^2 + h^2)``."""
    r_max: Real
    """Outer radius [m]: ``sqrt((l1 + l2)^2 + h^2)``."""

    def at(self, S: Vec, c: Real, s: Real) -> Vec:
        """``P(q4) - S`` at ``(cos q4, sin q4) = (c, s)``."""
        Pc, Pa, Pb = self.Pc, self.Pa, self.Pb
        return (
            Pc[0] + c * Pa[0] + s * Pb[0] - S[0],
            Pc[1] + c * Pa[1] + s * Pb[1] - S[1],
            Pc[2] + c * Pa[2] + s * Pb[2] - S[2],
        )


def forearm(xp: Arithmetic, S: Vec, E: Vec, ue: Vec, P: Vec) -> Forearm:
    """The :class:`Forearm` of point ``P`` (at zero) for shoulder ``S``, elbow anchor
    ``E`` and unit elbow axis ``u_e``.

    With ``a = S - E`` and ``w = P - E`` split along and normal to ``u_e``
    (``a = a_u u_e + a_p``, ``w = w_u u_e + w_p``): ``l1 = |a_p|``, ``l2 = |w_p|``,
    ``h = |a_u - w_u|``, ``alpha = atan2((u_e x w_p) . a_p, w_p . a_p)``;
    ``Pc = E + w_u u_e``, ``Pa = w_p``, ``Pb = u_e x w``.
    """
    a = (S[0] - E[0], S[1] - E[1], S[2] - E[2])
    au = dot(a, ue)
    ap = (a[0] - au * ue[0], a[1] - au * ue[1], a[2] - au * ue[2])
    w = (P[0] - E[0], P[1] - E[1], P[2] - E[2])
    wu = dot(w, ue)
    wp = (w[0] - wu * ue[0], w[1] - wu * ue[1], w[2] - wu * ue[2])
    l1 = math.sqrt(dot(ap, ap))
    l2 = xp.sqrt(dot(wp, wp))
    h = abs(au - wu)
    alpha = xp.atan2(dot(cross(ue, wp), ap), dot(wp, ap))
    den = 2.0 * l1 * l2
    return Forearm(
        L2=l1 * l1 + l2 * l2 + h * h,
        den=xp.where(den > 1e-300, den, 1e-300),
        alpha=alpha,
        Pc=(E[0] + wu * ue[0], E[1] + wu * ue[1], E[2] + wu * ue[2]),
        Pa=wp,
        Pb=cross(ue, w),
        r_min=xp.sqrt((l1 - l2) * (l1 - l2) + h * h),
        r_max=xp.sqrt((l1 + l2) * (l1 + l2) + h * h),
    )


# ------------------------------------------------------------------------------ the context
class Gravity(Protocol):
    """A context with the model's unit gravity (:class:`ArmContext`, ``two_link``'s)."""

    down: Vec


class ArmContext:
    """An :class:`ArmGeometry` and the float constants derived from it, for one chain."""

    def __init__(self, geo: ArmGeometry, lower: NDArray, upper: NDArray):
        self.geo = geo
        self.lower, self.upper = lower.copy(), upper.copy()
        self.sh = Triple(geo.shoulder_axes, lower[:3], upper[:3])
        self.wr = Triple(geo.wrist_axes, lower[4:], upper[4:])
        self.S, self.E, self.ue = vec(geo.shoulder), vec(geo.elbow), vec(geo.elbow_axis)
        self.W0, self.down = vec(geo.wrist), vec(geo.down)
        self.e_rest = vec(geo.elbow - geo.shoulder)
        """``E - S``: the elbow seen from the shoulder at zero."""
        self.hand = vec(geo.hand_offset)
        """``d``: the end effector minus the wrist point, in the end-effector frame."""
        self.hand_rest = vec(geo.p_ee0 - geo.wrist)
        """The end effector minus the wrist point at zero, in the world frame."""
        self.shoulder_axes = tuple(vec(a) for a in geo.shoulder_axes)
        self.wrist_axes = tuple(vec(a) for a in geo.wrist_axes)
        wr = self.wr
        self.wr_hand = tuple(float(x) for v in (wr.u3, wr.f1, wr.f2) for x in geo.R_ee0.T @ v)
        """``R_ee0' u3, R_ee0' f1, R_ee0' f2`` of the wrist: its reading vectors in the
        end-effector frame (9 floats)."""
        self.elbow_lo, self.elbow_hi = float(lower[3]), float(upper[3])
        lo, hi = self.elbow_lo, self.elbow_hi
        self.elbow_center = 0.5 * (lo + hi) if math.isfinite(lo + hi) else 0.0
        self.forearm = forearm(FLOATS, self.S, self.E, self.ue, self.W0)
        """The :class:`Forearm` of the wrist point (pose targets)."""
        self.rest = unit(FLOATS, sub(self.W0, self.S), X_AXIS)
        """Unit ``W0 - S``: the arm's line at zero, for a pose target on the shoulder
        (:func:`~.swivel.rest_direction` of :attr:`forearm`)."""
        self.memo = StartMemo()


class StartMemo:
    """The last start seen by a one-target solve and what it gives (the elbow's place,
    the hand's forearm point): solves from one start again and again (a bench, a still
    arm) do not recompute them. Only one-target solves read and write it (``closed_form``'s
    float path, ``two_link``'s start elbow)."""

    def __init__(self) -> None:
        self.shoulder: tuple = ((), None)
        """``(start shoulder angles, R_sh(q0) (E - S))``."""
        self.wrist: tuple = ((), None)
        """``(start wrist angles, Forearm of the end effector)``."""

    def get(self, slot: str, angles: Sequence[float], make: Callable[[Vec, Vec], T]) -> T:
        """``make(cos, sin)`` of the three ``angles`` [rad], kept in ``slot`` for the
        same angles next time."""
        key = tuple(angles)
        kept = getattr(self, slot)
        if kept[0] == key:
            return kept[1]
        got = make(tuple(map(math.cos, key)), tuple(map(math.sin, key)))  # type: ignore[arg-type]
        setattr(self, slot, (key, got))
        return got


# ------------------------------------------------------------------------------ the cache
class Kept(Generic[C]):
    """What an exact solver keeps with a chain (built once by :meth:`Chain.derived`):
    why it does not apply (``reason``, ``None`` if it does) and its context.

    The structure check never goes stale (a chain's joints are fixed). The context is
    read in world coordinates, so it is read again when a joint on the end effector's
    path that is not in the chain (a free base, a torso hinge, a wrist left out of the
    chain) has moved since it was read; that is the only rule.
    """

    reason: str | None
    seen: list[float] | None = None
    context: C | None = None

    def read(self, chain: Chain) -> C:
        """The context, read from MuJoCo."""
        raise NotImplementedError

    def current(self, chain: Chain) -> C:
        """The chain's context, read again if the arm's base has moved.

        Raises:
            SolverError: the solver does not apply to the chain (the reason).
        """
        if self.reason is not None:
            raise SolverError(self.reason)
        seen = chain.base_state()
        if self.context is None or seen != self.seen:
            self.context = self.read(chain)
            self.seen = seen
        return self.context


class ArmCache(Kept[ArmContext]):
    """What the closed form keeps with a chain: its structure check and
    :class:`ArmContext` (:class:`Kept`)."""

    def __init__(self, chain: Chain):
        self.reason = structure_problem(chain)

    def read(self, chain: Chain) -> ArmContext:
        return ArmContext(read_geometry(chain), chain.lower, chain.upper)


def arm_cache(chain: Chain) -> ArmCache:
    """The chain's :class:`ArmCache` (made on the first call)."""
    return chain.derived("closed_form", ArmCache)


def arm_context(chain: Chain) -> ArmContext:
    """The chain's :class:`ArmContext` (see :meth:`ArmCache.current`)."""
    return chain.derived("closed_form", ArmCache).current(chain)


def arm_geometry(chain: Chain) -> ArmGeometry:
    """The chain's geometry as the closed form uses it (read once, then kept).

    Raises:
        SolverError: the chain has no spherical shoulder, elbow and spherical wrist.
    """
    return arm_context(chain).geo
