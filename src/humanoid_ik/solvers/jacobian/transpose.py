"""Jacobian transpose with a step rule that converges."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.solvers.jacobian.loop import JacobianOptions, JacobianSolver
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["JacobianTranspose"]


@dataclass(frozen=True)
class TransposeOptions(JacobianOptions):
    """Options of ``jacobian_transpose`` (more, smaller steps than the other two).

    Attributes:
        orientation_weight: weight of the orientation rows [m/rad].
    """

    max_iterations: int = 1500
    restarts: int = 10
    stall_window: int = 200
    orientation_weight: float = 0.3


class JacobianTranspose(JacobianSolver):
    """``dq = alpha J' e`` with ``alpha = <e, J J' e> / <J J' e, J J' e>`` (Buss).

    ``alpha`` is the step that minimises ``|e - alpha J J' e|`` along the gradient
    direction, so the linearised error never grows; every iteration re-reads FK and the
    Jacobian from MuJoCo (a fixed tiny step on stale joint positions never converges).
    For pose targets the orientation rows of ``J`` and ``e`` are scaled by
    ``orientation_weight`` [m/rad], so that metres and radians weigh alike in the
    gradient. Convergence is linear: expect hundreds of iterations.
    """

    name: ClassVar[str] = "jacobian_transpose"
    summary: ClassVar[str] = "Jacobian transpose, optimal step along the gradient"
    Options: ClassVar[type[SolverOptions]] = TransposeOptions
    options: TransposeOptions

    def _prepare(self, chain: Chain, rows: int) -> None:
        self._w = np.ones(rows)
        self._w[3:] = self.options.orientation_weight
        self._Jw = np.empty((rows, chain.n))
        self._ew = np.empty(rows)

    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        Jw = np.multiply(J, self._w[:, None], out=self._Jw)
        ew = np.multiply(e, self._w, out=self._ew)
        g = Jw.T @ ew
        Jg = Jw @ g
        den = float(Jg @ Jg)
        if den <= 1e-300:
            return g * 0.0
        return g * (float(ew @ Jg) / den)
