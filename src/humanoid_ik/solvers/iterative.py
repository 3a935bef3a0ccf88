"""The loop shared by the Jacobian family: error, Jacobian, step, clamp to ranges.

Per iteration: ``mj_kinematics`` -> task error ``e`` (3 or 6 rows) -> ``mj_comPos`` +
``mj_jacSite`` -> ``dq = step(J, e)`` (recomputed without the joints that sit at a range
end and would be pushed past it) -> optional null-space bias toward ``home`` -> step
capped at ``max_step`` -> ``q`` clipped to the joint ranges. All buffers are
allocated once per solve. A run that stalls (no 1 % progress in ``stall_window``
iterations) or hits ``max_iterations`` restarts from a seeded random in-range pose, up to
``restarts`` times; the best pose seen is returned.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.chain import Chain
from humanoid_ik.solvers.base import Solver, pose_error
from humanoid_ik.types import IKResult, Target

__all__ = ["JacobianSolver"]


class JacobianSolver(Solver):
    """Base of ``jacobian_transpose``, ``pseudoinverse`` and ``dls``."""

    supports_orientation: ClassVar[bool] = True
    loop_defaults: ClassVar[dict[str, Any]] = {
        "max_iterations": 100,
        "restarts": 20,
        "max_step": 0.8,
        "nullspace_gain": 0.0,
        "stall_window": 8,
        "seed": 0,
    }

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.defaults = {**JacobianSolver.loop_defaults, **cls.defaults}

    def _prepare(self, chain: Chain, rows: int) -> None:
        """Per-solve set-up of the step rule (before the loop)."""

    @abstractmethod
    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        """Joint step ``(n,)`` reducing ``e`` ``(rows,)`` given ``J`` ``(rows, n)``."""

    def _nullspace(self, J: NDArray[np.float64]) -> NDArray[np.float64]:
        """Projector ``(n, n)`` onto the null space of ``J``: ``I - J+ J``."""
        return np.eye(J.shape[1]) - np.linalg.pinv(J, rcond=1e-6) @ J

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        m, d = chain.model, chain.data
        qadr, lo, hi = chain.qpos_adr, chain.lower, chain.upper
        pose = target.quat is not None
        rows = 6 if pose else 3
        J = chain._J[:rows]
        e = np.empty(6)
        ev = e[:rows]
        tol, rot_tol = self.tol, self.rot_tol
        max_step, gain = self.max_step, self.nullspace_gain
        window = max(2, self.stall_window)
        self._prepare(chain, rows)

        best_q, best_cost = q0.copy(), math.inf
        iterations = 0
        for q in self.starts(chain, q0):
            history = np.full(window, math.inf)
            d.qpos[qadr] = q
            for it in range(self.max_iterations + 1):
                mujoco.mj_kinematics(m, d)
                ep, er = pose_error(chain, target, e)
                cost = ep + (0.1 * er if pose else 0.0)
                if cost < best_cost:
                    best_cost = cost
                    best_q[:] = q
                if ep < tol and (not pose or er < rot_tol):
                    iterations += it
                    return self._result(chain, target, q, iterations)
                if it == self.max_iterations or (
                    it >= window and cost > 0.99 * history[it % window]
                ):
                    iterations += it
                    break
                history[it % window] = cost
                chain._jacobian()
                dq = self._step(J, ev)
                # joints at a range end that the step pushes outward leave the task
                blocked = ((q <= lo) & (dq < 0.0)) | ((q >= hi) & (dq > 0.0))
                if blocked.any():
                    J[:, blocked] = 0.0
                    dq = self._step(J, ev)
                    dq[blocked] = 0.0
                if gain > 0.0:
                    dq += self._nullspace(J) @ (gain * (chain.q_home - q))
                big = float(np.max(np.abs(dq)))
                if big > max_step:
                    dq *= max_step / big
                q += dq
                np.clip(q, lo, hi, out=q)
                d.qpos[qadr] = q
        return self._result(chain, target, best_q, iterations)
