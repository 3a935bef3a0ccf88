"""A 6-hinge chain as the subproblem solver reads it, and the family it belongs to.

Read from MuJoCo once, at the chain's zero configuration, in the chain's *base frame*
(the frame of the body its first hinge's body hangs from), in the product-of-exponentials
form: unit axes ``h1..h6``, a point ``p1..p6`` on each axis (MuJoCo's joint anchors) and
the end frame ``(R0, p0)``. The base frame makes the geometry independent of the joints
off the chain (a torso hinge, a free base): a solve reads only the base's world pose,
again only when those joints have moved (:meth:`SubproblemCache.base`).

Families (:func:`family_of`), tried in this order, each also on the chain reversed
(base and end swapped, so a spherical shoulder is a spherical wrist of the reversed
chain):

- ``spherical wrist``: axes 4, 5, 6 meet in one point (within
  :data:`~humanoid_ik.solvers.analytic.closed_form.geometry.MEET_TOL`, the closed form's
  rule), and the first three axes place that point by two subproblems: ``h2 || h3``
  (Kinova j2s6s200, most industrial arms), ``h1 || h2``, or two neighbouring axes that
  meet (``h1`` and ``h2``, ``h2`` and ``h3``);
- ``three parallel axes``: ``h2 || h3 || h4`` (the UR family), with ``h1`` and ``h5``
  not parallel to them; the wrist may be anything (where axes 5 and 6 meet, as on the UR
  arms, ``q1`` and ``q5`` come from two SP4s instead of SP6's quartic).

A 7-hinge chain is solved with its last (else its first) joint *locked*: if the six
other joints are a family above, the locked joint is searched (in C): its start value
first, then 0.25 rad steps outwards with two bisections back towards the start, else
0.002 rad steps to the ends of its range, until at some value one of the six-joint
solutions fits the ranges (the 1-D search of IK-Geo and IKFast's free
joint; Panda with its last joint locked is a spherical shoulder with ``h5`` and ``h6``
meeting, Talos's arm with its first a spherical wrist with ``h2`` and ``h3`` meeting).

Axes are *parallel* within :data:`PARALLEL_TOL` (the sine of their angle). Any other
6- or 7-hinge chain gets a reason, said by ``inspect`` and used by ``auto``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.closed_form.geometry import meeting
from humanoid_ik.solvers.analytic.subproblem import _subproblem

__all__ = [
    "PARALLEL_TOL",
    "ArmGeometry",
    "Family",
    "SubproblemCache",
    "arm_geometry",
    "family_of",
    "subproblem_cache",
]

PARALLEL_TOL = 1e-7
"""Axes whose directions differ by less than this (the sine of their angle) are
*parallel*. The subproblems are exact for parallel axes; axes off by ``d`` give answers
off by about ``d`` times the arm's length before the Newton polish of every solution
(in C) brings them back to rounding, so the tolerance only has to keep the
decomposition's roots close: UR5's axes are parallel within 1e-11."""


class ArmGeometry(NamedTuple):
    """A 6-hinge chain at its zero configuration, in its base frame."""

    axes: NDArray[np.float64]
    """Unit axes ``h1..h6`` ``(6, 3)``, one per row."""
    points: NDArray[np.float64]
    """A point on each axis ``(6, 3)`` [m] (MuJoCo's joint anchors)."""
    end_rotation: NDArray[np.float64]
    """The end frame's rotation ``R0`` ``(3, 3)``."""
    end_position: NDArray[np.float64]
    """The end frame's origin ``p0`` ``(3,)`` [m]."""


class Family(NamedTuple):
    """How a chain decomposes into subproblems."""

    family: int
    """0: a spherical wrist, 1: three parallel axes (as the C module numbers them)."""
    case: int
    """Family 0, the wrist point's placement: 0 ``h2 || h3``, 1 ``h1 || h2``, 2 ``h1``
    and ``h2`` meet, 3 ``h2`` and ``h3`` meet. Family 1: 0 in general, 1 where axes 5 and 6
    meet."""
    reverse: bool
    """The chain is solved reversed (base and end swapped)."""
    wrist: NDArray[np.float64]
    """The wrist point (family 0) in the base frame, in the solved order."""
    meet: NDArray[np.float64]
    """Where the two placing axes meet (family 0, cases 2 and 3), or axes 5 and 6
    (family 1, case 1)."""
    name: str
    """The family in words, in the chain's own joint numbers."""
    locked: int = -1
    """A 7-hinge chain's joint held and searched over: 0 (the first) or 6 (the last);
    -1 on a 6-hinge chain."""


def arm_geometry(chain: Chain) -> tuple[ArmGeometry, NDArray[np.float64]]:
    """The chain's :class:`ArmGeometry` and its base's world pose (12 floats: position,
    row-major rotation), read at the zero configuration; the scratch data's joints are
    put back."""
    keep = chain.q
    chain.set_q(np.zeros(chain.n))
    anchors, axes = chain.joint_axes()
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    p0, R0 = chain.position.copy(), chain.rotation.copy()
    base = base_pose(chain)
    chain.set_q(keep)
    Rb, pb = base[3:].reshape(3, 3), base[:3]
    geo = ArmGeometry(
        axes=axes @ Rb,
        points=(anchors - pb) @ Rb,
        end_rotation=Rb.T @ R0,
        end_position=Rb.T @ (p0 - pb),
    )
    return geo, base


def base_pose(chain: Chain) -> NDArray[np.float64]:
    """The world pose of the chain's base frame from the last kinematics pass: position
    and row-major rotation (12 floats)."""
    m, d = chain.model, chain.data
    body = int(m.body_parentid[m.jnt_bodyid[chain.joint_ids[0]]])
    return np.concatenate([d.xpos[body], d.xmat[body]])


def _parallel(a: NDArray, b: NDArray) -> bool:
    return float(np.linalg.norm(np.cross(a, b))) < PARALLEL_TOL


def family_of(geo: ArmGeometry) -> tuple[Family | None, str]:
    """The chain's :class:`Family`, or ``None`` and why none applies: 6 hinges, or 7 with
    the last (else the first) locked (``Family.locked``)."""
    n = geo.axes.shape[0]
    if n == 7:
        for locked in (6, 0):
            keep = [i for i in range(7) if i != locked]
            six = ArmGeometry(geo.axes[keep], geo.points[keep], geo.end_rotation, geo.end_position)
            family, _ = _six(six, 1 if locked == 0 else 0)
            if family is not None:
                name = f"{family.name}, joint {locked + 1} searched"
                return family._replace(locked=locked, name=name), ""
        return None, (
            "subproblem: 7 hinges, and neither the first nor the last held leaves six of a "
            "family it decomposes (a spherical wrist or shoulder, three parallel axes)"
        )
    if n != 6:
        return None, f"subproblem needs 6 or 7 hinges; the chain has {n} joint(s)"
    return _six(geo, 0)


def _six(geo: ArmGeometry, offset: int) -> tuple[Family | None, str]:
    """:func:`family_of` of six hinges, named with their numbers plus ``offset``."""
    forward = _family(geo.axes, geo.points, False, offset)
    if forward is not None:
        return forward, ""
    backward = _family(-geo.axes[::-1], geo.points[::-1], True, offset)
    if backward is not None:
        return backward, ""
    W = meeting(geo.points[3:], geo.axes[3:])[0]
    S = meeting(geo.points[:3], geo.axes[:3])[0]
    if W is not None or S is not None:
        which = "4-6" if W is not None else "1-3"
        return None, (
            f"subproblem: axes {which} meet but the other three axes have no parallel or "
            "meeting neighbours to place that point (a general 3R position, not solved)"
        )
    return None, (
        "subproblem needs a spherical wrist or shoulder (three axes that meet) or three "
        "parallel neighbouring axes (2-4 or 3-5); the chain has neither"
    )


def _family(h: NDArray, p: NDArray, reverse: bool, offset: int) -> Family | None:
    """The family of the chain ``(h, p)`` in the solved order, or ``None``; named with
    the chain's joint numbers (the six's plus ``offset``)."""

    def number(i: int) -> int:  # the chain's own number of the solved order's axis i
        return (7 - i if reverse else i) + offset

    def axes(*solved: int, sep: str) -> str:  # the chain's own numbers, ascending
        return sep.join(f"h{k}" for k in sorted(number(i) for i in solved))

    zero = np.zeros(3)
    W, _ = meeting(p[3:], h[3:])
    if W is not None and not _parallel(h[3], h[4]) and not _parallel(h[4], h[5]):
        meet = ", ".join(str(k) for k in sorted(number(i) for i in (4, 5, 6)))
        kind = f"spherical {'shoulder' if reverse else 'wrist'} (axes {meet} meet)"
        cases: list[tuple[int, bool, NDArray | None, str]] = [
            (0, _parallel(h[1], h[2]) and not _parallel(h[0], h[1]), None, axes(2, 3, sep=" || ")),
            (1, _parallel(h[0], h[1]) and not _parallel(h[0], h[2]), None, axes(1, 2, sep=" || ")),
        ]
        for case, (i, j) in ((2, (0, 1)), (3, (1, 2))):
            O = None if _parallel(h[i], h[j]) else meeting(p[[i, j]], h[[i, j]])[0]
            cases.append((case, O is not None, O, axes(i + 1, j + 1, sep=" and ") + " meet"))
        for case, ok, O, words in cases:
            if ok:
                name = f"{kind}, {words}"
                return Family(0, case, reverse, W, zero if O is None else O, name)
    if (
        _parallel(h[1], h[2])
        and _parallel(h[2], h[3])
        and not _parallel(h[0], h[1])
        and not _parallel(h[4], h[1])
    ):
        name = f"three parallel axes ({axes(2, 3, 4, sep=' || ')})"
        O, _ = meeting(p[4:], h[4:])
        if O is not None and not _parallel(h[4], h[5]):  # SP4 + SP4 for q1, q5, not SP6
            return Family(1, 1, reverse, zero, O, f"{name}, {axes(5, 6, sep=' and ')} meet")
        return Family(1, 0, reverse, zero, zero, name)
    return None


class SubproblemCache:
    """What the solver keeps with a chain (:meth:`Chain.derived`): the family (or why
    none applies), the compiled :class:`~._subproblem.Arm`, and the base's world pose
    with the joints off the chain it was read at.

    The joints on the end frame's path that are not the chain's are followed: those
    above the chain (a torso, a free base) move only its base, so the base pose is read
    again when they have moved; one between the chain's joints changes the arm itself,
    which is then read again whole (its family too)."""

    def __init__(self, chain: Chain):
        self.family: Family | None = None
        self.arm: _subproblem.Arm | None = None
        self.seen = chain.base_state()
        self.inner = False
        """A joint off the chain lies between its joints."""
        if chain.n not in (6, 7):
            self.reason: str | None = (
                f"subproblem needs 6 or 7 hinges; the chain has {chain.n} joint(s)"
            )
            return
        path = chain.path_joint_ids.tolist()  # tip first
        mine = set(chain.joint_ids.tolist())
        root = max(path.index(j) for j in mine)
        self.inner = any(j not in mine for j in path[:root])
        self._read(chain)

    def _read(self, chain: Chain) -> None:
        geo, base = arm_geometry(chain)
        family, why = family_of(geo)
        self.reason = None if family is not None else why
        """Why no exact decomposition applies to the chain, or ``None``."""
        self._base = base
        self.family, self.arm = family, None
        if family is None:
            return
        h, p = geo.axes, geo.points
        k = family.locked
        line = (h[k].copy(), p[k].copy()) if k >= 0 else (None, None)  # the locked joint's
        if k >= 0:  # the six others
            h, p = np.delete(h, k, axis=0), np.delete(p, k, axis=0)
        if family.reverse:
            h, p = -h[::-1], p[::-1]
        self.arm = _subproblem.Arm(
            family.family,
            family.case,
            family.reverse,
            np.ascontiguousarray(h).ravel(),
            np.ascontiguousarray(p).ravel(),
            np.ascontiguousarray(geo.end_rotation).ravel(),
            np.ascontiguousarray(geo.end_position),
            np.ascontiguousarray(family.wrist, dtype=np.float64),
            np.ascontiguousarray(family.meet, dtype=np.float64),
            k,
            *line,
        )

    def current(self, chain: Chain) -> tuple[_subproblem.Arm, NDArray[np.float64]]:
        """The compiled arm and the base's world pose (12 floats), read again when a
        joint off the chain has moved since (see the class docstring).

        Raises:
            SolverError: no exact decomposition applies to the chain.
        """
        if self.seen is not None:
            seen = chain.base_state()
            if seen != self.seen:
                if self.inner:
                    self._read(chain)
                else:
                    chain.set_q(chain.q)  # the kinematics of the joints as they are now
                    self._base = base_pose(chain).copy()
                self.seen = seen
        if self.arm is None:
            raise SolverError(str(self.reason))
        return self.arm, self._base


def subproblem_cache(chain: Chain) -> SubproblemCache:
    """The chain's :class:`SubproblemCache` (made on the first call)."""
    return chain.derived("subproblem", SubproblemCache)
