"""What every target motion shares: the :class:`Motion` interface and the easing and
interpolation formulas the motion kinds are built from.

Every motion is a frozen dataclass whose parameters are checked in ``__post_init__``
(a bad one raises :class:`~humanoid_ik.errors.MotionError` naming the parameter,
what it must be and what it was; see :mod:`humanoid_ik.core.checks`) and whose
:meth:`Motion.position` is a pure function of time, so a scene renders the same frames
every run.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import MISSING, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Motion", "hermite", "plane_basis", "set_frozen", "smoothstep"]


def set_frozen(obj: Any, name: str, value: Any) -> None:
    """Set attribute ``name`` of a frozen dataclass (in its ``__post_init__``, to store
    the checked value of a parameter)."""
    object.__setattr__(obj, name, value)


def smoothstep(u: float) -> float:
    """Cosine ease ``s(u) = (1 - cos(pi u)) / 2`` for ``u`` clipped to [0, 1].

    ``s(0) = 0``, ``s(1) = 1`` and ``s'(0) = s'(1) = 0``: the target starts and stops at rest.
    """
    u = min(max(u, 0.0), 1.0)
    return 0.5 * (1.0 - math.cos(math.pi * u))


def hermite(
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    m0: NDArray[np.float64],
    m1: NDArray[np.float64],
    h: float,
    s: float,
) -> NDArray[np.float64]:
    """Cubic Hermite point ``(3,)`` [m] on a segment of duration ``h`` [s] at fraction
    ``s`` in [0, 1].

    ``p(s) = (2s^3 - 3s^2 + 1) p0 + (s^3 - 2s^2 + s) h m0 + (-2s^3 + 3s^2) p1
    + (s^3 - s^2) h m1`` with end points ``p0``, ``p1`` ``(3,)`` [m] and end velocities
    ``m0``, ``m1`` ``(3,)`` [m/s].
    """
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * h * m0
        + (-2 * s3 + 3 * s2) * p1
        + (s3 - s2) * h * m1
    )


def plane_basis(normal: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit in-plane axes ``(u, v)``, each ``(3,)``, of the plane with ``normal`` ``(3,)``,
    with ``u x v = n``.

    ``v`` is the in-plane direction closest to world up (+z), or to +x when the plane is
    horizontal; ``u = v x n``. For the frontal plane (``n = +x``, the humanoid faces +x)
    ``u = +y`` and ``v = +z``.
    """
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    ref = np.array([0.0, 0.0, 1.0])
    if abs(float(n @ ref)) > 0.999:
        ref = np.array([1.0, 0.0, 0.0])
    v = ref - float(ref @ n) * n
    v /= np.linalg.norm(v)
    u = np.cross(v, n)
    return u, v


class Motion(ABC):
    """Where a target is over time. Subclasses are frozen dataclasses, registered by
    ``kind`` in :data:`humanoid_ik.motion.registry.MOTIONS`."""

    kind: ClassVar[str]
    """The name a scene file uses in ``motion.kind``."""
    summary: ClassVar[str]
    """One line for ``humanoid-ik scenes``."""

    @abstractmethod
    def position(self, t: float) -> NDArray[np.float64]:
        """Target position ``(3,)`` [m] at time ``t`` [s] (``t < 0`` is read as 0): a new
        float64 array on each call, which the caller keeps (:meth:`TargetTrack.at
        <humanoid_ik.motion.track.TargetTrack.at>` makes it the target's, read-only)."""

    @property
    def horizon(self) -> float:
        """The latest time [s] the motion can be evaluated at: ``inf``, except for a motion
        that keeps what it draws (a ``random_walk`` holds a bounded number of knots)."""
        return math.inf

    def positions(self, times: ArrayLike) -> NDArray[np.float64]:
        """Positions ``(N, 3)`` [m] at each of ``times`` ``(N,)`` [s]."""
        return np.array([self.position(float(t)) for t in np.asarray(times, dtype=np.float64)])

    @classmethod
    def parameters(cls) -> list[str]:
        """The parameter names (the keys a scene's ``motion`` table may hold besides kind)."""
        return [f.name for f in fields(cls) if f.init]  # type: ignore[arg-type]

    @classmethod
    def required(cls) -> list[str]:
        """Parameters without a default."""
        return [
            f.name
            for f in fields(cls)  # type: ignore[arg-type]
            if f.init and f.default is MISSING and f.default_factory is MISSING
        ]
