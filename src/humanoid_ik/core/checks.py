"""Value checks: a parameter converted to its type, or one error naming it.

Each ``check_*`` returns the converted value or raises
:class:`~humanoid_ik.errors.TrajectoryError` ``(field, expected, got)``. The motions'
constructors call them on their parameters, and the TOML reader
(:class:`~humanoid_ik.config.toml.TomlReader`) calls them on file values, turning the
error into a :class:`~humanoid_ik.errors.SceneError` that names the file and the key.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import TrajectoryError

__all__ = [
    "check_bool",
    "check_choice",
    "check_int",
    "check_number",
    "check_points",
    "check_vector",
]


def check_number(name: str, value: Any, *, low: float | None = None, strict: bool = False) -> float:
    """``value`` as a finite float, ``> low`` (``strict``) or ``>= low``.

    Args:
        name: the parameter's name (for the error).
        value: the value given.
        low: the lower bound, or ``None`` for none.
        strict: the bound is exclusive.
    """
    if low is None:
        expected = "a number"
    else:
        expected = f"a number {'>' if strict else '>='} {low:g}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise TrajectoryError(name, expected, value)
    v = float(value)
    if not math.isfinite(v):
        raise TrajectoryError(name, expected, value)
    if low is not None and (v <= low if strict else v < low):
        raise TrajectoryError(name, expected, value)
    return v


def check_int(name: str, value: Any, *, low: int | None = None) -> int:
    """``value`` as an int ``>= low`` (a float with an integer value is accepted)."""
    expected = "an integer" if low is None else f"an integer >= {low}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer)):
        raise TrajectoryError(name, expected, value)
    if isinstance(value, float) and (not math.isfinite(value) or value != int(value)):
        raise TrajectoryError(name, expected, value)
    v = int(value)
    if low is not None and v < low:
        raise TrajectoryError(name, expected, value)
    return v


def check_bool(name: str, value: Any) -> bool:
    """``value`` when it is ``true`` or ``false``."""
    if not isinstance(value, (bool, np.bool_)):
        raise TrajectoryError(name, "true or false", value)
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
        raise TrajectoryError(name, expected, value)
    items = list(value)
    if len(items) != n or any(
        isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in items
    ):
        raise TrajectoryError(name, expected, value)
    arr = np.array(items, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise TrajectoryError(name, expected, value)
    if low is not None and np.any(arr < low):
        raise TrajectoryError(name, expected, value)
    if nonzero and float(np.linalg.norm(arr)) < 1e-12:
        raise TrajectoryError(name, expected, value)
    arr.setflags(write=False)
    return arr


def check_points(name: str, value: Any, *, minimum: int = 1) -> NDArray[np.float64]:
    """``value`` as a read-only ``(N, 3)`` array [m] with ``N >= minimum``; a bad point
    is named ``name[i]``."""
    expected = f"a list of at least {minimum} point(s) [x, y, z]"
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TrajectoryError(name, expected, value)
    if len(value) < minimum:
        raise TrajectoryError(name, expected, value)
    rows = [check_vector(f"{name}[{i}]", p) for i, p in enumerate(value)]
    arr = np.array(rows, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def check_choice(name: str, value: Any, valid: Sequence[str]) -> str:
    """``value`` when it is one of ``valid``."""
    if not isinstance(value, str) or value not in valid:
        raise TrajectoryError(name, f"one of {', '.join(repr(v) for v in valid)}", value)
    return value
