"""Typed solver options: one frozen dataclass per solver, checked once when it is made.

A solver declares its options as a dataclass deriving from :class:`SolverOptions`;
``make_solver(name, **options)`` (and scene and sweep files) hand keyword arguments to
:meth:`SolverOptions.parse`, which rejects unknown names and wrong types with one line
naming the bad value and the valid ones. The solver reads ``self.options.<name>``.

Checks follow each field's default: a ``bool`` takes only ``true``/``false``; an ``int``
or ``float`` a finite number >= 0 (an ``int`` an integral one); a ``str`` one of the
field's ``choices``; a field whose default is ``None`` is checked by its solver.

Bounds: a number may also have explicit ``(lower, upper)`` bounds in the class's
``BOUNDS`` (merged along the class hierarchy, a subclass's entry winning), checked by
:meth:`SolverOptions.parse` with the bounds in the message. Every solver's options
bound ``tol`` (at most 1 m) and ``rot_tol`` (at most pi rad): larger tolerances accept
any pose. Iteration counts, restarts and windows are bounded where they are declared,
so that a solve stays finite in time and memory.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import MISSING, Field, dataclass, field, fields
from typing import Any, ClassVar, Self

from humanoid_ik.errors import SolverError, choices

__all__ = ["SolverOptions", "option"]


def option(default: Any, *, valid: tuple[str, ...] | None = None) -> Any:
    """A dataclass field with a default and, for a string option, its valid values."""
    return field(default=default, metadata={"choices": valid} if valid else {})


@dataclass(frozen=True)
class SolverOptions:
    """The options every solver takes.

    Attributes:
        tol: position tolerance [m].
        rot_tol: orientation tolerance [rad].
    """

    tol: float = 1e-4
    rot_tol: float = 1e-3
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "tol": (0.0, 1.0),
        "rot_tol": (0.0, math.pi),
    }
    """``(lower, upper)`` bounds of numeric options by name (see the module docstring)."""

    @classmethod
    def bounds(cls) -> dict[str, tuple[float, float]]:
        """Every bounded option's ``(lower, upper)``: the ``BOUNDS`` of the class and
        its bases, a subclass's entry winning."""
        out: dict[str, tuple[float, float]] = {}
        for klass in reversed(cls.__mro__):
            out.update(vars(klass).get("BOUNDS", {}))
        return out

    @classmethod
    def parse(cls, solver: str, given: Mapping[str, Any]) -> Self:
        """The options of solver ``solver`` from keyword values (defaults elsewhere).

        Raises:
            SolverError: an unknown name (the valid ones are listed) or a bad value.
        """
        by_name = {f.name: f for f in fields(cls)}
        bounds = cls.bounds()
        values = {}
        for key, value in given.items():
            f = by_name.get(key)
            if f is None:
                raise SolverError(
                    f"option '{key}' unknown for solver '{solver}'; options: {choices(by_name)}"
                )
            values[key] = _check(solver, f, value)
            if key in bounds:
                _check_bounds(solver, key, values[key], *bounds[key])
        return cls(**values)

    def as_dict(self) -> dict[str, Any]:
        """Every option by name, in declaration order."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


def _check(solver: str, f: Field[Any], value: Any) -> Any:
    default = f.default if f.default is not MISSING else None
    where = f"option '{f.name}' of solver '{solver}'"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise SolverError(f"{where} must be true or false, got {value!r}")
        return value
    if isinstance(default, (int, float)):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SolverError(f"{where} must be a number, got {value!r}")
        if not math.isfinite(value) or value < 0:
            raise SolverError(f"{where} must be a finite number >= 0, got {value!r}")
        if isinstance(default, int):
            if value != int(value):
                raise SolverError(f"{where} must be an integer, got {value!r}")
            return int(value)
        return float(value)
    if isinstance(default, str):
        allowed = f.metadata.get("choices") or ()
        if not isinstance(value, str) or (allowed and value not in allowed):
            raise SolverError(f"{where} is {value!r}; choices: {choices(allowed)}")
        return value
    return value


def _check_bounds(solver: str, key: str, value: Any, low: float, high: float) -> None:
    """Raises SolverError unless ``low <= value <= high``; a value that is not a finite
    number (an option whose default is ``None``) is left to its solver's own check."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    if not math.isfinite(value) or low <= value <= high:
        return
    kind = "an integer" if isinstance(value, int) else "a finite number"
    raise SolverError(
        f"option '{key}' of solver '{solver}' must be {kind} >= {_num(low)} and "
        f"<= {_num(high)}, got {value!r}"
    )


def _num(x: float) -> str:
    """A bound as written: integral values without a decimal point or exponent."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"
