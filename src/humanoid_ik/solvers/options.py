"""Typed solver options: one frozen dataclass per solver, checked once when it is made.

A solver declares its options as a dataclass deriving from :class:`SolverOptions`;
``make_solver(name, **options)`` (and scene and sweep files) hand keyword arguments to
:meth:`SolverOptions.parse`, which rejects unknown names and wrong types with one line
naming the bad value and the valid ones. The solver reads ``self.options.<name>``.

Checks follow each field's default: a ``bool`` takes only ``true``/``false``; an ``int``
or ``float`` a finite number >= 0 (an ``int`` an integral one); a ``str`` one of the
field's ``choices``; a field whose default is ``None`` is checked by its solver.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import MISSING, Field, dataclass, field, fields
from typing import Any, Self

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

    @classmethod
    def parse(cls, solver: str, given: Mapping[str, Any]) -> Self:
        """The options of solver ``solver`` from keyword values (defaults elsewhere).

        Raises:
            SolverError: an unknown name (the valid ones are listed) or a bad value.
        """
        by_name = {f.name: f for f in fields(cls)}
        values = {}
        for key, value in given.items():
            f = by_name.get(key)
            if f is None:
                raise SolverError(
                    f"option '{key}' unknown for solver '{solver}'; options: {choices(by_name)}"
                )
            values[key] = _check(solver, f, value)
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
