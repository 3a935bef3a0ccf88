"""``auto``: the fastest solver that applies to the chain and task, and ``lm`` behind it.

The choice, per chain and task (measured in ``docs/lm.md``):

- ``closed_form`` where the chain is a spherical shoulder, an elbow and a spherical
  wrist (its :meth:`~humanoid_ik.solvers.base.Solver.applicable`): exact, one pass;
- else ``two_link`` for a position target on a chain it places whole (shoulder and
  elbow hinges, no joint after the elbow): exact, one pass;
- else ``lm``, which solves any hinge chain (with joints riding after the elbow,
  ``two_link`` holds them and misses reachable targets: 53 % success on the
  ``models/robot`` waist-and-arm chain, where ``lm`` reaches all).

The closed forms of a position target keep the joints they do not place (the wrist)
where they were, so a position target they miss may still be reachable: ``lm`` then
solves it from the same start. A pose target ``closed_form`` calls unreachable is
unreachable within the ranges (the closed form is complete), so it is returned as is.

The answer records the choice: :attr:`IKResult.solver` names the solver that produced
it, and ``details["auto"]`` lists the solvers tried, in order.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.solvers.analytic.closed_form import ClosedForm
from humanoid_ik.solvers.analytic.two_link import TwoLink
from humanoid_ik.solvers.analytic.two_link.geometry import limb_cache
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.jacobian.lm import LM

__all__ = ["Auto"]


class Auto(Solver):
    """``closed_form`` where it applies, ``two_link`` for position targets on a chain it
    places whole, ``lm`` otherwise and after a closed form's miss of a position target.

    Options: ``tol`` and ``rot_tol``, handed to each solver it runs (each keeps its
    other options' defaults).

    Caches: the three solvers it may run, made with the options (their own caches are
    documented with them); the choice per chain and task, kept with the chain
    (:meth:`Chain.derived`, dropped when the chain's model changes).
    """

    name: ClassVar[str] = "auto"
    summary: ClassVar[str] = "closed_form or two_link where they apply, else lm (recorded)"
    supports_orientation: ClassVar[bool] = True

    def __init__(self, **options: Any):
        super().__init__(**options)
        given = self.options.as_dict()
        self._closed_form = ClosedForm(**given)
        self._two_link = TwoLink(**given)
        self._lm = LM(**given)
        self._by_name: dict[str, Solver] = {
            s.name: s for s in (self._closed_form, self._two_link, self._lm)
        }

    def choice(self, chain: Chain, pose: bool = False) -> Solver:
        """The solver ``auto`` runs first on ``chain`` for a pose (or position) target
        (the choice is kept with the chain, :meth:`Chain.derived`)."""
        name = chain.derived(("auto", pose), lambda c: self._choose(c, pose))
        return self._by_name[name]

    def _choose(self, chain: Chain, pose: bool) -> str:
        if self._closed_form.applicable(chain, pose) is None:
            return self._closed_form.name
        if self._two_link.applicable(chain, pose) is None and limb_cache(chain).k + 1 == chain.n:
            return self._two_link.name
        return self._lm.name

    def prepare(self, chain: Chain) -> None:
        """Prepare the solvers that may run on ``chain`` (both tasks) before any timed solve."""
        for pose in (False, True):
            self.choice(chain, pose).prepare(chain)
        self._lm.prepare(chain)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        first = self.choice(chain, target.is_pose)
        result = first._solve(chain, target, q0)
        tried: tuple[str, ...] = (first.name,)
        if not result.converged and first is not self._lm and not target.is_pose:
            retry = self._lm._solve(chain, target, q0)
            tried += (self._lm.name,)
            if retry.converged or retry.position_error < result.position_error:
                result = retry
            else:
                chain.set_q(result.q)  # the scratch data at the returned pose
        r = result  # the same result with the choice added to its details
        return IKResult(
            r.q, r.converged, r.iterations, r.position_error, r.orientation_error, r.status,
            r.solver, r.message, {**r.details, "auto": tried},
        )  # fmt: skip
