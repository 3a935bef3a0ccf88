"""``auto``: an exact solver where one applies to the chain and task, else ``lm``, and a
second opinion after a miss.

The choice depends on the chain and the target only (measured on real arms in
``docs/benchmarks.md``, "Exact solvers on real arms"); "meet" is within
:data:`~humanoid_ik.solvers.analytic.closed_form.geometry.MEET_TOL`:

- a pose target: ``closed_form`` where the chain is a spherical shoulder, an elbow and
  a spherical wrist (three shoulder axes and three wrist axes that meet: Romeo, iCub,
  the bundled humanoid): exact, one pass, every pose in the ranges; ``subproblem`` on a
  6-hinge chain of a family its subproblems decompose (a spherical wrist or shoulder,
  three parallel axes: Kinova j2s6s200, UR5; ``docs/subproblem.md``): exact, every
  solution, the in-range one nearest the start, on UR5 and Kinova at ``lm``'s median
  CPU or below with a p95 a quarter of ``lm``'s (``benchmarks/peers.py``,
  ``docs/subproblem.md``); else ``lm``, also on a 7-hinge chain ``subproblem`` solves
  by searching its first or last joint (Panda, Talos's arm: the search's CPU median
  measured 0.86-1.19 times ``lm``'s on Panda, PR2, Talos and TIAGo,
  ``benchmarks/searched.py``: faster on two of them, no rule);
- a position target: ``two_link`` where it places the end frame wherever the chain can:
  shoulder axes that meet (or a planar shoulder), an elbow, and nothing after the elbow
  that moves the end frame (no wrist, as on a 4-joint H1-like arm, or an end frame on
  the wrist's axes, as iCub's hand); else ``lm``: the lowest CPU time per solve at full
  success on every arm measured, where the closed forms hold the wrist and miss
  reachable targets (Romeo: 10 %, Kinova: 64 %). Where the shoulder axes nearly meet
  (H1's pass 9 mm from one point), ``two_link`` on the nearest spherical arm as a start
  for an ``lm`` polish was measured: slower than ``lm`` alone at the same success, so
  it is not used.

A position target ``lm`` misses goes to ``closed_form``'s second opinion where it
applies; its answer to a target beyond reach is the arm stretched towards it, with the
status ``unreachable``; the closer of the two answers is returned. The exact solvers'
own misses are returned as they are (they are complete: a target they call
unreachable is unreachable within the ranges); a pose target ``lm`` misses is tried
again by ``lm`` from :data:`RETRY_RESTARTS` further starts of another seed (UR5's
straight-elbow targets, which 21 starts may miss), and the better answer is returned.

The answer records the choice: :attr:`IKResult.solver` names the solver that produced
it, and ``details["auto"]`` lists the solvers tried, in order; :meth:`Auto.reason` says
why (``inspect`` prints it per limb).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.solvers.analytic.closed_form import ClosedForm
from humanoid_ik.solvers.analytic.closed_form.geometry import arm_cache
from humanoid_ik.solvers.analytic.subproblem import Subproblem, subproblem_cache
from humanoid_ik.solvers.analytic.two_link import TwoLink
from humanoid_ik.solvers.analytic.two_link.geometry import limb_cache
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.iterate import pose_cost
from humanoid_ik.solvers.jacobian.lm import LM

__all__ = ["RETRY_RESTARTS", "Auto"]

RETRY_RESTARTS = 100
"""Starts of ``lm``'s second try at a pose target its first try missed."""


class Auto(Solver):
    """``closed_form`` or ``subproblem`` for pose targets and ``two_link`` for position
    targets where they are exact, else ``lm``, then a second opinion after ``lm``'s miss
    (see the module docstring).

    Options: ``tol`` and ``rot_tol``, handed to each solver it runs (each keeps its
    other options' defaults).

    State: the four solvers it may run, made with the options (themselves without
    state); the choice per chain and task is kept with the chain (:meth:`Chain.derived`,
    dropped when the model changes).
    """

    name: ClassVar[str] = "auto"
    summary: ClassVar[str] = (
        "an exact solver where one applies (closed_form, subproblem, two_link), else lm"
    )
    supports_orientation: ClassVar[bool] = True

    def __init__(self, **options: Any):
        super().__init__(**options)
        given = self.options.as_dict()
        self._closed_form = ClosedForm(**given)
        self._two_link = TwoLink(**given)
        self._subproblem = Subproblem(**given)
        self._lm = LM(**given)
        self._lm_retry = LM(**given, restarts=RETRY_RESTARTS, seed=1)
        self._by_name: dict[str, Solver] = {
            s.name: s for s in (self._closed_form, self._two_link, self._subproblem, self._lm)
        }

    def choice(self, chain: Chain, pose: bool = False) -> Solver:
        """The solver ``auto`` runs first on ``chain`` for a pose (or position) target
        (kept with the chain, :meth:`Chain.derived`)."""
        return self._by_name[self._choose(chain, pose)[0]]

    def reason(self, chain: Chain, pose: bool = False) -> str:
        """Why :meth:`choice` is that solver, in a few words."""
        return self._choose(chain, pose)[1]

    @property
    def retry(self) -> LM:
        """The ``lm`` that tries a pose target again after ``lm``'s miss
        (:data:`RETRY_RESTARTS` starts of another seed)."""
        return self._lm_retry

    def second_opinion(self, chain: Chain) -> Solver | None:
        """The solver that tries a position target ``lm`` missed on ``chain``:
        ``closed_form`` where it applies, else ``None``."""
        if self.choice(chain, False) is self._lm and self._closed_form.applicable(chain) is None:
            return self._closed_form
        return None

    def _choose(self, chain: Chain, pose: bool) -> tuple[str, str]:
        return chain.derived(("auto", pose), lambda c: _choose(c, pose))

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
        if result.converged or first is not self._lm:
            pass  # an exact solver's miss is a target out of reach: returned as is
        elif target.is_pose:
            retry = self._lm_retry._solve(chain, target, q0)
            tried += ("lm",)
            if retry.converged or _cost(retry) < _cost(result):
                result = retry
            else:
                chain.set_q(result.q)
        else:
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


def _choose(chain: Chain, pose: bool) -> tuple[str, str]:
    """The first solver for ``chain`` and the task, and why (see the module docstring)."""
    shape = arm_cache(chain).reason
    limb = limb_cache(chain)
    if pose:
        if shape is None:
            return "closed_form", "shoulder and wrist axes meet: exact"
        family = subproblem_cache(chain).family
        if family is not None and family.locked < 0:
            return "subproblem", f"6 hinges, {family.name}: exact"
        if family is not None:
            return "lm", (
                f"7 hinges, subproblem's search ({family.name}) measured no faster than lm "
                "on most arms"
            )
        return "lm", "no exact solver applies to pose targets"
    if limb.reason is None and limb.held is None:
        if limb.k + 1 == chain.n:
            kind = ("planar", "two-hinge", "three-hinge")[limb.k - 1]
            return "two_link", f"a {kind} shoulder whose axes meet and an elbow: exact"
        return "two_link", "the end frame is on the wrist's axes: exact"
    held = [
        name for name, why in (("closed_form", shape), ("two_link", limb.reason)) if why is None
    ]
    if held:
        return "lm", f"{' and '.join(held)} would hold the wrist and miss reachable targets"
    return "lm", "no exact solver applies to position targets"


def _cost(result: IKResult) -> float:
    return pose_cost(result.position_error, result.orientation_error)
