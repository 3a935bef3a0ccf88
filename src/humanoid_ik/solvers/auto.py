"""``auto``: the fastest solver that applies to the chain and task, and ``lm`` behind it.

The choice, per chain and task (measured in ``docs/lm.md``):

- a pose target: ``closed_form`` where the chain is a spherical shoulder, an elbow and
  a spherical wrist (its :meth:`~humanoid_ik.solvers.base.Solver.applicable`): exact,
  one pass, the tightest tail; else ``lm``;
- a position target: ``lm`` where its compiled loop runs (:attr:`LM.compiled`): the
  lowest median and mean CPU time per solve on every arm measured, at full success,
  where the closed forms miss 2-6 % of reachable targets;
- a position target with ``lm``'s Python loop: ``closed_form`` as above, else
  ``two_link`` on a chain it places whole (shoulder and elbow hinges, no joint after
  the elbow), else ``lm`` (with joints riding after the elbow ``two_link`` holds them
  and misses reachable targets: 53 % success on the ``models/robot`` waist-and-arm
  chain).

The closed forms of a position target keep the joints they do not place (the wrist)
where they were, so a position target they miss may still be reachable: ``lm`` then
solves it from the same start. A position target ``lm`` misses goes to the closed form
where one applies (its answer to a target beyond reach is the arm stretched towards it,
with the status ``unreachable``), and the closer answer is returned. A pose target
``closed_form`` calls unreachable is unreachable within the ranges (the closed form is
complete), so it is returned as is.

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
    """``closed_form`` for pose targets where it applies, ``lm`` for position targets
    and otherwise (with ``lm``'s Python loop, the closed forms first for position
    targets too, ``lm`` after their miss; see the module docstring).

    Options: ``tol`` and ``rot_tol``, handed to each solver it runs (each keeps its
    other options' defaults).

    Caches: the three solvers it may run, made with the options (their own caches are
    documented with them); the choice per chain and task, kept with the chain
    (:meth:`Chain.derived`, dropped when the chain's model changes).
    """

    name: ClassVar[str] = "auto"
    summary: ClassVar[str] = "closed_form for pose targets where it applies, else lm (recorded)"
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

    @property
    def lm(self) -> LM:
        """The ``lm`` solver ``auto`` runs; its ``compiled`` decides the position rule."""
        return self._lm

    def choice(self, chain: Chain, pose: bool = False, compiled: bool | None = None) -> Solver:
        """The solver ``auto`` runs first on ``chain`` for a pose (or position) target,
        for ``lm``'s compiled or Python loop (default: the loop it runs). The choice is
        kept with the chain (:meth:`Chain.derived`)."""
        compiled = self._lm.compiled if compiled is None else compiled
        key = ("auto", pose, compiled)
        return self._by_name[chain.derived(key, lambda c: self._choose(c, pose, compiled))]

    def _choose(self, chain: Chain, pose: bool, compiled: bool) -> str:
        if not pose and compiled:
            return self._lm.name
        if self._closed_form.applicable(chain, pose) is None:
            return self._closed_form.name
        if self._two_link.applicable(chain, pose) is None and limb_cache(chain).k + 1 == chain.n:
            return self._two_link.name
        return self._lm.name

    def prepare(self, chain: Chain) -> None:
        """Prepare the solvers that may run on ``chain`` (both tasks) before any timed solve."""
        for pose in (False, True):
            for compiled in (True, False):  # the first choice and the second opinion
                self.choice(chain, pose, compiled).prepare(chain)
        self._lm.prepare(chain)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        first = self.choice(chain, target.is_pose)
        result = first._solve(chain, target, q0)
        tried: tuple[str, ...] = (first.name,)
        if not result.converged and not target.is_pose:
            # a closed form's miss goes to lm; lm's miss to the closed form, whose
            # answer to a target out of reach is the arm stretched towards it
            second = self._lm if first is not self._lm else self.choice(chain, False, False)
            if second is not first:
                retry = second._solve(chain, target, q0)
                tried += (second.name,)
                if retry.converged or retry.position_error < result.position_error:
                    result = retry
                else:
                    chain.set_q(result.q)  # the scratch data at the returned pose
        return result.with_details(auto=tried)  # the choice added to its details
