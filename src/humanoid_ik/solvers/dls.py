"""Damped least squares (Levenberg-Marquardt) with damping that adapts near singularities."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.chain import Chain
from humanoid_ik.solvers.iterative import JacobianSolver

__all__ = ["DLS"]


class DLS(JacobianSolver):
    """``dq = J' (J J' + lambda^2 I)^-1 e``.

    The damping follows the manipulability ``w = sqrt(det(J J'))`` (Nakamura and Hanafusa):
    ``lambda^2 = damping^2 (1 - w / w0)^2`` when ``w < w0``, plus ``min_damping^2``
    always, with ``w0 = singular_fraction * w(home)``. Far from singularities the step
    is the pseudo-inverse step; near one it stays bounded.
    """

    name: ClassVar[str] = "dls"
    summary: ClassVar[str] = "damped least squares, damping adapts near singularities"
    defaults: ClassVar[dict[str, Any]] = {
        "damping": 0.05,
        "min_damping": 1e-3,
        "singular_fraction": 0.1,
    }

    def _prepare(self, chain: Chain, rows: int) -> None:
        key = (id(chain), rows)
        cache = getattr(self, "_w0_cache", None)
        if cache is None or cache[0] != key:
            saved = chain.q
            chain.set_q(chain.q_home)
            J = chain._jacobian()[:rows]
            w_home = math.sqrt(max(np.linalg.det(J @ J.T), 0.0))
            chain.set_q(saved)
            self._w0_cache = (key, self.singular_fraction * w_home)
        self._w0 = self._w0_cache[1]
        self._eye = np.eye(rows)
        self._A = np.empty((rows, rows))

    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        A = np.matmul(J, J.T, out=self._A)
        lam2 = self.min_damping * self.min_damping
        if self._w0 > 0.0:
            w = math.sqrt(max(np.linalg.det(A), 0.0))
            if w < self._w0:
                s = 1.0 - w / self._w0
                lam2 += self.damping * self.damping * s * s
        A += lam2 * self._eye
        return J.T @ np.linalg.solve(A, e)
