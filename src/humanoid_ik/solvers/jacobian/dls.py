"""Damped least squares (Levenberg-Marquardt) with damping that adapts near singularities."""

from __future__ import annotations

import math
import weakref
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.solvers.jacobian.loop import JacobianSolver

__all__ = ["DLS"]

_W0: weakref.WeakKeyDictionary[Chain, dict[int, float]] = weakref.WeakKeyDictionary()


class DLS(JacobianSolver):
    """``dq = J' (J J' + lambda^2 I)^-1 e``.

    The damping follows the manipulability ``w = sqrt(det(J J'))`` (Nakamura and Hanafusa):
    ``lambda^2 = damping^2 (1 - w / w0)^2`` when ``w < w0``, plus ``min_damping^2``
    always, with ``w0 = singular_fraction * w(home)``. Far from singularities the step
    is the pseudo-inverse step; near one it stays bounded. The system is solved by
    MuJoCo's Cholesky factorisation (``mju_cholFactor``/``mju_cholSolve``), whose diagonal
    also gives ``w``, without a separate determinant.
    """

    name: ClassVar[str] = "dls"
    summary: ClassVar[str] = "damped least squares, damping adapts near singularities"
    defaults: ClassVar[dict[str, Any]] = {
        "damping": 0.05,
        "min_damping": 1e-3,
        "singular_fraction": 0.1,
    }

    def _prepare(self, chain: Chain, rows: int) -> None:
        per_chain = _W0.setdefault(chain, {})
        if rows not in per_chain:  # manipulability at home, once per chain and task
            saved = chain.q
            chain.set_q(chain.q_home)
            J = chain._jacobian()[:rows]
            per_chain[rows] = math.sqrt(max(np.linalg.det(J @ J.T), 0.0))
            chain.set_q(saved)
        self._w0 = self.singular_fraction * per_chain[rows]
        if getattr(self, "_rows", None) != rows:
            self._rows = rows
            self._A = np.empty((rows, rows))
            self._L = np.empty((rows, rows))
            self._A_diag = self._A.reshape(-1)[:: rows + 1]  # views of the diagonals
            self._L_diag = self._L.reshape(-1)[:: rows + 1]
            self._y = np.empty(rows)

    def _step(self, J: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
        A, L, y = self._A, self._L, self._y
        np.matmul(J, J.T, out=A)
        self._A_diag += self.min_damping * self.min_damping
        L[:] = A
        mujoco.mju_cholFactor(L, 1e-15)  # A = L L' (lower triangle, in place)
        if self._w0 > 0.0:
            w = float(np.prod(self._L_diag))  # sqrt(det A) = product of diag(L)
            if w < self._w0:
                s = 1.0 - w / self._w0
                L[:] = A
                self._L_diag += self.damping * self.damping * s * s
                mujoco.mju_cholFactor(L, 1e-15)
        mujoco.mju_cholSolve(y, L, e)
        return J.T @ y
