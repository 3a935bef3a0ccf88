"""Damped least squares (Levenberg-Marquardt) with damping that adapts near singularities."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.solvers.jacobian.lm import pole_steps
from humanoid_ik.solvers.jacobian.loop import JacobianOptions, JacobianSolver
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["DLS"]


@dataclass(frozen=True)
class DLSOptions(JacobianOptions):
    """Options of ``dls``.

    Attributes:
        damping: largest damping ``lambda`` [m], reached at a singularity.
        min_damping: damping everywhere [m].
        singular_fraction: manipulability, as a fraction of that at home, below which
            the damping grows.
    """

    damping: float = 0.05
    min_damping: float = 1e-3
    singular_fraction: float = 0.1


class _Work(NamedTuple):
    """One solve's manipulability threshold ``w0`` and the ``(rows, rows)`` system,
    factor and ``(rows,)`` solution buffers."""

    w0: float
    A: NDArray[np.float64]
    L: NDArray[np.float64]
    y: NDArray[np.float64]


class DLS(JacobianSolver):
    """``dq = J' (J J' + lambda^2 I)^-1 e``.

    The damping follows the manipulability ``w = sqrt(det(J J'))`` (Nakamura and Hanafusa):
    ``lambda^2 = damping^2 (1 - w / w0)^2`` when ``w < w0``, plus ``min_damping^2``
    always, with ``w0 = singular_fraction * w(home)``. Far from singularities the step
    is the pseudo-inverse step; near one it stays bounded. The system is solved by
    MuJoCo's Cholesky factorisation (``mju_cholFactor``/``mju_cholSolve``), whose diagonal
    also gives ``w``, without a separate determinant.

    An elbow pole is honoured after convergence as ``lm`` does
    (:func:`~humanoid_ik.solvers.jacobian.lm.pole_steps`, in the task's null space).
    """

    name: ClassVar[str] = "dls"
    honours_pole: ClassVar[bool] = True
    summary: ClassVar[str] = "damped least squares, damping adapts near singularities"
    Options: ClassVar[type[SolverOptions]] = DLSOptions
    options: DLSOptions

    def prepare(self, chain: Chain) -> None:
        """Build the seed library and the home manipulability of both task sizes."""
        super().prepare(chain)
        for rows in (3, 6):
            _manipulability_at_home(chain, rows)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        res = super()._solve(chain, target, q0)
        if target.pole is None or not res.converged:
            return res
        return pole_steps(self, chain, target, res)

    def _prepare(self, chain: Chain, rows: int) -> _Work:
        w_home = _manipulability_at_home(chain, rows)
        r = chain.robot
        A = r.buffer("dls_A", (rows, rows))
        L = r.buffer("dls_L", (rows, rows))
        return _Work(self.options.singular_fraction * w_home, A, L, r.buffer("dls_y", (rows,)))

    def _step(
        self, work: _Work, J: NDArray[np.float64], e: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        A, L, y, w0 = work.A, work.L, work.y, work.w0
        rows = A.shape[0]
        A_diag, L_diag = A.reshape(-1)[:: rows + 1], L.reshape(-1)[:: rows + 1]
        np.matmul(J, J.T, out=A)
        A_diag += self.options.min_damping * self.options.min_damping
        L[:] = A
        mujoco.mju_cholFactor(L, 1e-15)  # A = L L' (lower triangle, in place)
        if w0 > 0.0:
            w = float(np.prod(L_diag))  # sqrt(det A) = product of diag(L)
            if w < w0:
                s = 1.0 - w / w0
                L[:] = A
                L_diag += self.options.damping * self.options.damping * s * s
                mujoco.mju_cholFactor(L, 1e-15)
        mujoco.mju_cholSolve(y, L, e)
        return J.T @ y


def _manipulability_at_home(chain: Chain, rows: int) -> float:
    """``sqrt(det(J J'))`` of the first ``rows`` Jacobian rows at the home pose, computed
    once per chain and kept with it."""

    def build(c: Chain) -> float:
        saved = c.q
        J = c.jacobian(c.q_home)[:rows]
        c.set_q(saved)
        return math.sqrt(max(np.linalg.det(J @ J.T), 0.0))

    return chain.derived(("manipulability_at_home", rows), build)
