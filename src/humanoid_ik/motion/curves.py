"""Closed curves a target goes round: :class:`Circle`, :class:`FigureEight` and
:class:`Lissajous`, each periodic in time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.checks import check_bool, check_number, check_vector
from humanoid_ik.motion.base import Motion, plane_basis, set_frozen

__all__ = ["Circle", "FigureEight", "Lissajous"]


def _floats(*vectors: NDArray[np.float64]) -> tuple[float, ...]:
    """The coordinates of ``vectors`` as one tuple of floats, for a curve's position."""
    return tuple(x for vec in vectors for x in vec.tolist())


@dataclass(frozen=True)
class Circle(Motion):
    """A circle in the plane through ``center`` with ``normal``.

    ``p(t) = c + r (cos th u + sin th v)``, ``th = 2 pi t / period + phase`` (negated when
    ``reverse``), with ``(u, v)`` from :func:`plane_basis`: counter-clockwise seen from
    the side the normal points to.

    Args:
        center: ``(3,)`` [m].
        radius: [m], > 0.
        normal: plane normal ``(3,)``, not zero (default +x: the frontal plane).
        period: time of one turn [s], > 0.
        phase: start angle [rad].
        reverse: turn clockwise instead.
    """

    kind: ClassVar[str] = "circle"
    summary: ClassVar[str] = "a circle in any plane"
    center: NDArray[np.float64]
    radius: float
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    period: float = 4.0
    phase: float = 0.0
    reverse: bool = False
    u: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    v: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _floats: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_frozen(self, "center", check_vector("center", self.center))
        set_frozen(self, "radius", check_number("radius", self.radius, low=0.0, strict=True))
        set_frozen(self, "normal", check_vector("normal", self.normal, nonzero=True))
        set_frozen(self, "period", check_number("period", self.period, low=0.0, strict=True))
        set_frozen(self, "phase", check_number("phase", self.phase))
        set_frozen(self, "reverse", check_bool("reverse", self.reverse))
        u, v = plane_basis(self.normal)
        set_frozen(self, "u", u)
        set_frozen(self, "v", v)
        set_frozen(self, "_floats", _floats(self.center, u, v))

    def angle(self, t: float) -> float:
        """``th(t)`` [rad]."""
        th = 2.0 * math.pi * max(t, 0.0) / self.period
        return (-th if self.reverse else th) + self.phase

    def position(self, t: float) -> NDArray[np.float64]:
        # c + r (cos th u + sin th v), per coordinate in floats: the same operations in
        # the same order as on the arrays, without numpy's cost on three values
        th = self.angle(t)
        r, ct, st = self.radius, math.cos(th), math.sin(th)
        c0, c1, c2, u0, u1, u2, v0, v1, v2 = self._floats
        return np.array(
            (
                c0 + r * (ct * u0 + st * v0),
                c1 + r * (ct * u1 + st * v1),
                c2 + r * (ct * u2 + st * v2),
            )
        )


@dataclass(frozen=True)
class FigureEight(Motion):
    """A figure-eight (a 1:2 Lissajous curve) in the plane through ``center``.

    ``p(t) = c + (w/2) sin(th) u + (h/2) sin(2 th) v`` with ``th = 2 pi t / period + phase``
    and ``(u, v)`` from :func:`plane_basis`: lying (like infinity) ``width`` across and
    ``height`` tall; it crosses itself at the centre.

    Args:
        center: ``(3,)`` [m].
        width: extent along ``u`` [m], > 0.
        height: extent along ``v`` [m], > 0.
        normal: plane normal ``(3,)`` (default +x).
        period: time of one loop [s], > 0.
        phase: start angle [rad].
    """

    kind: ClassVar[str] = "figure8"
    summary: ClassVar[str] = "a figure-eight in any plane"
    center: NDArray[np.float64]
    width: float
    height: float
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    period: float = 6.0
    phase: float = 0.0
    u: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    v: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _floats: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_frozen(self, "center", check_vector("center", self.center))
        set_frozen(self, "width", check_number("width", self.width, low=0.0, strict=True))
        set_frozen(self, "height", check_number("height", self.height, low=0.0, strict=True))
        set_frozen(self, "normal", check_vector("normal", self.normal, nonzero=True))
        set_frozen(self, "period", check_number("period", self.period, low=0.0, strict=True))
        set_frozen(self, "phase", check_number("phase", self.phase))
        u, v = plane_basis(self.normal)
        set_frozen(self, "u", u)
        set_frozen(self, "v", v)
        set_frozen(self, "_floats", _floats(self.center, u, v))

    def position(self, t: float) -> NDArray[np.float64]:
        # c + a u + b v per coordinate in floats (the order of the array expression)
        th = 2.0 * math.pi * max(t, 0.0) / self.period + self.phase
        a = 0.5 * self.width * math.sin(th)
        b = 0.5 * self.height * math.sin(2.0 * th)
        c0, c1, c2, u0, u1, u2, v0, v1, v2 = self._floats
        return np.array((c0 + a * u0 + b * v0, c1 + a * u1 + b * v1, c2 + a * u2 + b * v2))


@dataclass(frozen=True)
class Lissajous(Motion):
    """A Lissajous curve: ``p_i(t) = c_i + A_i sin(2 pi f_i t + phi_i)`` per world axis.

    Args:
        center: ``(3,)`` [m].
        amplitude: ``(3,)`` [m], each >= 0.
        frequency: ``(3,)`` [Hz], each >= 0.
        phase: ``(3,)`` [rad].
    """

    kind: ClassVar[str] = "lissajous"
    summary: ClassVar[str] = "a Lissajous curve (a sine per axis)"
    center: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    frequency: NDArray[np.float64]
    phase: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        set_frozen(self, "center", check_vector("center", self.center))
        set_frozen(self, "amplitude", check_vector("amplitude", self.amplitude, low=0.0))
        set_frozen(self, "frequency", check_vector("frequency", self.frequency, low=0.0))
        set_frozen(self, "phase", check_vector("phase", self.phase))

    def position(self, t: float) -> NDArray[np.float64]:
        t = max(t, 0.0)
        return self.center + self.amplitude * np.sin(
            2.0 * math.pi * self.frequency * t + self.phase
        )
