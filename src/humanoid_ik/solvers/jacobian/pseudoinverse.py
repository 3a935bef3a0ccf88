"""Jacobian pseudo-inverse steps."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.solvers.jacobian.loop import JacobianSolver

__all__ = ["PseudoInverse"]


class PseudoInverse(JacobianSolver):
    """``dq = J+ e`` with the Moore-Penrose pseudo-inverse (SVD, singular values below
    ``rcond * s_max`` dropped)."""

    name: ClassVar[str] = "pseudoinverse"
    summary: ClassVar[str] = "Jacobian pseudo-inverse (SVD)"
    defaults: ClassVar[dict[str, Any]] = {"rcond": 1e-4}

    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.linalg.pinv(J, rcond=self.rcond) @ e
