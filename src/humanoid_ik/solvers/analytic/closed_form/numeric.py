"""One arithmetic for one target and for a batch.

The closed form's derivation is written once, in functions whose numbers are either
plain Python floats (one target: no numpy call, about 30 ns an operation) or numpy
arrays that broadcast together (a batch: one numpy call per operation for every
target). Arithmetic operators work on both; the few other operations come from an
:class:`Arithmetic` ``xp``, :data:`FLOATS` or :data:`ARRAYS` (not a rendering backend:
that word is the renderer's, ``outputs/render/backend.py``). Comparisons are combined with ``&``
and ``|``, which mean the same on Python bools and on bool arrays (``not`` and ``~``
do not); only a step that runs on floats alone (``xp.floats``, a lazy reading) branches
on a comparison with ``if``.

A 3-vector is a tuple of three components (floats, or arrays of one shape). A choice
that depends on the data (a fallback where a vector vanishes) is made with
``xp.where`` behind an ``xp.any`` test, so the float path pays for it only when it
happens. Rotations here act on components (:func:`rot`);
:func:`humanoid_ik.core.rotations.axis_angle_matrix` is the matrix of the same
rotation, used where one matrix is needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = [
    "vec",
    "TWO_PI",
    "RANGE_TOL",
    "Real",
    "Vec",
    "Arithmetic",
    "FLOATS",
    "ARRAYS",
    "sub",
    "dot",
    "cross",
    "rot",
    "proj",
    "unit",
    "perp_unit",
    "into_range",
    "X_AXIS",
    "Y_AXIS",
]

TWO_PI = 2.0 * math.pi
RANGE_TOL = 1e-9
"""Slack [rad] on the joint ranges when a swivel is tested (a range end is feasible)."""

Real = Any
"""A float, or an ndarray: the same code runs on both."""
Vec = tuple[Any, Any, Any]
"""A 3-vector as its three components."""

X_AXIS: Vec = (1.0, 0.0, 0.0)
Y_AXIS: Vec = (0.0, 1.0, 0.0)


class Arithmetic:
    """The non-arithmetic operations on numbers of one kind (see the module's docstring).

    The operations are instance attributes (a fast lookup on the float path).

    Attributes:
        floats: the numbers are Python floats (one target): a test may then branch on
            a comparison directly, to skip work that cannot change its outcome.
        sqrt, atan2, acos: as in :mod:`math`.
        where: ``where(cond, a, b)``, ``a`` where ``cond`` holds, else ``b``.
        any: whether ``cond`` holds anywhere.
        maximum: the larger of two numbers, elementwise.
        clip: ``clip(x, lo, hi)``.
        round: to the nearest integer, halves to even (as ``numpy.round``).
    """

    def __init__(
        self,
        floats: bool,
        sqrt: Callable[[Real], Real],
        atan2: Callable[[Real, Real], Real],
        acos: Callable[[Real], Real],
        where: Callable[[Real, Real, Real], Real],
        any: Callable[[Real], bool],
        maximum: Callable[[Real, Real], Real],
        clip: Callable[[Real, float, float], Real],
        round: Callable[[Real], Real],
    ):
        self.floats = floats
        self.sqrt, self.atan2, self.acos = sqrt, atan2, acos
        self.where, self.any, self.maximum = where, any, maximum
        self.clip, self.round = clip, round


def _where(cond: bool, a: Any, b: Any) -> Any:
    return a if cond else b


def _clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


FLOATS = Arithmetic(True, math.sqrt, math.atan2, math.acos, _where, bool, max, _clip, round)
"""The arithmetic of one target: plain Python floats (``math``)."""
ARRAYS = Arithmetic(
    False, np.sqrt, np.arctan2, np.arccos, np.where, np.any, np.maximum, np.clip, np.round
)
"""The arithmetic of a batch."""


def vec(v: Any) -> Vec:
    """A ``(3,)`` array (or any three numbers) as a tuple of floats."""
    return float(v[0]), float(v[1]), float(v[2])


def sub(a: Sequence[Real], b: Sequence[Real]) -> Vec:
    """``a - b``."""
    return a[0] - b[0], a[1] - b[1], a[2] - b[2]


def dot(a: Vec, b: Vec) -> Real:
    """``a . b``."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    """``a x b``."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


def rot(u: Vec, c: Real, s: Real, v: Vec) -> Vec:
    """``Rot(u, t) v = c v + s (u x v) + (1 - c) (u . v) u`` for unit ``u``, with
    ``c, s = cos t, sin t`` (Rodrigues; ``axis_angle_matrix(u, t) @ v`` without the
    matrix, so ``t`` may differ per component of an array)."""
    ux, uy, uz = u
    vx, vy, vz = v
    p = (ux * vx + uy * vy + uz * vz) * (1.0 - c)
    return (
        vx * c + (uy * vz - uz * vy) * s + ux * p,
        vy * c + (uz * vx - ux * vz) * s + uy * p,
        vz * c + (ux * vy - uy * vx) * s + uz * p,
    )


def proj(rows: Sequence[float], v: Vec) -> Vec:
    """``(r1 . v, r2 . v, r3 . v)`` for three vectors given as 9 floats, row after row."""
    a0, a1, a2, b0, b1, b2, c0, c1, c2 = rows
    x, y, z = v
    return a0 * x + a1 * y + a2 * z, b0 * x + b1 * y + b2 * z, c0 * x + c1 * y + c2 * z


def unit(xp: Arithmetic, v: Vec, fallback: Vec | Callable[[], Vec], eps: float = 1e-12) -> Vec:
    """``v / |v|``; where ``|v| < eps`` the vector ``fallback`` (or ``fallback()``, called
    only then)."""
    x, y, z = v
    norm = xp.sqrt(x * x + y * y + z * z)
    small = norm < eps
    if not xp.any(small):
        inv = 1.0 / norm
        return x * inv, y * inv, z * inv
    inv = 1.0 / xp.where(small, 1.0, norm)
    fb = fallback() if callable(fallback) else fallback
    return (
        xp.where(small, fb[0], x * inv),
        xp.where(small, fb[1], y * inv),
        xp.where(small, fb[2], z * inv),
    )


def perp_unit(xp: Arithmetic, v: Vec, n: Vec, fallbacks: Callable[[], Sequence[Vec]]) -> Vec:
    """The unit component of ``v`` normal to unit ``n``: ``w / |w|``, ``w = v - (v . n) n``.

    Done twice: once normalised, a short component is normal to ``n`` to rounding,
    which keeps the frames built from it orthonormal. Where ``|w| < 1e-9`` the first
    of ``fallbacks()`` whose normal component is not that short stands in.
    """
    nx, ny, nz = n
    d = v[0] * nx + v[1] * ny + v[2] * nz
    wx, wy, wz = v[0] - d * nx, v[1] - d * ny, v[2] - d * nz
    norm = xp.sqrt(wx * wx + wy * wy + wz * wz)
    bad = norm < 1e-9
    if xp.any(bad):
        return _perp_fallback(xp, (wx, wy, wz), norm, bad, n, fallbacks)
    inv = 1.0 / norm
    wx, wy, wz = wx * inv, wy * inv, wz * inv
    d = wx * nx + wy * ny + wz * nz
    wx, wy, wz = wx - d * nx, wy - d * ny, wz - d * nz
    inv = 1.0 / xp.sqrt(wx * wx + wy * wy + wz * wz)
    return wx * inv, wy * inv, wz * inv


def _normal_part(v: Vec, n: Vec) -> Vec:
    d = v[0] * n[0] + v[1] * n[1] + v[2] * n[2]
    return v[0] - d * n[0], v[1] - d * n[1], v[2] - d * n[2]


def _perp_fallback(
    xp: Arithmetic, w: Vec, norm: Real, bad: Real, n: Vec, fallbacks: Callable[[], Sequence[Vec]]
) -> Vec:
    """:func:`perp_unit` where some ``|w|`` is short (the same arithmetic elsewhere)."""
    inv = 1.0 / xp.where(bad, 1.0, norm)
    out = _normal_part((w[0] * inv, w[1] * inv, w[2] * inv), n)
    norm = xp.sqrt(dot(out, out))
    inv = 1.0 / xp.where(norm > 0.0, norm, 1.0)
    out = (out[0] * inv, out[1] * inv, out[2] * inv)
    for fb in fallbacks():
        alt = _normal_part(fb, n)
        an = xp.sqrt(dot(alt, alt))
        ok = bad & (an >= 1e-9)
        inv = 1.0 / xp.where(an < 1e-12, 1.0, an)
        out = (
            xp.where(ok, alt[0] * inv, out[0]),
            xp.where(ok, alt[1] * inv, out[1]),
            xp.where(ok, alt[2] * inv, out[2]),
        )
        bad = bad & (an < 1e-9)
        if not xp.any(bad):
            break
    return out


def into_range(xp: Arithmetic, q: Real, center: Real) -> Real:
    """``q + 2 pi round((center - q) / 2 pi)``: ``q`` shifted by turns next to ``center``."""
    return q + TWO_PI * xp.round((center - q) / TWO_PI)


def __getattr__(name: str) -> Any:
    if name == "Backend":  # its former name, for one release
        import warnings

        warnings.warn(
            f"{__name__}.Backend is deprecated; use Arithmetic", DeprecationWarning, stacklevel=2
        )
        return Arithmetic
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
