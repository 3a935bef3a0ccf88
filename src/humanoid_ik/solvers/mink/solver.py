"""The ``mink`` solver: differential IK as a quadratic program through mink and daqp.

:class:`MinkSolver` (``"mink"``) is the :class:`~humanoid_ik.solvers.base.Solver` of the
package, usable by name in ``solve``, ``bench``, sweeps, scenes and the CLI. It runs an
:class:`~humanoid_ik.solvers.mink.upper_body.UpperBodyIK` on one chain (``solve``), or
on every effector of a scene that names it at once (``solve_effectors``: the ``reach``
hands and one ``look_at`` gaze in one QP per step). The QP of one step is described in
:mod:`humanoid_ik.solvers.mink.problem`.

This module does not import mink; building the first :class:`UpperBodyIK` does.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import EffectorGoal, IKResult, Target
from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.mink.upper_body import DEFAULT_COLLISION_PAIRS, NAME, UpperBodyIK
from humanoid_ik.solvers.options import SolverOptions, option

__all__ = ["MinkOptions", "MinkSolver", "UpperBodyIK"]

_TASKS = ("reach", "look_at")
EffectorsKey = tuple[tuple[Chain, int, bool], ...]
"""Each goal's chain, its ``version`` (a model changed since rebuilds) and whether it looks."""
"""The goals' chains (by identity) and whether each is a ``look_at``, in goal order."""


@dataclass(frozen=True)
class MinkOptions(SolverOptions):
    """Options of ``mink`` (see :class:`UpperBodyIK` for the costs and gains).

    Attributes:
        max_iterations: QP steps per start.
        restarts: further starts (seeded random poses) after a stall.
        seed: seed of the random restarts.
        max_step: largest joint move per step [rad].
        stall_window: steps without a 1 % gain that count as a stall.
        posture_cost, posture_gain: the pull toward ``home``.
        orientation_cost: weight of the orientation error [1/rad].
        damping, lm_damping: QP regularisation and Levenberg-Marquardt damping.
        collisions: keep the bundled humanoid's collision pairs apart.
        dt: with ``dt > 0`` [s] each scene frame is one tracking step of ``dt``.
        max_velocity: joint speed limit of tracking steps [rad/s].
        qp_solver: the qpsolvers backend.
        forward_axis: the axis (``x``, ``y`` or ``z``) of the ``look_at`` site's frame
            that is aimed at the target (:meth:`MinkSolver.gaze_axis`).
    """

    max_iterations: int = 200
    restarts: int = 20
    seed: int = 0
    max_step: float = 0.2
    stall_window: int = 10
    posture_cost: float = 1e-3
    posture_gain: float = 0.1
    orientation_cost: float = 0.5
    damping: float = 1e-12
    lm_damping: float = 0.0
    collisions: bool = False
    dt: float = 0.0
    max_velocity: float = 4.0
    qp_solver: str = "daqp"
    forward_axis: str = option("x", valid=("x", "y", "z"))

    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "max_iterations": (0, 100_000),
        "restarts": (0, 1_000),
        "stall_window": (0, 100_000),
        "max_step": (0.0, 2.0 * math.pi),
        "dt": (0.0, 10.0),
        "max_velocity": (0.0, 1e3),
    }
    """Steps, restarts and the stall window bound a solve's time; a step larger than a
    turn, a tracking step over 10 s or a joint speed over 1000 rad/s is an input
    mistake."""


class MinkSolver(Solver):
    """Differential IK as a QP through mink on one chain, or on several at once.

    On one chain (:meth:`solve`): a task on the chain's end effector (position, or pose
    with ``orientation_cost``), a posture task toward ``home`` and joint range limits;
    the model's joints outside the chain are frozen by an equality constraint and keep
    their values exactly. Iterates QP steps (each joint moving at most ``max_step``
    [rad] per step) until within ``tol`` / ``rot_tol``, restarting from seeded random
    in-range poses after a stall (``restarts``).

    On several chains (:meth:`solve_effectors`, the scene runner's hook): every
    ``reach`` effector gets a hand task and one ``look_at`` effector the gaze task, all
    in one QP per step. With ``dt`` > 0 each call is one tracking step of ``dt`` [s]
    under the joint velocity limit ``max_velocity`` (set ``dt`` to the scene's frame
    time); with ``dt = 0`` each call iterates to convergence.

    The gaze axis: ``forward_axis`` (``x``, ``y`` or ``z``; default ``x``) names the
    axis of the ``look_at`` site's frame that is aimed at the target: the gaze task
    drives ``e = R a - (p* - p) / |p* - p|`` to zero with ``a`` that unit axis
    (:class:`~humanoid_ik.solvers.mink.tasks.GazeTask`). :meth:`gaze_axis` returns ``a``,
    and the runner measures the gaze error about the same axis.

    With ``collisions`` the chains also keep the bundled humanoid's collision pairs
    apart (:data:`~humanoid_ik.solvers.mink.upper_body.DEFAULT_COLLISION_PAIRS`); use
    :class:`UpperBodyIK` directly for other geom names. Off by default so that the
    bench's random targets (some of which put the hand inside the torso) stay
    comparable with the other solvers.

    Caches: the solver keeps two :class:`UpperBodyIK` objects (each with its own
    ``mink.Configuration``, tasks, limits and per-active-set QP problems), built on
    first use or ahead of time by :meth:`prepare` / :meth:`prepare_effectors`:

    - for :meth:`solve`: the one of the last chain given, rebuilt when another
      :class:`~humanoid_ik.core.chain.Chain` object (identity, not equality) is given;
    - for :meth:`solve_effectors`: the one of the last goals, keyed by their chains
      (identity) and whether each is a ``look_at``, in order; rebuilt when that key
      changes.

    Nothing else makes them stale: the options are frozen when the solver is made, a
    chain's model, joints and ranges are fixed when the chain is made, and every call
    sets the full ``qpos`` it starts from (the chain's scratch ``qpos`` with ``q0``, or
    the goals' warm starts), so no joint value carries over from one call to the next.
    """

    name: ClassVar[str] = NAME
    summary: ClassVar[str] = "differential IK as a QP through mink (daqp), limits as constraints"
    supports_orientation: ClassVar[bool] = True
    solves_effectors: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = MinkOptions
    options: MinkOptions
    _forwarded: ClassVar[tuple[str, ...]] = (
        "tol",
        "rot_tol",
        "max_iterations",
        "max_step",
        "stall_window",
        "posture_cost",
        "posture_gain",
        "orientation_cost",
        "damping",
        "lm_damping",
        "max_velocity",
        "qp_solver",
    )

    def __init__(self, **options: Any):
        super().__init__(**options)
        self._cache: tuple[Chain, int, UpperBodyIK] | None = None
        """The :meth:`solve` cache: (chain, its UpperBodyIK)."""
        self._multi_cache: tuple[EffectorsKey, UpperBodyIK] | None = None
        """The :meth:`solve_effectors` cache: (goals key, their UpperBodyIK)."""

    def _build(
        self, model: mujoco.MjModel, hands: Sequence[Chain], gaze: Chain | None
    ) -> UpperBodyIK:
        """A new :class:`UpperBodyIK` with this solver's options."""
        opts = {k: getattr(self.options, k) for k in self._forwarded}
        return UpperBodyIK(
            model,
            hands=tuple(hands),
            gaze=gaze,
            collision_pairs=DEFAULT_COLLISION_PAIRS if self.options.collisions else None,
            gaze_axis=self.gaze_axis(),
            **opts,
        )

    # ------------------------------------------------------------------ one chain
    def upper_body(self, chain: Chain) -> UpperBodyIK:
        """The :class:`UpperBodyIK` this solver runs on ``chain`` (see the caches above).

        Raises:
            SolverError: a bad option value (e.g. an unknown ``qp_solver``).
        """
        if self._cache is not None and self._cache[0] is chain:
            if self._cache[1] == chain.version:
                return self._cache[2]
        ik = self._build(chain.model, (chain,), None)
        self._cache = (chain, chain.version, ik)
        return ik

    def prepare(self, chain: Chain) -> None:
        """Build the :class:`UpperBodyIK` of ``chain`` and its QP problems (position and
        pose targets), and import mink, so a later timed :meth:`solve` pays for none of it.

        Raises:
            SolverError: a bad option value (e.g. an unknown ``qp_solver``).
        """
        self.upper_body(chain).prepare()

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        ik = self.upper_body(chain)
        qpos = chain.data.qpos.copy()
        key = {chain.ee_name: target}
        best_q, best_cost, iterations = q0.copy(), math.inf, 0
        best_start, best_why = 0, ""
        for k, start in enumerate(self.starts(chain, q0)):
            qpos[chain.qpos_adr] = start
            ik.set_q(qpos)
            res = ik.solve(key)
            iterations += res.iterations
            r = res[chain.ee_name]
            if res.converged:
                return self._result(chain, target, r.q, iterations)
            cost = r.position_error + 0.1 * (r.orientation_error or 0.0)
            if cost < best_cost:
                best_cost, best_q, best_start, best_why = cost, r.q.copy(), k + 1, res.message
        return self._result(
            chain,
            target,
            best_q,
            iterations,
            message=self._gave_up(iterations, best_start, best_why),
        )

    def _gave_up(self, iterations: int, best_start: int, why: str) -> str:
        """The message of a solve in which no start converged: the iterations summed over
        the starts (what ``IKResult.iterations`` counts) against the per-start cap, and
        why the start of the returned pose ended."""
        o = self.options
        return (
            f"{self.gave_up()}; {iterations} iterations in all, at most "
            f"{o.max_iterations} per start; start {best_start} (the closest): {why}"
        )

    # ------------------------------------------------------------------ several effectors
    def upper_body_for(self, goals: Sequence[EffectorGoal]) -> UpperBodyIK:
        """The :class:`UpperBodyIK` for these goals' chains and tasks (see the caches).

        Raises:
            SolverError: an unknown task, more than one ``look_at``, a bad option.
            ChainError: chains on different models.
        """
        key: EffectorsKey = tuple((g.chain, g.chain.version, g.task == "look_at") for g in goals)
        cached = self._multi_cache
        if (
            cached is not None
            and len(cached[0]) == len(key)
            and all(
                a is b and va == vb and la == lb
                for (a, va, la), (b, vb, lb) in zip(cached[0], key, strict=True)
            )
        ):
            return cached[1]
        for g in goals:
            if g.task not in _TASKS:
                raise SolverError(
                    f"task '{g.task}' of '{g.chain.ee_name}' unknown; tasks: {choices(_TASKS)}"
                )
        looks = [c for c, _v, look in key if look]
        if len(looks) > 1:
            raise SolverError(
                "mink aims one look_at effector per call, got "
                f"{len(looks)}: {', '.join(c.ee_name for c in looks)}"
            )
        hands = [c for c, _v, look in key if not look]
        ik = self._build(key[0][0].model, hands, looks[0] if looks else None)
        self._multi_cache = (key, ik)
        return ik

    def prepare_effectors(self, goals: Sequence[EffectorGoal]) -> None:
        """Build the :class:`UpperBodyIK` of ``goals`` (as :meth:`solve_effectors` gets
        them) and its QP problems, so a later timed call pays for none of it.

        Raises:
            SolverError, ChainError: as in :meth:`solve_effectors`.
        """
        if goals:
            self.upper_body_for(goals).prepare()

    def solve_effectors(self, goals: Sequence[EffectorGoal]) -> list[IKResult]:
        """Solve several effectors jointly: the scene runner's multi-effector hook.

        Args:
            goals: items with ``chain`` (all on one model; their scratch ``qpos`` holds
                the scene's current joints), ``target`` (a :class:`Target`; for
                ``look_at`` its position is the point to look at), ``q0`` (the chain's
                warm start ``(n,)`` [rad]) and ``task`` (``reach`` or ``look_at``).

        Returns:
            One ``IKResult`` per goal, in order (``q`` in the chain's joint order). Joints
            outside the goals' chains are frozen.

        Raises:
            SolverError: an unknown task, more than one ``look_at``, a bad option.
            ChainError: chains on different models.
            TargetError: a bad warm start or target.
        """
        if not goals:
            return []
        for g in goals:  # follow a model changed in place (see Chain.sync)
            g.chain.sync()
        ik = self.upper_body_for(goals)
        qpos = goals[0].chain.data.qpos.copy()
        targets: dict[str, Target | NDArray[np.float64]] = {}
        for g in goals:
            chain = g.chain
            qpos[chain.qpos_adr] = chain.clip(chain.check_q(g.q0))
            tgt = Target.of(g.target)
            targets[chain.ee_name] = tgt.position if g.task == "look_at" else tgt
        ik.set_q(qpos)
        res = ik.step(targets, self.options.dt) if self.options.dt > 0 else ik.solve(targets)
        return [res[g.chain.ee_name] for g in goals]
