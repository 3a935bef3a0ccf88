"""Target orientation over time, for pose targets."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.checks import check_number, check_vector
from humanoid_ik.core.rotations import quat_mul
from humanoid_ik.errors import MotionError
from humanoid_ik.motion.base import set_frozen

__all__ = ["Orientation"]


@dataclass(frozen=True)
class Orientation:
    """A target orientation over time: ``quat`` rocked about a world ``axis``.

    ``q(t) = exp(axis * amplitude * sin(2 pi t / period)) * quat`` (wxyz, the rocking
    applied in the world frame); ``amplitude = 0`` holds ``quat``.

    Args:
        quat: unit quaternion ``(4,)`` wxyz (norm within 1e-3 of 1).
        axis: rocking axis ``(3,)``, not zero (default +z).
        amplitude: rocking amplitude [rad], >= 0.
        period: rocking period [s], > 0.
    """

    quat: NDArray[np.float64]
    axis: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    amplitude: float = 0.0
    period: float = 4.0

    def __post_init__(self) -> None:
        q = check_vector("quat", self.quat, 4, nonzero=True)
        if abs(float(np.linalg.norm(q)) - 1.0) > 1e-3:
            raise MotionError("quat", "a unit quaternion [w, x, y, z]", self.quat)
        q = q / np.linalg.norm(q)
        q.setflags(write=False)
        set_frozen(self, "quat", q)
        a = check_vector("axis", self.axis, nonzero=True)
        a = a / np.linalg.norm(a)
        a.setflags(write=False)
        set_frozen(self, "axis", a)
        set_frozen(self, "amplitude", check_number("amplitude", self.amplitude, low=0.0))
        set_frozen(self, "period", check_number("period", self.period, low=0.0, strict=True))

    @classmethod
    def parameters(cls) -> list[str]:
        """The keys a scene's ``orientation`` table may hold."""
        return [f.name for f in fields(cls)]

    def quat_at(self, t: float) -> NDArray[np.float64]:
        """Unit wxyz quaternion ``(4,)`` at time ``t`` [s]."""
        if self.amplitude == 0.0:
            return np.array(self.quat)
        angle = self.amplitude * math.sin(2.0 * math.pi * max(t, 0.0) / self.period)
        rock = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * self.axis])
        return quat_mul(rock, self.quat)
