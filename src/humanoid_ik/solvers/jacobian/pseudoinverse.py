"""Jacobian pseudo-inverse steps."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.solvers.jacobian.loop import JacobianOptions, JacobianSolver
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["PseudoInverse"]


@dataclass(frozen=True)
class PseudoInverseOptions(JacobianOptions):
    """Options of ``pseudoinverse``.

    Attributes:
        rcond: singular values below ``rcond`` times the largest are cut.
    """

    rcond: float = 1e-4


class PseudoInverse(JacobianSolver):
    """``dq = J+ e`` with the Moore-Penrose pseudo-inverse (SVD, singular values below
    ``rcond * s_max`` dropped)."""

    name: ClassVar[str] = "pseudoinverse"
    summary: ClassVar[str] = "Jacobian pseudo-inverse (SVD)"
    Options: ClassVar[type[SolverOptions]] = PseudoInverseOptions
    options: PseudoInverseOptions

    def _step(
        self, work: None, J: NDArray[np.float64], e: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        return np.linalg.pinv(J, rcond=self.options.rcond) @ e
