"""The base of our mink tasks: error and Jacobian computed once per QP, into buffers."""

from __future__ import annotations

import mink
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.errors import TargetError
from humanoid_ik.solvers.mink.adapter import weighted_residual

__all__ = ["BufferedTask", "check_point"]


def check_point(point: ArrayLike, what: str) -> NDArray[np.float64]:
    """``point`` as a new ``(3,)`` float array.

    Raises:
        TargetError: not 3 finite numbers (the message starts with ``what``).
    """
    p = np.asarray(point, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise TargetError(f"{what} must be 3 finite numbers, got {np.asarray(point)!r}")
    return p.copy()


class BufferedTask(mink.Task):
    r"""A ``mink.Task`` that fills its error ``e`` ``(k,)`` and Jacobian ``J = de/dq``
    ``(k, nv)`` in one pass, into buffers it owns.

    Subclasses implement :meth:`fill`. The QP reads the task through mink's public hook
    ``compute_qp_residual``, which here evaluates the kinematics once; its contribution
    to the objective is mink's::

        |W (J dq + alpha e)|^2 + mu |dq|^2,   W = diag(cost), mu = lm_damping |W alpha e|^2

    ``compute_error`` and ``compute_jacobian`` return copies (for tests and for mink's
    generic paths, such as ``compute_qp_objective``).
    """

    _e: NDArray[np.float64]
    _J: NDArray[np.float64]

    def fill(self, configuration: mink.Configuration) -> None:
        """Fill ``_e`` ``(k,)`` and ``_J`` ``(k, nv)`` at the configuration's kinematics.

        Raises:
            mink.TargetNotSet: no target yet.
        """
        raise NotImplementedError

    def compute_error(self, configuration: mink.Configuration) -> NDArray[np.float64]:
        """The task error ``e`` ``(k,)`` (a copy)."""
        self.fill(configuration)
        return self._e.copy()

    def compute_jacobian(self, configuration: mink.Configuration) -> NDArray[np.float64]:
        """The task Jacobian ``J = de/dq`` ``(k, nv)`` (a copy)."""
        self.fill(configuration)
        return self._J.copy()

    def compute_qp_residual(
        self, configuration: mink.Configuration
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        """``(W J, -alpha W e, mu)`` from one :meth:`fill` (see ``mink.BaseTask``)."""
        self.fill(configuration)
        return weighted_residual(self, self._e, self._J)
