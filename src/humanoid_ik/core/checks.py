"""Value checks: a parameter converted to its type, or one error naming it.

Each ``check_*`` returns the converted value or raises
:class:`~humanoid_ik.errors.MotionError` ``(field, expected, got)``. The motions'
constructors call them on their parameters, and the typed models of scene and sweep
files (``config/schema.py``) call them on file values, turning the error into a
:class:`~humanoid_ik.errors.SceneError` that names the file and the key.

Size-like values have explicit upper bounds, named in the error (``docs/limits.md``
lists every bound of the package): :data:`MAX_POINTS` here for a motion's points,
:data:`MAX_TARGETS` for a benchmark's or a sweep's target set.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import MotionError, TargetError

MAX_POINTS = 10_000
"""Most points a motion's ``points`` list may hold (``points``, ``waypoints``)."""
MAX_TARGETS = 1_000_000
"""Most targets in one benchmark run (``bench --n``) or one sweep target set (``n``)."""

__all__ = [
    "MAX_POINTS",
    "MAX_TARGETS",
    "check_bool",
    "check_choice",
    "check_int",
    "check_number",
    "check_points",
    "check_vector",
    "float_array",
]


def _range(kind: str, low: float | None, high: float | None, strict: bool = False) -> str:
    """``a number > 0 and <= 1000``: what a value must be, for a message."""
    parts = [kind]
    if low is not None:
        parts.append(f"{'>' if strict else '>='} {_show(low)}")
    if high is not None:
        parts.append(f"{'and ' if low is not None else ''}<= {_show(high)}")
    return " ".join(parts)


def _show(bound: float) -> str:
    """A bound as written in a message: an integer in full (``100000``), else ``%g``."""
    return str(int(bound)) if float(bound).is_integer() and abs(bound) < 1e15 else f"{bound:g}"


def check_number(
    name: str,
    value: Any,
    *,
    low: float | None = None,
    strict: bool = False,
    high: float | None = None,
) -> float:
    """``value`` as a finite float, ``> low`` (``strict``) or ``>= low``, and ``<= high``.

    Args:
        name: the parameter's name (for the error).
        value: the value given.
        low: the lower bound, or ``None`` for none.
        strict: the lower bound is exclusive.
        high: the upper bound (inclusive), or ``None`` for none.
    """
    expected = _range("a number", low, high, strict)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise MotionError(name, expected, value)
    try:
        v = float(value)
    except OverflowError:  # an int beyond float's range
        raise MotionError(name, expected, value) from None
    if not math.isfinite(v):
        raise MotionError(name, expected, value)
    if low is not None and (v <= low if strict else v < low):
        raise MotionError(name, expected, value)
    if high is not None and v > high:
        raise MotionError(name, expected, value)
    return v


def check_int(name: str, value: Any, *, low: int | None = None, high: int | None = None) -> int:
    """``value`` as an int ``>= low`` and ``<= high`` (a float with an integer value is
    accepted)."""
    expected = _range("an integer", low, high)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer)):
        raise MotionError(name, expected, value)
    if isinstance(value, float) and (not math.isfinite(value) or value != int(value)):
        raise MotionError(name, expected, value)
    v = int(value)
    if (low is not None and v < low) or (high is not None and v > high):
        raise MotionError(name, expected, value)
    return v


def check_bool(name: str, value: Any) -> bool:
    """``value`` when it is ``true`` or ``false``."""
    if not isinstance(value, (bool, np.bool_)):
        raise MotionError(name, "true or false", value)
    return bool(value)


def check_vector(
    name: str, value: Any, n: int = 3, *, low: float | None = None, nonzero: bool = False
) -> NDArray[np.float64]:
    """``value`` as a read-only float64 ``(n,)`` array of finite numbers.

    Args:
        name: the parameter's name (for the error).
        value: a sequence of ``n`` numbers.
        n: the length (3 reads as ``[x, y, z]``, 4 as a quaternion ``[w, x, y, z]``).
        low: each component at least this, or ``None``.
        nonzero: reject a vector of norm below 1e-12.
    """
    what = {3: "[x, y, z]", 4: "[w, x, y, z]"}.get(n, f"{n} numbers")
    expected = f"{n} numbers {what}" if n in (3, 4) else what
    if low is not None:
        expected += f", each >= {low:g}"
    if nonzero:
        expected += ", not all zero"
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)):
        raise MotionError(name, expected, value)
    items = list(value)
    if len(items) != n or any(
        isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in items
    ):
        raise MotionError(name, expected, value)
    arr = np.array(items, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise MotionError(name, expected, value)
    if low is not None and np.any(arr < low):
        raise MotionError(name, expected, value)
    if nonzero and float(np.linalg.norm(arr)) < 1e-12:
        raise MotionError(name, expected, value)
    arr.setflags(write=False)
    return arr


def check_points(
    name: str, value: Any, *, minimum: int = 1, maximum: int = MAX_POINTS
) -> NDArray[np.float64]:
    """``value`` as a read-only ``(N, 3)`` array [m] with ``minimum <= N <= maximum``; a
    bad point is named ``name[i]``."""
    expected = f"a list of at least {minimum} point(s) [x, y, z]"
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)):
        raise MotionError(name, expected, value)
    if len(value) < minimum:
        raise MotionError(name, expected, value)
    if len(value) > maximum:  # the count, not the list, goes into the message
        raise MotionError(name, f"at most {maximum} points", len(value))
    rows = [check_vector(f"{name}[{i}]", p) for i, p in enumerate(value)]
    arr = np.array(rows, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def check_choice(name: str, value: Any, valid: Sequence[str]) -> str:
    """``value`` when it is one of ``valid``."""
    if not isinstance(value, str) or value not in valid:
        raise MotionError(name, f"one of {', '.join(repr(v) for v in valid)}", value)
    return value


def float_array(what: str, value: Any) -> NDArray[np.float64]:
    """``value`` as a new float64 array (any shape; the caller checks it), or a
    :class:`~humanoid_ik.errors.TargetError` naming ``what`` when it holds something
    that is not a number (a string, ``None`` inside a list, an object).

    The library's entry points take targets, quaternions and joint vectors through it,
    so a wrong type is one error of the package, never a bare ``ValueError``."""
    if isinstance(value, (str, bytes)):
        raise TargetError(f"{what} must be numbers, got the text {value!r}")
    kind = getattr(getattr(value, "dtype", None), "kind", "f")
    if kind in "bcUSV":  # numpy would drop an imaginary part or read True as 1.0
        raise TargetError(f"{what} must be real numbers, got an array of {value.dtype}")
    try:
        return np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise TargetError(f"{what} must be numbers, got {shown}") from None
