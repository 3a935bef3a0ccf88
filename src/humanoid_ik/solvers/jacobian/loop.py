"""The loop shared by the Jacobian family: error, Jacobian, step, clamp to ranges.

Per iteration: ``mj_kinematics`` -> task error ``e`` (3 or 6 rows) -> ``mj_comPos`` +
``mj_jacSite`` -> ``dq = step(J, e)`` (recomputed without the joints that sit at a range
end and would be pushed past it) -> optional null-space bias toward ``home`` -> step
capped at ``max_step`` -> ``q`` clipped to the joint ranges. Buffers are allocated once
per solve and MuJoCo's arrays are read through views, so the loop allocates little.

A run that stalls (less than 1 % progress in ``stall_window`` iterations: the one rule
of :mod:`humanoid_ik.solvers.iterate`) or hits ``max_iterations`` restarts, up to
``restarts`` times, from the poses of the chain's seed library
(:mod:`humanoid_ik.solvers.jacobian.seeds`) whose FK lies nearest the target,
alternating with seeded random in-range poses. The best pose seen (the lowest
:func:`~humanoid_ik.solvers.iterate.pose_cost`) is returned. A step that is not
finite (an option so large that it overflows) ends that start like a stall.

The options' bounds (:data:`OPTION_BOUNDS`) keep a solve finite in time, memory and
arithmetic; a value beyond one is a :class:`~humanoid_ik.errors.SolverError` naming it
and the bound.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.base import Solver, error_buffers
from humanoid_ik.solvers.iterate import Best, Stall, pose_cost
from humanoid_ik.solvers.jacobian.seeds import restart_poses, seed_library
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["OPTION_BOUNDS", "JacobianOptions", "JacobianSolver"]

OPTION_BOUNDS: dict[str, tuple[float, float]] = {
    "max_iterations": (0, 100_000),
    "restarts": (0, 1_000),
    "stall_window": (0, 100_000),
    "library_seeds": (0, 4_000),
    "nullspace_gain": (0.0, 1.0),
}
"""``(lower, upper)`` bounds of the Jacobian family's options (``JacobianOptions.BOUNDS``,
checked by :meth:`SolverOptions.parse`): iterations, restarts and the stall window
bound a solve's time and memory; the seed library holds 4,000 poses; a
``nullspace_gain`` of 1 already moves all the way to home in the null space, and more
overshoots. Other options are unbounded: a value so large that a step overflows ends
that start (see the module's docstring)."""


@dataclass(frozen=True)
class JacobianOptions(SolverOptions):
    """Options of the Jacobian family's loop.

    Attributes:
        max_iterations: iterations per start.
        restarts: further starts after a stall (seed-library poses, random poses).
        max_step: largest joint step per iteration [rad].
        nullspace_gain: pull toward the home pose in the task's null space.
        stall_window: iterations without a 1 % gain that count as a stall.
        seed: seed of the random restarts.
        library_seeds: seed-library poses nearest the target among the restarts.
    """

    max_iterations: int = 100
    restarts: int = 20
    max_step: float = 0.8
    nullspace_gain: float = 0.0
    stall_window: int = 8
    seed: int = 0
    library_seeds: int = 8
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = OPTION_BOUNDS


class JacobianSolver(Solver):
    """Base of ``jacobian_transpose``, ``pseudoinverse`` and ``dls``."""

    supports_orientation: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = JacobianOptions
    options: JacobianOptions

    def prepare(self, chain: Chain) -> None:
        """Build the chain's seed library (used by the restarts) before any timed solve."""
        if self.options.restarts and self.options.library_seeds:
            seed_library(chain)

    def _prepare(self, chain: Chain, rows: int) -> Any:
        """Per-solve set-up of the step rule (before the loop): what :meth:`_step` gets
        as ``work`` (buffers from the chain's robot state, values of this solve)."""
        return None

    @abstractmethod
    def _step(
        self, work: Any, J: NDArray[np.float64], e: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Joint step ``(n,)`` reducing ``e`` ``(rows,)`` given ``J`` ``(rows, n)`` and the
        ``work`` of :meth:`_prepare`."""

    def _nullspace(self, J: NDArray[np.float64]) -> NDArray[np.float64]:
        """Projector ``(n, n)`` onto the null space of ``J``: ``I - J+ J``."""
        return np.eye(J.shape[1]) - np.linalg.pinv(J, rcond=1e-6) @ J

    def starts(self, chain: Chain, q0: NDArray[np.float64], target: Target | None = None):
        """``q0``, then library poses nearest ``target`` alternating with seeded random ones
        (:func:`~humanoid_ik.solvers.jacobian.seeds.restart_poses`)."""
        o = self.options
        return restart_poses(chain, q0, target, o.restarts, o.library_seeds, o.seed)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        m, d = chain.model, chain.data
        qadr, lo, hi = chain.qpos_adr, chain.lower, chain.upper
        pose = target.quat is not None
        rows = 6 if pose else 3
        e, quat_buf = error_buffers(chain)
        e[:] = 0.0
        ev = e[:rows]
        tp, tq = target.position, target.quat
        site = chain.ee_kind == "site"
        xpos = d.site_xpos[chain.ee_id] if site else d.xpos[chain.ee_id]
        xmat = d.site_xmat[chain.ee_id] if site else d.xmat[chain.ee_id]
        tol, rot_tol = self.options.tol, self.options.rot_tol
        max_iterations = self.options.max_iterations
        max_step, gain = self.options.max_step, self.options.nullspace_gain
        kinematics, jacobian = mujoco.mj_kinematics, chain.current_jacobian
        work = self._prepare(chain, rows)

        best = Best(q0)
        iterations = 0
        er_n = 0.0
        for q in self.starts(chain, q0, target):
            stalled = Stall(self.options.stall_window)
            d.qpos[qadr] = q
            for it in range(max_iterations + 1):
                kinematics(m, d)
                ep, er = pose_error(xpos, xmat, tp, tq, e, quat_buf)
                if pose:
                    er_n = er
                cost = pose_cost(ep, er_n)
                best.offer(q, cost)
                if ep < tol and er_n < rot_tol:  # kinematics are current: no second FK
                    er_out = er_n if pose else None
                    return IKResult(
                        q, True, iterations + it, ep, er_out, Status.CONVERGED, self.name
                    )
                if it == max_iterations or stalled(it, cost):
                    iterations += it
                    break
                J = jacobian()[:rows]
                dq = self._step(work, J, ev)
                # joints at a range end that the step pushes outward leave the task
                blocked = ((q <= lo) & (dq < 0.0)) | ((q >= hi) & (dq > 0.0))
                if blocked.any():
                    J[:, blocked] = 0.0
                    dq = self._step(work, J, ev)
                    dq[blocked] = 0.0
                if gain > 0.0:
                    dq += self._nullspace(J) @ (gain * (chain.q_home - q))
                big = max(-dq.min(), dq.max())
                if not math.isfinite(big):  # overflow: this start ends like a stall
                    iterations += it
                    break
                if big > max_step:
                    dq *= max_step / big
                q += dq
                np.clip(q, lo, hi, out=q)
                d.qpos[qadr] = q
        return self._result(chain, target, best.q, iterations, message=self.gave_up())
