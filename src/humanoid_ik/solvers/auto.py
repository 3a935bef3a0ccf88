"""``auto``: the fastest solver that applies to the chain and task, and a second opinion
after a miss.

The choice depends on the chain and the target only (measured in ``docs/lm.md``):

- a pose target: ``closed_form`` where the chain is a spherical shoulder, an elbow and
  a spherical wrist (its :meth:`~humanoid_ik.solvers.base.Solver.applicable`): exact,
  one pass, the tightest tail; else ``lm``;
- a position target: ``lm``: the lowest median and mean CPU time per solve on every
  arm measured, at full success, where the closed forms miss 2-6 % of reachable
  targets (they keep the wrist where it was).

A position target ``lm`` misses goes to a second opinion where one applies:
``closed_form`` as above, else ``two_link`` on a chain it places whole (shoulder and
elbow hinges, no joint after the elbow); their answer to a target beyond reach is the
arm stretched towards it, with the status ``unreachable``. The closer of the two answers
is returned. A pose target ``closed_form`` calls unreachable is unreachable within the
ranges (the closed form is complete), so it is returned as is; a pose target ``lm``
misses is tried again by ``lm`` from :data:`RETRY_RESTARTS` further starts of another
seed (UR5's straight-elbow targets, which 21 starts may miss), and the better of the
two answers is returned.

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
from humanoid_ik.solvers.iterate import pose_cost
from humanoid_ik.solvers.jacobian.lm import LM

__all__ = ["RETRY_RESTARTS", "Auto"]

RETRY_RESTARTS = 100
"""Starts of ``lm``'s second try at a pose target its first try missed."""


class Auto(Solver):
    """``closed_form`` for pose targets where it applies, else ``lm``; for position
    targets ``lm``, then a closed form's second opinion after a miss (see the module
    docstring).

    Options: ``tol`` and ``rot_tol``, handed to each solver it runs (each keeps its
    other options' defaults).

    State: the three solvers it may run, made with the options (themselves without
    state); the choice per chain and task is kept with the chain (:meth:`Chain.derived`,
    dropped when the model changes).
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
        self._lm_retry = LM(**given, restarts=RETRY_RESTARTS, seed=1)
        self._by_name: dict[str, Solver] = {
            s.name: s for s in (self._closed_form, self._two_link, self._lm)
        }

    def choice(self, chain: Chain, pose: bool = False) -> Solver:
        """The solver ``auto`` runs first on ``chain`` for a pose (or position) target
        (kept with the chain, :meth:`Chain.derived`)."""
        key = ("auto", pose)
        return self._by_name[chain.derived(key, lambda c: self._choose(c, pose))]

    def second_opinion(self, chain: Chain) -> Solver | None:
        """The solver that tries a position target ``lm`` missed on ``chain``, ``None``
        where no closed form applies (kept with the chain)."""
        name = chain.derived(("auto", "second_opinion"), self._second)
        return None if name is None else self._by_name[name]

    def _choose(self, chain: Chain, pose: bool) -> str:
        if pose and self._closed_form.applicable(chain, pose) is None:
            return self._closed_form.name
        return self._lm.name

    def _second(self, chain: Chain) -> str | None:
        if self._closed_form.applicable(chain, False) is None:
            return self._closed_form.name
        if self._two_link.applicable(chain, False) is None and limb_cache(chain).k + 1 == chain.n:
            return self._two_link.name
        return None

    def prepare(self, chain: Chain) -> None:
        """Prepare the solvers that may run on ``chain`` (both tasks and the second
        opinion) before any timed solve."""
        for pose in (False, True):
            self.choice(chain, pose).prepare(chain)
        second = self.second_opinion(chain)
        if second is not None:
            second.prepare(chain)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        first = self.choice(chain, target.is_pose)
        result = first._solve(chain, target, q0)
        tried: tuple[str, ...] = (first.name,)
        if not result.converged and target.is_pose and first is self._lm:
            retry = self._lm_retry._solve(chain, target, q0)
            tried += ("lm",)
            if retry.converged or _cost(retry) < _cost(result):
                result = retry
            else:
                chain.set_q(result.q)
        elif not result.converged and not target.is_pose:
            # lm's miss to the closed form, whose answer to a target out of reach is the
            # arm stretched towards it
            second = self.second_opinion(chain)
            if second is not None:
                retry = second._solve(chain, target, q0)
                tried += (second.name,)
                if retry.converged or retry.position_error < result.position_error:
                    result = retry
                else:
                    chain.set_q(result.q)  # the scratch data at the returned pose
        return result.with_details(auto=tried)  # the choice added to its details


def _cost(result: IKResult) -> float:
    return pose_cost(result.position_error, result.orientation_error)
