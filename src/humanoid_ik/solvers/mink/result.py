"""What one call of :class:`~humanoid_ik.solvers.mink.UpperBodyIK` did."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.types import IKResult, Status

__all__ = ["UpperBodyResult"]


@dataclass(frozen=True)
class UpperBodyResult:
    """What one :meth:`UpperBodyIK.step` or :meth:`UpperBodyIK.solve` did.

    One ``IKResult`` per effector with a target (chosen over a new per-effector type so
    metrics and the CLI read every solver's errors the same way): its ``q`` holds that
    chain's joints, its errors are measured with MuJoCo FK at the returned pose; for the
    gaze, ``position_error`` is the distance from the target to the gaze ray and
    ``orientation_error`` the angle between the forward axis and the target direction
    (:func:`humanoid_ik.core.measures.gaze_error`).

    Attributes:
        q: full ``qpos`` ``(nq,)`` [rad] after the call (read-only).
        effectors: ``IKResult`` per effector name with a target (hands in the order
            configured, then the gaze; read-only).
        converged: every effector within ``tol`` / ``rot_tol``.
        iterations: QP steps taken (1 for ``step``).
        status: ``converged`` or ``max_iterations`` (also after a stall; see ``message``).
        message: why it did not converge, or ``""``.
    """

    q: NDArray[np.float64]
    effectors: Mapping[str, IKResult]
    converged: bool
    iterations: int
    status: Status
    message: str = ""

    def __post_init__(self) -> None:
        q = np.array(self.q, dtype=np.float64)
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "effectors", MappingProxyType(dict(self.effectors)))
        object.__setattr__(self, "status", Status(self.status))

    def __getitem__(self, name: str) -> IKResult:
        return self.effectors[name]
