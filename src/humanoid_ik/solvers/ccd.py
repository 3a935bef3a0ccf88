"""Cyclic coordinate descent with a nudge factor (lecture notes, IK method 2)."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import mujoco
import numpy as np

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import hinge_angle_between
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.solvers.base import Solver

__all__ = ["CCD"]


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
    defaults: ClassVar[dict[str, Any]] = {
        "nudge": 1.0,
        "max_iterations": 300,
        "restarts": 10,
        "stall_window": 15,
        "seed": 0,
    }

    def __init__(self, **options: Any):
        super().__init__(**options)
        if not 0.0 < self.nudge <= 1.0:
            from humanoid_ik.errors import SolverError

            raise SolverError(f"option 'nudge' of solver 'ccd' must be in (0, 1], got {self.nudge}")

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
        if best_err < self.tol:
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
        c = self.nudge
        window = max(2, self.stall_window)
        history = np.full(window, math.inf)
        err = math.inf
        for sweep in range(1, self.max_iterations + 1):
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
            if err < self.tol:
                return True, err, sweep
            if sweep > window and err > 0.99 * history[sweep % window]:
                return False, err, sweep
            history[sweep % window] = err
        return False, err, self.max_iterations
