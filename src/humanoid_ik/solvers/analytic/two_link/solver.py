"""The ``two_link`` solver: the elbow by the law of cosines, the shoulder in closed form,
every branch, joint ranges, and the worksheet's intermediate values on the result."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.analytic.closed_form.numeric import Vec
from humanoid_ik.solvers.analytic.elbow import arm_points, pole_angle, pole_search, pole_verdict
from humanoid_ik.solvers.analytic.two_link.geometry import (
    Limb,
    LimbContext,
    Shell,
    inside,
    limb_cache,
    limb_context,
)
from humanoid_ik.solvers.analytic.two_link.shoulders import (
    Candidate,
    angle_axis_method,
    elbow_branches,
    hand,
    planar,
    polar_method,
    three_hinge,
    twist_frame,
    two_hinge,
)
from humanoid_ik.solvers.base import Solver, error_buffers
from humanoid_ik.solvers.options import SolverOptions, option

__all__ = ["TwoLink", "TwoLinkOptions", "Solution", "Details"]

BOUNDARY_TOL = 1e-9  # [m]: a target this close to what the limb reaches counts as reached


@dataclass(frozen=True)
class TwoLinkOptions(SolverOptions):
    """Options of ``two_link``.

    Attributes:
        method: the three-hinge shoulder's preferred twist about the shoulder-target
            line: ``nearest`` (the elbow closest to where it was at the start),
            ``polar`` or ``angle_axis`` (the worksheet method's shoulder rotation). The
            twist kept is the feasible one nearest it. Planar and two-hinge shoulders
            have no twist to choose and ignore it.
        branch: the elbow branch: ``auto`` (the in-range solution nearest the start),
            ``negative`` (``theta2 = phi - pi``, the worksheet's) or ``positive``
            (``theta2 = pi - phi``); ``theta2`` is the elbow's turn from the straight limb.
        shoulder: two- and three-hinge shoulders: ``auto``, ``plus`` or ``minus`` (see
            :attr:`Solution.shoulder`).
    """

    method: str = option("nearest", valid=("nearest", "polar", "angle_axis"))
    branch: str = option("auto", valid=("auto", "positive", "negative"))
    shoulder: str = option("auto", valid=("auto", "plus", "minus"))


class Solution(NamedTuple):
    """One joint vector that ``two_link`` finds for a target (see :meth:`TwoLink.solutions`)."""

    q: NDArray[np.float64]
    """Joint values ``(n,)`` [rad] (joints after the elbow at the start's values)."""
    inside: bool
    """Every joint inside its range (1e-9 rad slack)."""
    elbow: str
    """``negative``, ``positive`` or ``both`` (straight or folded elbow)."""
    shoulder: str
    """``plus``, ``minus``, ``both`` or ``""`` (planar: one shoulder angle)."""
    distance: float
    """``|q - q0|`` over the shoulder and elbow [rad]."""
    twist: float | None
    """Three-hinge shoulder: the twist [rad] about the shoulder-target line (0: the
    elbow toward gravity), else ``None``."""


class _Reach(NamedTuple):
    """What the target fixes before any branch: distances and the elbow's cosine."""

    t: Vec
    """Target minus shoulder point [m]."""
    r: float
    """Shoulder-to-target distance [m] (planar: in the arm's plane)."""
    cos_e: float
    """``(L2 - r^2) / den``, unclipped: outside [-1, 1] beyond the shell."""
    miss: float
    """Distance [m] outside the shell (0 inside)."""


class TwoLink(Solver):
    """Analytic shoulder + elbow solve of a two-link limb, in closed form.

    The chain is a shoulder of 1, 2 or 3 hinges (1: parallel to the elbow's axis, a
    planar arm; 2 or 3: axes meeting at the shoulder point ``S``), an elbow hinge, and
    any joints after it, which keep their start values and ride along.

    Elbow: with ``a = S - E`` and ``w = P - E`` (elbow anchor ``E``, hand ``P``, all at
    zero) split along and normal to the elbow axis,
    ``|S - P(qe)|^2 = l1^2 + l2^2 + h^2 - 2 l1 l2 cos(qe - alpha)``, so
    ``qe = alpha +- phi`` with ``phi = law_of_cosines(l1, l2, sqrt(r^2 - h^2))`` the
    interior angle and ``theta2 = qe - (alpha + pi) = +-(phi - pi)`` the turn from the
    straight limb (the worksheet's ``theta2z = phi - pi``).

    Shoulder (:mod:`.shoulders`): planar ``theta1 = theta_t1 -+ theta_t2`` (the report);
    two hinges, the two solutions of ``Rot(a1, q1) Rot(a2, q2) v = w``; three hinges,
    the feasible twist nearest the preferred one (``method``), decomposed on the axes.

    Every branch is computed; the answer is the one inside the ranges nearest the start
    (``|q - q0|``), within the chosen ``branch`` and ``shoulder``. ``unreachable`` when
    the target is outside the shell (the distance is given), off a planar arm's plane,
    outside a two-hinge shoulder's band, or when no branch fits the ranges; the limb
    then stretches (or folds) toward the target on the least violating branch, moved
    inside the ranges.

    An elbow pole (``Target.pole``) chooses among them: a three-hinge shoulder's twist
    is the pole's angle about the shoulder-target line (corrected by
    :func:`~..elbow.pole_search` when a wrist puts the wrist point off that line; the
    nearest feasible twist where the ranges forbid it), and among the branches
    (elbow and shoulder, within the ``branch`` and ``shoulder`` options) the one inside
    the ranges whose elbow is nearest the pole's plane is kept (ties: nearest the
    start). ``details`` then add ``pole`` (``honoured``, or why not), ``pole_error``
    [rad] (:func:`~..elbow.pole_angle`) and, for a three-hinge shoulder,
    ``pole_twist``. Without a pole nothing changes.

    The result's ``details`` hold the intermediate values (``docs/two_link.md``).

    Caches: the chain keeps the structure and the geometry
    (:class:`~.geometry.LimbCache`, read again when a joint off the chain moves the
    limb), and the hand's constants per set of riding joint values; :meth:`prepare`
    builds them for the chain's current values.
    """

    name: ClassVar[str] = "two_link"
    honours_pole: ClassVar[bool] = True
    summary: ClassVar[str] = "analytic: law of cosines, planar/2-/3-hinge shoulder in closed form"
    Options: ClassVar[type[SolverOptions]] = TwoLinkOptions
    options: TwoLinkOptions

    # ------------------------------------------------------------------ structure
    def prepare(self, chain: Chain) -> None:
        """Check the structure, read the geometry and the hand's constants for the
        chain's current joints after the elbow (kept with the chain)."""
        cache = limb_cache(chain)
        if cache.reason is None:
            q_keep = chain.q
            ctx = cache.current(chain)
            ctx.limb(chain, tuple(q_keep[ctx.k + 1 :].tolist()))
            chain.set_q(q_keep)

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        reason = super().applicable(chain, pose)
        if reason is not None:
            return reason
        return limb_cache(chain).reason

    @staticmethod
    def structure_problem(chain: Chain) -> str | None:
        """Why the chain is not a two-link limb (see :func:`~.geometry.read_structure`),
        or ``None``."""
        return limb_cache(chain).reason

    @staticmethod
    def kind(chain: Chain) -> str:
        """The chain's shoulder: ``planar``, ``two_hinge`` or ``three_hinge``.

        Raises:
            SolverError: the chain is not a two-link limb.
        """
        return limb_context(chain).kind

    def shell(self, chain: Chain, q0: ArrayLike | None = None) -> Shell:
        """Elbow geometry and reachable shell with the joints after the elbow at ``q0``'s
        values (default: the chain's current ones).

        Raises:
            SolverError: the chain is not a two-link limb.
            TargetError: a bad ``q0``.
        """
        q = chain.q if q0 is None else chain.check_q(q0)
        ctx = limb_context(chain)
        shell = ctx.limb(chain, tuple(q[ctx.k + 1 :].tolist())).shell
        chain.set_q(q)
        return shell

    # ------------------------------------------------------------------ solve
    def solutions(
        self, chain: Chain, target: Target | ArrayLike, q0: ArrayLike | None = None
    ) -> list[Solution]:
        """Every joint vector ``two_link`` finds that puts the end effector on ``target``,
        in the order it prefers them: inside the ranges first, then nearest ``q0``
        (default the chain's joints); the options ``branch`` and ``shoulder`` are not
        applied.

        Planar: one per elbow branch; two-hinge: two per elbow branch whose band holds
        the target's direction (one on its edge); three-hinge: both decompositions at
        each elbow branch's kept twist. Empty when the target is out of reach (beyond
        the shell, off a planar arm's plane, outside every band).

        Raises:
            SolverError: the chain is not a two-link limb.
            TargetError: a bad target or ``q0``.
        """
        tgt = Target.of(target)
        start = chain.clip(chain.q if q0 is None else chain.check_q(q0))
        ctx = limb_context(chain)
        q0l = start.tolist()
        limb = ctx.limb(chain, tuple(q0l[ctx.k + 1 :]))
        reach = _reach(ctx, limb, tgt.position.tolist())
        elbows = elbow_branches(ctx, limb, reach.cos_e, q0l)
        cands, info = self._candidates(ctx, limb, reach, q0l, elbows, every_branch=True)
        chain.set_q(start)
        if reach.miss > BOUNDARY_TOL or info.get("off_plane", 0.0) > BOUNDARY_TOL:
            return []
        out = []
        for c in sorted(cands, key=_order(q0l)):
            if c.gap > BOUNDARY_TOL:
                continue
            q = np.array(q0l)
            q[: ctx.k + 1] = c.q
            out.append(Solution(q, c.inside, c.elbow, c.shoulder, _distance(c, q0l), c.twist))
        return out

    def _candidates(
        self,
        ctx: LimbContext,
        limb: Limb,
        reach: _Reach,
        q0: list[float],
        elbows: list,
        every_branch: bool = False,
        prefer: float | None = None,
    ) -> tuple[list[Candidate], dict[str, Any]]:
        if ctx.k == 1:
            return planar(ctx, limb, reach.t, q0, elbows)
        if ctx.k == 2:
            return two_hinge(ctx, limb, reach.t, q0, elbows)
        # a chosen shoulder branch needs both decompositions to choose from
        every = every_branch or self.options.shoulder != "auto"
        return three_hinge(ctx, limb, reach.t, q0, elbows, self.options.method, every, prefer)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        pole = target.pole
        if pole is None:
            return self._at(chain, target, q0, None, None)
        ctx = limb_context(chain)
        if ctx.k != 3:  # no twist: the pole picks the branch
            res = self._at(chain, target, q0, pole, None)
            return _with_pole(chain, res, pole)
        q0l = q0.tolist()
        limb = ctx.limb(chain, tuple(q0l[4:]))
        t = _reach(ctx, limb, target.position.tolist()).t
        found = pole_search(
            chain,
            lambda w: self._at(chain, target, q0, pole, w),
            limb.S,
            twist_frame(ctx, limb, t),
            pole,
            tries=4 if ctx.k + 1 < chain.n else 1,  # no wrist: the hand is on the axis
        )
        if found is None:
            res = self._at(chain, target, q0, None, None)
            return res.with_details(pole="undefined: the pole lies on the shoulder-target line")
        return _with_pole(chain, found[0], pole, pole_twist=found[1])

    def _at(
        self,
        chain: Chain,
        target: Target,
        q0: NDArray[np.float64],
        pole: NDArray[np.float64] | None,
        prefer: float | None,
    ) -> IKResult:
        """The answer (see the class docstring): with ``pole``, the branches ordered by
        the pole's angle to the elbow's plane; ``prefer``, a three-hinge shoulder's
        preferred twist [rad]."""
        ctx = limb_context(chain)
        k, o = ctx.k, self.options
        q0l = q0.tolist()
        limb = ctx.limb(chain, tuple(q0l[k + 1 :]))
        reach = _reach(ctx, limb, target.position.tolist())
        elbows = elbow_branches(ctx, limb, reach.cos_e, q0l)
        if o.branch != "auto":
            elbows = [e for e in elbows if e[1] in (o.branch, "both")]
        # the elbows inside their range first; the others only if none of those fits
        lo, hi = ctx.lower[k], ctx.upper[k]
        first = [e for e in elbows if inside(e[0], lo, hi)]
        later = [e for e in elbows if not inside(e[0], lo, hi)]
        if not first:
            first, later = later, []
        found, info = self._candidates(ctx, limb, reach, q0l, first, prefer=prefer)
        cands = self._chosen_shoulder(found, k)
        if later and not any(c.inside for c in cands):
            more, more_info = self._candidates(ctx, limb, reach, q0l, later, prefer=prefer)
            found += more
            cands += self._chosen_shoulder(more, k)
            for key, value in more_info.items():
                if isinstance(value, dict):
                    info[key] = {**value, **info[key]}
        if not cands:  # the chosen shoulder branch has none: the others, out of the running
            cands = [c._replace(inside=False, violation=math.inf) for c in found]
        if not cands:
            # a three-hinge shoulder whose axes reach no rotation pointing the limb there
            cands = [Candidate(tuple(q0l[: k + 1]), True, 0.0, "both", "both", None, math.inf)]
        order = _order(q0l) if pole is None else _pole_order(chain, q0l, pole)
        best = cands[0] if len(cands) == 1 else min(cands, key=order)
        qs = list(best.q)
        if not best.inside:  # the least violating branch, moved inside the ranges (or the
            # other shoulder branch's answer when the chosen one has none)
            qs = [min(max(x, ctx.lower[i]), ctx.upper[i]) for i, x in enumerate(qs)]
        q = np.array(qs + q0l[k + 1 :])
        status, message = self._verdict(chain, ctx, limb, reach, info, best)
        # Solver._result, with the details: measured by core.measures.pose_error
        chain.set_q(q)
        ep, _ = pose_error(
            chain.position, chain.rotation, target.position, None, *error_buffers(chain)
        )
        if status is None:
            status = Status.CONVERGED if ep < o.tol else Status.MAX_ITERATIONS
        elif best.gap > 0.0 and math.isfinite(best.gap):
            message += f"; the arm is turned to the band's edge, {ep:.6g} m away"
        details = _details(ctx, limb, reach, elbows, info, best)
        return IKResult(
            q, status is Status.CONVERGED, 1, ep, None, status, self.name, message, details
        )

    def _chosen_shoulder(self, cands: list[Candidate], k: int) -> list[Candidate]:
        """The candidates on the ``shoulder`` option's branch (all for ``auto`` or a
        planar arm)."""
        want = self.options.shoulder
        if want == "auto" or k == 1:
            return cands
        return [c for c in cands if c.shoulder in (want, "both")]

    def _verdict(
        self,
        chain: Chain,
        ctx: LimbContext,
        limb: Limb,
        reach: _Reach,
        info: dict[str, Any],
        best: Candidate,
    ) -> tuple[Status | None, str]:
        """The status (``None``: from the tolerances) and message of the answer."""
        sh = limb.shell
        off = info.get("off_plane", 0.0)
        if reach.miss > BOUNDARY_TOL:
            where = "beyond" if reach.r > sh.r_max else "inside the inner hole of"
            msg = (
                f"target is {reach.miss:.6g} m {where} the reachable shell "
                f"[{sh.r_min:.4f}, {sh.r_max:.4f}] m around the shoulder"
            )
            if ctx.k == 1:
                msg += f" axis (in the arm's plane; {off:.6g} m off the plane)"
            return Status.UNREACHABLE, msg
        if off > BOUNDARY_TOL:
            return Status.UNREACHABLE, (
                f"target is {off:.6g} m off the planar arm's plane (normal to the shoulder "
                "axis through the hand), which no joint leaves"
            )
        if best.gap > BOUNDARY_TOL:
            if not math.isfinite(best.gap):
                return Status.UNREACHABLE, (
                    "the three shoulder hinges reach no rotation that points the limb at the target"
                )
            bands = sorted({(round(lo, 4), round(hi, 4)) for lo, hi in info["bands"].values()})
            where = " and ".join(f"[{lo:.4f}, {hi:.4f}]" for lo, hi in bands)
            return Status.UNREACHABLE, (
                f"the target's direction is {info['theta_t']:.4f} rad from the first "
                f"shoulder axis, outside the band{'s' if len(bands) > 1 else ''} {where} rad "
                "the two-hinge shoulder reaches at this distance (one per elbow branch)"
            )
        if best.violation == math.inf:
            return Status.UNREACHABLE, (
                f"the chosen shoulder '{self.options.shoulder}' has no solution for this "
                "target (only the other shoulder branch reaches it)"
            )
        if not best.inside:
            o = self.options
            chosen = [f"{n} '{getattr(o, n)}'" for n in ("branch", "shoulder")]
            chosen = [c for c in chosen if not c.endswith("'auto'")]
            msg = "no shoulder and elbow angles inside the joint ranges reach the target"
            if chosen:
                msg += f" on the chosen {' and '.join(chosen)}"
            return Status.UNREACHABLE, msg + _worst_joint(chain, ctx, best)
        return None, ""


def _reach(ctx: LimbContext, limb: Limb, p: list[float]) -> _Reach:
    """:class:`_Reach` of target position ``p``: ``r = |t|`` (planar: ``t`` normal to the
    shoulder axis), ``cos_e = (L2 - r^2) / den``, ``miss = max(r - r_max, r_min - r, 0)``."""
    S, fa = limb.S, limb.fa
    t = (p[0] - S[0], p[1] - S[1], p[2] - S[2])
    r2 = t[0] * t[0] + t[1] * t[1] + t[2] * t[2]
    if ctx.k == 1:
        a = ctx.axes[0]
        z = t[0] * a[0] + t[1] * a[1] + t[2] * a[2]
        r2 = max(r2 - z * z, 0.0)
    r = math.sqrt(r2)
    sh = limb.shell
    miss = max(r - sh.r_max, sh.r_min - r, 0.0)
    return _Reach(t, r, (fa.L2 - r2) / fa.den, miss)


def _order(q0: list[float]) -> Callable[[Candidate], tuple]:
    """The preference among candidates: inside the ranges, then the smallest band gap,
    then the least range violation, then nearest ``q0``."""
    return lambda c: (not c.inside, c.gap, c.violation, _distance(c, q0))


def _pole_order(
    chain: Chain, q0: list[float], pole: NDArray[np.float64]
) -> Callable[[Candidate], tuple]:
    """:func:`_order` with the pole's angle to the candidate's elbow plane (in steps of
    1e-6 rad, so that equal planes tie) before the distance to the start."""

    def key(c: Candidate) -> tuple:
        a = pole_angle(arm_points(chain, list(c.q) + q0[len(c.q) :]), pole)
        a = round(0.0 if math.isnan(a) else a * 1e6)
        return (not c.inside, c.gap, c.violation, a, _distance(c, q0))

    return key


def _with_pole(chain: Chain, res: IKResult, pole: NDArray[np.float64], **extra: Any) -> IKResult:
    """``res`` with the pole's figures in its details (the chain left at ``res.q``)."""
    err = pole_angle(arm_points(chain, res.q), pole)
    why = "nearest feasible twist (joint ranges)" if extra else "nearest branch (no twist)"
    return res.with_details(pole=pole_verdict(err, res.status, why), pole_error=err, **extra)


def _distance(c: Candidate, q0: list[float]) -> float:
    """``|q - q0|`` over the candidate's shoulder and elbow [rad]."""
    return math.sqrt(sum((a - b) * (a - b) for a, b in zip(c.q, q0, strict=False)))


def _worst_joint(chain: Chain, ctx: LimbContext, c: Candidate) -> str:
    """``" (nearest: joint 'name' at x rad, range [lo, hi])"`` for the candidate's joint
    furthest outside its range."""
    worst, j = 0.0, -1
    for i, x in enumerate(c.q):
        v = max(ctx.lower[i] - x, x - ctx.upper[i], 0.0)
        if v > worst:
            worst, j = v, i
    if j < 0:
        return ""
    return (
        f" (nearest branch: joint '{chain.joint_names[j]}' at {c.q[j]:.4f} rad, range "
        f"[{ctx.lower[j]:.4g}, {ctx.upper[j]:.4g}])"
    )


class Details(Mapping[str, Any]):
    """The intermediate values of a ``two_link`` answer: a read-only mapping (the
    result's ``details``; keys in ``docs/two_link.md``).

    A three-hinge shoulder's worksheet values, ``polar`` (:class:`~.shoulders.Polar`)
    and ``angle_axis`` (:class:`~.shoulders.AngleAxis`), are computed from the limb
    ``v`` and the target ``t`` when first read, so a solve whose details nobody reads
    does not pay for them.
    """

    __slots__ = ("_values", "_v", "_t")

    def __init__(self, values: dict[str, Any], v: Vec | None = None, t: Vec | None = None):
        self._values = values
        self._v, self._t = v, t

    def __getitem__(self, key: str) -> Any:
        got = self._values.get(key, _MISSING)
        if got is not _MISSING:
            return got
        if self._v is not None and self._t is not None and key in _WORKSHEET:
            got = _WORKSHEET[key](self._v, self._t)
            self._values[key] = got
            return got
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        yield from self._values
        if self._v is not None:
            yield from (k for k in _WORKSHEET if k not in self._values)

    def __len__(self) -> int:
        lazy = 0 if self._v is None else sum(k not in self._values for k in _WORKSHEET)
        return len(self._values) + lazy

    def __repr__(self) -> str:
        return f"Details({dict(self)!r})"


_MISSING = object()
_WORKSHEET: dict[str, Callable[[Vec, Vec], Any]] = {
    "polar": polar_method,
    "angle_axis": angle_axis_method,
}


def _details(
    ctx: LimbContext,
    limb: Limb,
    reach: _Reach,
    elbows: list,
    info: dict[str, Any],
    best: Candidate,
) -> Details:
    """The intermediate values of the answer (see ``docs/two_link.md``)."""
    k = ctx.k
    theta2 = 0.0
    for e in elbows:
        if e[1] == best.elbow:
            theta2 = e[2]
    d: dict[str, Any] = {
        "kind": ctx.kind,
        "r": reach.r,
        "shell": (limb.shell.r_min, limb.shell.r_max),
        "phi": math.acos(max(-1.0, min(1.0, reach.cos_e))),
        "theta2": theta2,
        "elbow": best.q[k],
        "branch": best.elbow,
        "shoulder": best.shoulder,
    }
    if k == 1:
        d.update(info)
        d["theta1"] = best.q[0]
        return Details(d)
    if k == 2:
        d["theta_t"] = info["theta_t"]
        d["epsilon"] = info["epsilon"]
        d["band"] = info["bands"].get(best.elbow, (math.nan, math.nan))
        return Details(d)
    d["twist"] = best.twist
    d["twist_preferred"] = info["twist_preferred"].get(best.elbow)
    v = info["hands"].get(best.elbow) or hand(limb, best.q[k])
    return Details(d, v, reach.t)
