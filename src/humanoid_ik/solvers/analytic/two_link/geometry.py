"""The limb as ``two_link`` reads it from MuJoCo: which shoulder it has, its points and
axes at the zero pose, the hand's law-of-cosines constants, kept with the chain.

Everything is read in the world frame with the chain's joints at zero. The shoulder is
``k`` hinges (1: a planar arm, the shoulder axis parallel to the elbow's; 2 or 3: axes
meeting at the shoulder point ``S``), joint ``k`` is the elbow, and the joints after it
ride along at their start values. Their values move the hand point ``P`` the elbow
carries, so the hand's constants (:class:`Limb`) are kept per set of riding values.
"""

from __future__ import annotations

import math
from functools import partial
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.solvers.analytic.closed_form.geometry import (
    MEET_TOL,
    Forearm,
    Kept,
    StartMemo,
    Triple,
    forearm,
    gravity_down,
    meeting,
    missed_by,
    off_line,
    parallel_neighbours,
)
from humanoid_ik.solvers.analytic.closed_form.numeric import (
    FLOATS,
    RANGE_TOL,
    TWO_PI,
    Vec,
    cross,
    dot,
    into_range,
    sub,
    vec,
)
from humanoid_ik.solvers.analytic.closed_form.swivel import shoulder_turn

__all__ = [
    "KINDS",
    "Shell",
    "Limb",
    "LimbContext",
    "LimbCache",
    "law_of_cosines",
    "limb_cache",
    "limb_context",
    "place",
    "inside",
    "read_structure",
]

KINDS = {1: "planar", 2: "two_hinge", 3: "three_hinge"}
"""The shoulder kinds by number of shoulder hinges."""


def law_of_cosines(l1: float, l2: float, r: float) -> float:
    """Interior angle ``phi`` [rad] between links ``l1`` and ``l2`` whose ends are ``r`` apart.

    ``r^2 = l1^2 + l2^2 - 2 l1 l2 cos(phi)``; the cosine is clipped to [-1, 1], so a
    target beyond reach gives the straight (``pi``) or folded (``0``) limb.
    """
    c = (l1 * l1 + l2 * l2 - r * r) / (2.0 * l1 * l2)
    return math.acos(max(-1.0, min(1.0, c)))


class Shell(NamedTuple):
    """The elbow geometry of a chain (world frame, shoulder and elbow at zero)."""

    l1: float
    """Upper-arm length normal to the elbow axis [m]."""
    l2: float
    """Forearm-to-end-effector length normal to the elbow axis [m]."""
    h: float
    """Offset between the two along the elbow axis [m] (0 for a planar limb)."""
    alpha: float
    """Elbow angle [rad] at which the limb is folded (distance shortest); straight at
    ``alpha + pi``."""
    r_min: float
    """Inner radius of the reachable shell [m]: ``sqrt((l1 - l2)^2 + h^2)``."""
    r_max: float
    """Outer radius [m]: ``sqrt((l1 + l2)^2 + h^2)``."""


# ------------------------------------------------------------------------------ structure
def read_structure(chain: Chain) -> tuple[int, str | None]:
    """``(k, None)`` with ``k`` the number of shoulder hinges, or ``(0, reason)``.

    Tried in this order, on the axes at zero: three hinges meeting at one point with
    no two neighbours parallel (then joint 3 is the elbow); two non-parallel hinges
    meeting at a point (joint 2 the elbow); one hinge parallel to joint 1's axis and
    apart from it (a planar arm, joint 1 the elbow). The elbow axis must not pass
    through the shoulder point (for a planar arm: must not coincide with its axis), or
    the elbow cannot change the shoulder-to-hand distance. The joints after the elbow
    must be a wrist (:func:`wrist_problem`).
    """
    n = chain.n
    if n < 2:
        return 0, (
            f"two_link needs 1, 2 or 3 shoulder hinges and an elbow hinge; the chain has "
            f"{n} joint(s)"
        )
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    missed = ""
    for k in (3, 2):
        if n < k + 1:
            continue
        S, miss = meeting(anchors[:k], axes[:k])
        if S is None:
            if k == 3:
                missed = "; " + missed_by(miss, "the first three")
            continue
        if parallel_neighbours(axes[:k]):
            return 0, "two_link needs shoulder axes whose neighbours are not parallel"
        if off_line(S, anchors[k], axes[k]) < 1e-9:
            return 0, "two_link needs an elbow axis that does not pass through the shoulder"
        return _with_wrist(chain, anchors, axes, k)
    if parallel_neighbours(axes[:2]):
        if off_line(anchors[0], anchors[1], axes[1]) < 1e-9:
            return 0, (
                "two_link needs an elbow axis that does not pass through the shoulder "
                "(here it lies on the shoulder's axis)"
            )
        return _with_wrist(chain, anchors, axes, 1)
    return 0, (
        "two_link needs shoulder hinge axes that meet at one point (2 or 3 hinges) or a "
        "shoulder hinge parallel to the elbow's (a planar arm)" + missed
    )


def _with_wrist(chain: Chain, anchors: NDArray, axes: NDArray, k: int) -> tuple[int, str | None]:
    """``(k, None)`` when the joints after the elbow ``k`` are a wrist, else ``(0, why)``."""
    why = wrist_problem(chain, anchors, axes, k)
    return (0, why) if why is not None else (k, None)


MAX_WRIST = 3
"""The most hinges a wrist has."""


def wrist_problem(chain: Chain, anchors: NDArray, axes: NDArray, k: int) -> str | None:
    """Why the joints after the elbow (joint ``k``) are not a wrist, or ``None``.

    ``two_link`` places the end effector with the shoulder and the elbow and holds the
    joints after the elbow at their start values. That misses few targets the chain
    reaches only when those joints are a wrist: at most :data:`MAX_WRIST` hinges whose
    axes meet at one point ``W`` (one hinge: any point of its axis). The elbow carries
    ``W`` whatever the wrist does, and the wrist moves the end effector by at most its
    distance from ``W`` (0 for a hand at ``W``: the chain's whole workspace is reached;
    0.08 m for the humanoid's palm: 1.8 % of random targets are missed). Anything else
    after the elbow (a second arm segment, an offset wrist, the arm itself when the
    shoulder found is a torso's) moves the hand far: such a chain is refused.

    Args:
        chain: the chain.
        anchors, axes: its joints' world anchors and unit axes ``(n, 3)`` at zero.
        k: the elbow's index.
    """
    rest = list(range(k + 1, chain.n))
    if not rest:
        return None
    names = chain.joint_names
    after = f"the {len(rest)} joint(s) after the elbow '{names[k]}'"
    fix = (
        "; two_link holds them at their start values and would miss targets they reach "
        "(choose the arm's shoulder, elbow and wrist with --joints / joints=)"
    )
    if len(rest) > MAX_WRIST:
        return f"two_link needs a wrist of at most {MAX_WRIST} hinges after the elbow; {after}{fix}"
    if len(rest) > 1 and meeting(anchors[rest], axes[rest])[0] is None:
        listed = ", ".join(f"'{names[i]}'" for i in rest)
        return (
            f"two_link needs the joints after the elbow to be a wrist, their axes meeting at "
            f"one point; those of {listed} (after the elbow '{names[k]}') do not{fix}"
        )
    return None


def held_wrist(chain: Chain, k: int) -> str | None:
    """Why ``two_link`` misses targets the chain reaches (its wrist, joints ``k + 1 ..``,
    held at the start moves the end frame), or ``None`` where it reaches them all: no
    joint after the elbow ``k``, or an end frame on the wrist's axes (within
    :data:`~humanoid_ik.solvers.analytic.closed_form.geometry.MEET_TOL`; iCub's hand).
    """
    rest = list(range(k + 1, chain.n))
    if not rest:
        return None
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    keep = chain.q
    hand = chain.fk(np.zeros(chain.n))[0]
    chain.set_q(keep)
    W = meeting(anchors[rest], axes[rest])[0] if len(rest) > 1 else None
    off = (
        float(np.linalg.norm(hand - W))
        if W is not None
        else max(off_line(hand, anchors[i], axes[i]) for i in rest)
    )
    if off <= MEET_TOL:
        return None
    return (
        f"two_link holds the {len(rest)} joint(s) after the elbow at their start and the "
        f"end frame is {off * 1e3:.3g} mm off their axes: it misses targets they reach"
    )


# ------------------------------------------------------------------------------ the hand
class Limb(NamedTuple):
    """The hand point ``P`` as the elbow moves it, for one set of riding joint values."""

    fa: Forearm
    """``P(qe) = Pc + cos qe Pa + sin qe Pb`` (shoulder at zero) and the law of cosines
    ``|P(qe) - S|^2 = L2 - den cos(qe - alpha)``."""
    S: Vec
    """The shoulder point [m]; for a planar arm the point of the shoulder axis in the
    hand's plane (normal to the axis)."""
    shell: Shell
    """Lengths and the reachable shell."""
    frame: tuple[Vec, Vec]
    """Planar arm: ``x`` (unit upper arm at zero, in the plane) and ``y = a x x``;
    otherwise the world's x and y."""


def _limb(ctx: LimbContext, P0: Vec) -> Limb:
    """The :class:`Limb` of hand point ``P0`` (world, chain at zero)."""
    S, E, ue = ctx.S, ctx.E, ctx.ue
    if ctx.k == 1:  # the shoulder axis's point in the hand's plane: no offset along it
        a = ctx.axes[0]
        z = dot(sub(P0, S), a)
        S = (S[0] + z * a[0], S[1] + z * a[1], S[2] + z * a[2])
    fa = forearm(FLOATS, S, E, ue, P0)
    au, wu = dot(sub(S, E), ue), dot(sub(P0, E), ue)
    ap = sub(sub(S, E), (au * ue[0], au * ue[1], au * ue[2]))
    l1, l2, h = math.sqrt(dot(ap, ap)), math.sqrt(dot(fa.Pa, fa.Pa)), abs(au - wu)
    shell = Shell(l1, l2, h, float(fa.alpha), float(fa.r_min), float(fa.r_max))
    frame: tuple[Vec, Vec] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    if ctx.k == 1:
        a = ctx.axes[0]
        x = sub(E, S)
        d = dot(x, a)
        x = (x[0] - d * a[0], x[1] - d * a[1], x[2] - d * a[2])
        nx = math.sqrt(dot(x, x))
        x = (x[0] / nx, x[1] / nx, x[2] / nx)
        frame = (x, cross(a, x))
    return Limb(fa, S, shell, frame)


# ------------------------------------------------------------------------------ the context
class LimbContext:
    """The chain's structure and geometry as Python floats (world frame, joints at zero).

    Attributes:
        k: shoulder hinges (1, 2 or 3); joint ``k`` is the elbow.
        kind: ``planar``, ``two_hinge`` or ``three_hinge``.
        S: shoulder point [m] (planar: the shoulder axis's anchor).
        axes: the ``k`` unit shoulder axes, proximal first.
        E, ue: elbow anchor [m] and unit axis.
        e_rest: ``E - S``.
        down: unit gravity (world ``-z`` when gravity is zero): the twist's zero.
        lower, upper: joint ranges [rad] (``-inf``/``inf`` when unlimited).
        tri: the three-hinge shoulder's constants (ranges, range-end equations), or
            ``None``.
    """

    def __init__(self, chain: Chain, k: int):
        anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
        self.k = k
        self.kind = KINDS[k]
        S = anchors[0] if k == 1 else meeting(anchors[:k], axes[:k])[0]
        assert S is not None
        self.S = vec(S)
        self.axes = tuple(vec(a) for a in axes[:k])
        self.E, self.ue = vec(anchors[k]), vec(axes[k])
        self.e_rest = sub(self.E, self.S)
        self.down = vec(gravity_down(chain.model))
        self.lower = tuple(float(x) for x in chain.lower)
        self.upper = tuple(float(x) for x in chain.upper)
        self.tri = Triple(axes[:3], chain.lower[:3], chain.upper[:3]) if k == 3 else None
        self._limbs: dict[tuple[float, ...], Limb] = {}
        self.memo = StartMemo()

    def limb(self, chain: Chain, riding: tuple[float, ...]) -> Limb:
        """The :class:`Limb` with the joints after the elbow at ``riding`` [rad].

        Kept per riding values (at most 64 sets, the oldest dropped first): a solve
        from the same wrist (a bench, a tracked target) reads MuJoCo once. Reading one
        runs ``mj_kinematics`` on the scratch data (chain joints at zero, riding joints
        at ``riding``).
        """
        got = self._limbs.get(riding)
        if got is not None:
            return got
        z = np.zeros(chain.n)
        z[self.k + 1 :] = riding
        chain.set_q(z)
        got = _limb(self, vec(chain.position))
        if len(self._limbs) >= 64:
            del self._limbs[next(iter(self._limbs))]
        self._limbs[riding] = got
        return got

    def start_elbow(self, q0: list[float]) -> Vec:
        """``R_sh(q0) (E - S)``: the start's elbow seen from a three-hinge shoulder
        (remembered for the last start)."""
        return self.memo.get("shoulder", q0[:3], partial(shoulder_turn, self.axes, v=self.e_rest))


# ------------------------------------------------------------------------------ ranges
def place(q: float, lo: float, hi: float, pref: float) -> float:
    """``q`` shifted by whole turns: into a range narrower than a turn when it fits
    (next to its middle), else next to ``pref`` and then into a wider range.

    ``q + 2 pi round((m - q) / 2 pi)`` with ``m`` the range's middle for a narrow
    range, ``pref`` otherwise.
    """
    narrow = hi - lo < TWO_PI  # False for an unlimited joint (inf - -inf)
    if narrow and lo <= q <= hi:
        return q
    m = 0.5 * (lo + hi) if narrow else pref
    x = into_range(FLOATS, q, m)
    if not narrow:
        if x < lo - RANGE_TOL:
            x += TWO_PI * math.ceil((lo - x) / TWO_PI)
        elif x > hi + RANGE_TOL:
            x -= TWO_PI * math.ceil((x - hi) / TWO_PI)
    return x


def inside(q: float, lo: float, hi: float) -> bool:
    """``lo <= q <= hi`` with the range slack (1e-9 rad)."""
    return lo - RANGE_TOL <= q <= hi + RANGE_TOL


# ------------------------------------------------------------------------------ the cache
class LimbCache(Kept[LimbContext]):
    """What ``two_link`` keeps with a chain: the shoulder it has, why ``two_link`` does
    not apply, and the :class:`LimbContext` (:class:`~..closed_form.geometry.Kept`)."""

    def __init__(self, chain: Chain):
        self.k, self.reason = read_structure(chain)
        """Shoulder hinges, and why ``two_link`` does not apply (``None`` if it does)."""
        self.held = None if self.reason is not None else held_wrist(chain, self.k)
        """Why ``two_link`` misses targets the chain reaches (:func:`held_wrist`), ``None``
        where it is exact: it then places the end frame wherever the chain can."""

    def read(self, chain: Chain) -> LimbContext:
        return LimbContext(chain, self.k)


def limb_cache(chain: Chain) -> LimbCache:
    """The chain's :class:`LimbCache` (made on the first call)."""
    return chain.derived("two_link", LimbCache)


def limb_context(chain: Chain) -> LimbContext:
    """The chain's :class:`LimbContext` (see :meth:`LimbCache.current`).

    Raises:
        SolverError: the chain is not a two-link limb.
    """
    return chain.derived("two_link", LimbCache).current(chain)
