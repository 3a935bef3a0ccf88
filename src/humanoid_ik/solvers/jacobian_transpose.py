"""Jacobian transpose with a step rule that converges."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.solvers.iterative import JacobianSolver

__all__ = ["JacobianTranspose"]


class JacobianTranspose(JacobianSolver):
    """``dq = alpha J' e`` with ``alpha = <e, J J' e> / <J J' e, J J' e>`` (Buss).

    ``alpha`` is the step that minimises ``|e - alpha J J' e|`` along the gradient
    direction, so the linearised error never grows: each iteration re-reads FK from
    MuJoCo, unlike a fixed tiny step on stale joint positions.
    """

    name: ClassVar[str] = "jacobian_transpose"
    summary: ClassVar[str] = "Jacobian transpose, optimal step along the gradient"
    defaults: ClassVar[dict[str, Any]] = {
        "max_iterations": 1500,
        "restarts": 3,
        "stall_window": 200,
    }

    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        g = J.T @ e
        Jg = J @ g
        den = float(Jg @ Jg)
        if den <= 1e-300:
            return g * 0.0
        return g * (float(e @ Jg) / den)
