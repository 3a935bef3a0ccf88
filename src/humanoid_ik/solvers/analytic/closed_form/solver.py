"""The ``closed_form`` solver: one target through the float path, the batch driver for
what that path leaves (out of reach, out of range, gimbal lock)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.closed_form.batch import solve_chunk
from humanoid_ik.solvers.analytic.closed_form.geometry import ArmContext, arm_cache, arm_context
from humanoid_ik.solvers.analytic.closed_form.numeric import FLOATS, sub
from humanoid_ik.solvers.analytic.closed_form.single import Fallback, solve_one
from humanoid_ik.solvers.analytic.closed_form.swivel import swivel_frame, wrist_target
from humanoid_ik.solvers.analytic.elbow import arm_points, pole_search, pole_verdict
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["ClosedForm", "ClosedFormOptions"]


@dataclass(frozen=True)
class ClosedFormOptions(SolverOptions):
    """Options of ``closed_form``.

    Attributes:
        swivel: the elbow's swivel angle about the shoulder-wrist line [rad], or
            ``None`` for the in-range swivel nearest the start.
    """

    swivel: float | None = None
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "swivel": (-2.0 * math.pi, 2.0 * math.pi)
    }
    """A swivel is an angle: one turn either way names every elbow position."""

    def __post_init__(self) -> None:
        sw = self.swivel
        if sw is None:
            return
        if isinstance(sw, bool) or not isinstance(sw, (int, float)) or not math.isfinite(sw):
            raise SolverError(
                "option 'swivel' of solver 'closed_form' must be a finite angle in "
                f"[rad] or None, got {sw!r}"
            )
        object.__setattr__(self, "swivel", float(sw))


class ClosedForm(Solver):
    """Closed-form pose IK of a 7-hinge arm with the swivel as the free parameter.

    Exact (to rounding) on any chain of three hinges meeting at a shoulder point, an
    elbow hinge and three hinges meeting at a wrist point, with the axes read from
    MuJoCo. Among all joint vectors that reach the target inside the joint ranges it
    returns one at the swivel closest to ``swivel`` (default: the starting elbow's
    swivel), with the shoulder and wrist branches closest to the start.

    Position targets: the wrist keeps its starting angles and the shoulder and elbow
    place the end effector (the hand rides along as part of the forearm).

    An elbow pole (``Target.pole``) sets the swivel: the elbow in the plane of the
    shoulder, the wrist and the pole, on the pole's side (for a pose target the pole's
    own angle about the shoulder-wrist line; for a position target, whose wrist is off
    the swivel's axis, that angle corrected by :func:`~..elbow.pole_search`). Where
    the ranges forbid that swivel the nearest feasible one is taken. ``details`` give
    ``pole_swivel`` (wanted), ``swivel`` (taken), ``pole_error`` [rad]
    (:func:`~..elbow.pole_angle` at the answer) and ``pole``: ``honoured``, or
    ``nearest feasible swivel (joint ranges)``. A pole overrides the ``swivel`` option.

    A target beyond the shell the wrist point can reach, or one for which no swivel
    keeps every joint in range, is ``unreachable``: the arm is stretched (or folded)
    toward it, at the least violating branch moved inside the ranges.

    Caches: the chain keeps the structure check and the geometry
    (:class:`~.geometry.ArmCache`); :meth:`prepare` builds them.
    """

    name: ClassVar[str] = "closed_form"
    honours_pole: ClassVar[bool] = True
    summary: ClassVar[str] = "closed form: law of cosines + elbow swivel, exact joint ranges"
    supports_orientation: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = ClosedFormOptions
    options: ClosedFormOptions

    def __init__(self, **options: Any):
        super().__init__(**options)
        sw = self.options.swivel
        self._psi = None if sw is None else np.array([sw])

    def prepare(self, chain: Chain) -> None:
        """Check the chain's structure and read its geometry (kept with the chain)."""
        if arm_cache(chain).reason is None:
            arm_context(chain)

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        return arm_cache(chain).reason

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        if target.pole is not None:
            return self._solve_pole(chain, target, q0, target.pole)
        return self._at(chain, target, q0, self.options.swivel, self._psi)[0]

    def _solve_pole(
        self, chain: Chain, target: Target, q0: NDArray[np.float64], pole: NDArray[np.float64]
    ) -> IKResult:
        """The answer at the swivel that honours ``pole`` (see the class docstring)."""
        ctx = arm_context(chain)
        S = ctx.S
        if target.rotation is not None:
            t = wrist_target(ctx, target.position.tolist(), target.rotation.tolist())
        else:
            t = sub(target.position.tolist(), S)
        _, r, k = nrk = swivel_frame(FLOATS, ctx, t, ctx.rest)
        found = pole_search(
            chain, lambda w: self._at(chain, target, q0, w, np.array([w])), S, nrk, pole
        )
        if found is None:
            res = self._at(chain, target, q0, self.options.swivel, self._psi)[0]
            return res.with_details(pole="undefined: the pole lies on the shoulder-wrist line")
        (res, got), want, err = found
        pts = arm_points(chain, res.q)  # the chain at the answer
        if got is None:  # the batch driver: the swivel as the elbow shows it
            e = pts.elbow - pts.shoulder
            got = math.atan2(float(e @ k), float(e @ r))
        how = pole_verdict(err, res.status, "nearest feasible swivel (joint ranges)")
        return res.with_details(pole=how, pole_error=err, pole_swivel=want, swivel=got)

    def _at(
        self,
        chain: Chain,
        target: Target,
        q0: NDArray[np.float64],
        swivel: float | None,
        psi: NDArray[np.float64] | None,
    ) -> tuple[IKResult, float | None]:
        """The answer at the feasible swivel nearest ``swivel`` (``psi``: the same as an
        array, for the batch driver), and the swivel taken (``None`` from the batch)."""
        ctx = arm_context(chain)
        rot = None if target.rotation is None else target.rotation.tolist()
        try:
            q, got = solve_one(ctx, target.position.tolist(), rot, q0.tolist(), swivel)
        except Fallback:
            return self._batch(chain, ctx, target, q0, psi), None
        return self._result(chain, target, np.array(q), 1), got

    def _batch(
        self,
        chain: Chain,
        ctx: ArmContext,
        target: Target,
        q0: NDArray[np.float64],
        psi: NDArray[np.float64] | None,
    ) -> IKResult:
        """What the one-target path leaves: the batch driver on one target."""
        R = None if target.rotation is None else target.rotation[None]
        res = solve_chunk(ctx, target.position[None], R, q0[None], psi)
        q1 = res.q[0]
        if res.miss[0] > 0.0:
            where = "inside the inner hole of" if res.inner[0] else "beyond"
            point = "wrist point" if R is not None else "end effector (wrist kept)"
            r_min, r_max = res.setup.shell[0][0], res.setup.shell[1][0]
            msg = (
                f"the target puts the {point} {res.miss[0]:.6g} m {where} the reachable "
                f"shell [{r_min:.4f}, {r_max:.4f}] m around the shoulder"
            )
            return self._result(chain, target, q1, 1, status=Status.UNREACHABLE, message=msg)
        if not res.feasible[0]:
            if not res.elbow_ok[0]:
                msg = (
                    f"the elbow angle this target needs is outside its range "
                    f"[{ctx.elbow_lo:.4g}, {ctx.elbow_hi:.4g}] rad"
                )
            else:
                msg = "no swivel angle keeps every shoulder and wrist joint inside its range"
            return self._result(chain, target, q1, 1, status=Status.UNREACHABLE, message=msg)
        return self._result(chain, target, q1, 1)
