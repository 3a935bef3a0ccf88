"""Cyclic coordinate descent with a nudge factor (lecture notes, IK method 2)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import mujoco
import numpy as np

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import hinge_angle_between
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["CCD"]


@dataclass(frozen=True)
class CCDOptions(SolverOptions):
    """Options of ``ccd``.

    Attributes:
        nudge: fraction of each joint's best angle applied per update, in (0, 1].
        max_iterations: sweeps per start.
        restarts: further starts (seeded random poses) after a stall.
        stall_window: sweeps without progress that count as a stall.
        seed: seed of the random restarts.
    """

    nudge: float = 1.0
    max_iterations: int = 300
    restarts: int = 10
    stall_window: int = 15
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.0 < self.nudge <= 1.0:
            raise SolverError(f"option 'nudge' of solver 'ccd' must be in (0, 1], got {self.nudge}")


class CCD(Solver):
    """Visit each joint from the end effector to the root and nudge it toward the target.

    For a hinge with axis ``u`` at anchor ``a``, end effector ``p`` and target ``p_d``,
    ``r = p - a`` and ``e = p_d - p``. The lecture's angle
    ``phi = atan2(|r x e|, r.r + r.e)`` is the angle from ``r`` to ``r + e``; a hinge
    can only turn about ``u``, so both are projected on the plane normal to ``u`` first
    (identical to the lecture's formula when ``u`` is parallel to ``r x e``). The joint
    turns by ``nudge * phi`` and is clipped to its range; FK is re-read from MuJoCo after
    every joint. Sweeps repeat until ``|p_d - p| < tol`` or ``max_iterations`` sweeps.
    Joint limits can trap CCD away from the target: a run that makes less than 1 %
    progress in ``stall_window`` sweeps restarts from a seeded random in-range pose, up
    to ``restarts`` times, and the best pose seen is returned.
    """

    name: ClassVar[str] = "ccd"
    summary: ClassVar[str] = "cyclic coordinate descent with a nudge factor"
    Options: ClassVar[type[SolverOptions]] = CCDOptions
    options: CCDOptions

    def _solve(self, chain: Chain, target: Target, q0: np.ndarray) -> IKResult:
        best_q, best_err = q0.copy(), math.inf
        sweeps = 0
        for q in self.starts(chain, q0, target):
            done, err, n = self._run(chain, target.position, q)
            sweeps += n
            if err < best_err:
                best_q, best_err = q.copy(), err
            if done:
                break
        if best_err < self.options.tol:
            return self._result(chain, target, best_q, sweeps)
        return self._result(
            chain,
            target,
            best_q,
            sweeps,
            message=self.gave_up(),
        )

    def _run(self, chain: Chain, pd: np.ndarray, q: np.ndarray) -> tuple[bool, float, int]:
        """Sweeps from ``q`` (updated in place): ``(converged, error [m], sweeps)``."""
        m, d = chain.model, chain.data
        chain.set_q(q)
        jids, qadr = chain.joint_ids, chain.qpos_adr
        lo, hi = chain.lower, chain.upper
        c = self.options.nudge
        window = max(2, self.options.stall_window)
        history = np.full(window, math.inf)
        err = math.inf
        for sweep in range(1, self.options.max_iterations + 1):
            for i in range(chain.n - 1, -1, -1):
                j = jids[i]
                anchor = d.xanchor[j]
                p = chain.position
                phi = hinge_angle_between(d.xaxis[j], p - anchor, pd - anchor)
                q[i] = min(max(q[i] + c * phi, lo[i]), hi[i])
                d.qpos[qadr[i]] = q[i]
                mujoco.mj_kinematics(m, d)
            diff = chain.position - pd
            err = math.sqrt(float(diff @ diff))
            if err < self.options.tol:
                return True, err, sweep
            if sweep > window and err > 0.99 * history[sweep % window]:
                return False, err, sweep
            history[sweep % window] = err
        return False, err, self.options.max_iterations
