"""The ``mink`` solver: differential IK as a quadratic program through mink and daqp.

:class:`MinkSolver` (``"mink"``) is the :class:`~humanoid_ik.solvers.base.Solver` of the
package, usable by name in ``solve``, ``bench``, sweeps, scenes and the CLI. It runs an
:class:`~humanoid_ik.solvers.mink.upper_body.UpperBodyIK` on one chain (``solve``), or
on every effector of a scene that names it at once (``solve_effectors``: the ``reach``
hands and one ``look_at`` gaze in one QP per step). The QP of one step is described in
:mod:`humanoid_ik.solvers.mink.problem`; the options, :class:`MinkOptions`, in
:mod:`humanoid_ik.solvers.mink.options`.

This module does not import mink; building the first :class:`UpperBodyIK` does.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.types import EffectorGoal, IKResult, Target
from humanoid_ik.errors import ChainError, SolverError, choices
from humanoid_ik.solvers.analytic.elbow import arm_points, pole_angle
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.iterate import Best, pose_cost
from humanoid_ik.solvers.mink.options import NAME, MinkOptions
from humanoid_ik.solvers.mink.upper_body import UpperBodyIK
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["MinkOptions", "MinkSolver", "UpperBodyIK"]

_TASKS = ("reach", "look_at")


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

    An elbow pole on a hand's target (``Target.pole``) adds a low-weight task turning
    that arm's elbow toward the pole's plane
    (:class:`~humanoid_ik.solvers.mink.tasks.ElbowTask`, cost ``pole_cost``); the
    results' ``details`` give the ``pole_error`` reached [rad].

    With ``collision_pairs`` (pairs of geom-name groups of the chains' model) the chains
    also keep those geoms apart. None by default, so that the bench's random targets
    (some of which put the hand inside the torso) stay comparable with the other
    solvers; a scene names its model's pairs in its solver options
    (``scenes/upper_body_mink.toml``).

    No state: the object holds only its options, so one object may serve several
    threads that each have their own robot state. What it builds, an
    :class:`UpperBodyIK` (its own ``mink.Configuration``, tasks, limits and
    per-active-set QP problems), lives in the robot's workspace
    (:meth:`Robot.workspace <humanoid_ik.core.robot.Robot.workspace>`), built on first
    use or ahead of time by :meth:`prepare` / :meth:`prepare_effectors`, keyed by
    everything it depends on:

    - for :meth:`solve`: the options and the chain's :attr:`~Chain.key` (end effector
      and joint ids);
    - for :meth:`solve_effectors`: the options and, in goal order, each goal's chain key
      and whether it is a ``look_at``.

    The robot drops its workspace when the model changes (:meth:`Chain.sync`, which
    every call runs first). Nothing else makes them stale: the options are frozen, and
    every call sets the full ``qpos`` it starts from (the robot's scratch ``qpos`` with
    ``q0``, or the goals' warm starts), so no joint value carries over from one call to
    the next.
    """

    name: ClassVar[str] = NAME
    summary: ClassVar[str] = "differential IK as a QP through mink (daqp), limits as constraints"
    supports_orientation: ClassVar[bool] = True
    solves_effectors: ClassVar[bool] = True
    honours_pole: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = MinkOptions
    options: MinkOptions

    def _build(self, robot: Robot, hands: Sequence[Chain], gaze: Chain | None) -> UpperBodyIK:
        """A new :class:`UpperBodyIK` with this solver's options."""
        return UpperBodyIK(
            robot, hands=tuple(hands), gaze=gaze, gaze_axis=self.gaze_axis(), options=self.options
        )

    # ------------------------------------------------------------------ one chain
    def upper_body(self, chain: Chain) -> UpperBodyIK:
        """The :class:`UpperBodyIK` this solver runs on ``chain``, from the chain's robot
        workspace (built there on first use; see the class docstring).

        Raises:
            SolverError: a bad option value (e.g. an unknown ``qp_solver``).
        """
        key: Hashable = (NAME, "chain", self.options, chain.key)
        return chain.robot.workspace(key, lambda: self._build(chain.robot, (chain,), None))

    def prepare(self, chain: Chain) -> None:
        """Build the :class:`UpperBodyIK` of ``chain`` and its QP problems (position and
        pose targets), and import mink, so a later timed :meth:`solve` pays for none of it.

        Raises:
            SolverError: a bad option value (e.g. an unknown ``qp_solver``).
        """
        self.upper_body(chain).prepare()

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        ik = self.upper_body(chain)
        ik.set_mocap(chain.data)
        qpos = chain.data.qpos.copy()
        key = {chain.ee_name: target}
        best, iterations, best_why = Best(q0), 0, ""
        for k, start in enumerate(self.starts(chain, q0)):
            qpos[chain.qpos_adr] = start
            ik.set_q(qpos)
            res = ik.solve(key)
            iterations += res.iterations
            r = res[chain.ee_name]
            if res.converged:
                return _with_pole(self._result(chain, target, r.q, iterations), chain, target)
            if best.offer(r.q, pose_cost(r.position_error, r.orientation_error), k + 1):
                best_why = res.message
        why = self._gave_up(iterations, best.start, best_why)
        out = self._result(chain, target, best.q, iterations, message=why)
        return _with_pole(out, chain, target)

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
        """The :class:`UpperBodyIK` for these goals' chains and tasks, from the first
        goal's robot workspace (built there on first use; see the class docstring).

        Raises:
            SolverError: no goal, an unknown task, more than one ``look_at``, a bad option.
            ChainError: chains on different models.
        """
        if not goals:
            raise SolverError("mink needs at least one goal")
        model = goals[0].chain.model
        for g in goals:
            if g.task not in _TASKS:
                raise SolverError(
                    f"task '{g.task}' of '{g.chain.ee_name}' unknown; tasks: {choices(_TASKS)}"
                )
            if g.chain.model is not model:
                raise ChainError(
                    f"chain of '{g.chain.ee_name}' is on another MjModel than "
                    f"'{goals[0].chain.ee_name}'; solve the effectors of one model together"
                )
        looks = [g.chain for g in goals if g.task == "look_at"]
        if len(looks) > 1:
            raise SolverError(
                "mink aims one look_at effector per call, got "
                f"{len(looks)}: {', '.join(c.ee_name for c in looks)}"
            )
        hands = [g.chain for g in goals if g.task != "look_at"]
        robot = goals[0].chain.robot
        key: Hashable = (
            NAME,
            "effectors",
            self.options,
            tuple((g.chain.key, g.task == "look_at") for g in goals),
        )
        return robot.workspace(key, lambda: self._build(robot, hands, looks[0] if looks else None))

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
        robots: list[Robot] = []
        for g in goals:
            if not any(g.chain.robot is r for r in robots):
                robots.append(g.chain.robot)
        claimed: list[Robot] = []
        try:
            for r in robots:
                r.claim()
                claimed.append(r)
            for g in goals:  # follow a model changed in place (see Chain.sync)
                g.chain.sync()
            return self._solve_effectors(goals)
        finally:
            for r in claimed:
                r.release()

    def _solve_effectors(self, goals: Sequence[EffectorGoal]) -> list[IKResult]:
        ik = self.upper_body_for(goals)
        ik.set_mocap(goals[0].chain.data)
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


def _with_pole(res: IKResult, chain: Chain, target: Target) -> IKResult:
    """``res`` with the pole's angle to the elbow's plane at its pose (the chain is at it)."""
    if target.pole is None:
        return res
    err = pole_angle(arm_points(chain), target.pole)
    return res.with_details(pole="secondary task", pole_error=err)
