"""Jacobian transpose with a step rule that converges."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

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


class _Work(NamedTuple):
    """One solve's row weights ``(rows,)`` and weighted ``J``, ``e`` buffers."""

    w: NDArray[np.float64]
    Jw: NDArray[np.float64]
    ew: NDArray[np.float64]


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

    def _prepare(self, chain: Chain, rows: int) -> _Work:
        r = chain.robot
        w = r.buffer("transpose_w", (rows,))
        w[:3] = 1.0
        w[3:] = self.options.orientation_weight
        return _Work(
            w, r.buffer("transpose_Jw", (rows, chain.n)), r.buffer("transpose_ew", (rows,))
        )

    def _step(
        self, work: _Work, J: NDArray[np.float64], e: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        Jw = np.multiply(J, work.w[:, None], out=work.Jw)
        ew = np.multiply(e, work.w, out=work.ew)
        g = Jw.T @ ew
        Jg = Jw @ g
        den = float(Jg @ Jg)
        if den <= 1e-300:
            return g * 0.0
        return g * (float(ew @ Jg) / den)
