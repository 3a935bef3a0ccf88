"""Exceptions of humanoid_ik: one root class, narrow subclasses.

Every message names the bad value and, where there is a finite set, the valid choices.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from typing import Any


class HumanoidIKError(Exception):
    """Root of every error raised by humanoid_ik."""


class ModelError(HumanoidIKError):
    """A model path that does not exist or XML that MuJoCo cannot compile."""


class NameNotFoundError(HumanoidIKError, KeyError):
    """A site, body or joint name that is not in the model."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]):
        self.kind = kind
        self.name = name
        self.valid = sorted(valid)
        shown = ", ".join(self.valid) if self.valid else "(none)"
        plural = "bodies" if kind == "body" else f"{kind}s"
        super().__init__(f"{kind} '{name}' not in model; {plural}: {shown}")

    def __str__(self) -> str:  # KeyError would quote the message.
        return str(self.args[0])


class UnsupportedJointError(HumanoidIKError):
    """A joint type the chain cannot drive (ball, slide, free) on the chain's path."""


class ChainError(HumanoidIKError):
    """A chain that cannot be built: no joints, joints not on the end effector's path."""


class TargetError(HumanoidIKError, ValueError):
    """A target with NaN/inf, a wrong shape, or a zero quaternion."""


class SolverError(HumanoidIKError, ValueError):
    """An unknown solver name, a bad solver option, or a solver that does not fit the chain."""


def choices(valid: Iterable[str]) -> str:
    """Comma-separated list of valid choices for an error message."""
    return ", ".join(sorted(valid))


class MotionError(HumanoidIKError, ValueError):
    """A target motion with a bad parameter (a negative radius, a zero normal...)
    (``TrajectoryError`` before: "trajectory" now means the files of a run only).

    Attributes:
        field: the parameter's name, e.g. ``radius``.
        expected: what the parameter must be, e.g. ``a number > 0``.
        got: the value that was given.
    """

    def __init__(self, field: str, expected: str, got: object):
        self.field = field
        self.expected = expected
        self.got = got
        super().__init__(f"{field}: expected {expected}, got {show_value(got)}")


class SceneError(HumanoidIKError, ValueError):
    """A scene file that cannot be read or does not fit the model.

    Attributes:
        path: the scene file as the user named it.
        key: the dotted key of the bad value, e.g. ``targets[0].motion.radius``
            (``""`` for the file as a whole).
    """

    def __init__(self, path: object, key: str, message: str):
        self.path = str(path)
        self.key = key
        where = f"{self.path}: {key}" if key else self.path
        super().__init__(f"{where}: {message}")


class RenderError(HumanoidIKError):
    """No working OpenGL backend, an unknown camera, or an output folder that cannot be
    written."""


def show_value(value: object) -> str:
    """A value as it would be written in a TOML scene file (for error messages)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {show_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(show_value(v) for v in value) + "]"
    if hasattr(value, "tolist"):
        return show_value(value.tolist())
    return repr(value)


class SweepError(HumanoidIKError, ValueError):
    """A sweep file that cannot be read or expanded, or a sweep that cannot run (Ray
    missing, an output folder that cannot be written).

    Attributes:
        path: the sweep file as the user named it (``""`` when no file is involved).
        key: the dotted key of the bad value, e.g. ``solvers[1].grid.damping``.
    """

    def __init__(self, path: object, key: str, message: str):
        self.path = "" if path is None else str(path)
        self.key = key
        where = ": ".join(p for p in (self.path, key) if p)
        super().__init__(f"{where}: {message}" if where else message)


class DatasetError(HumanoidIKError, ValueError):
    """A dataset request that cannot be met (bad size, a chain without the closed-form
    structure) or a file that is not a humanoid_ik dataset."""


class TrajectoryFileError(HumanoidIKError, ValueError):
    """A trajectory file that cannot be read, or that does not fit the model it is played
    or exported on (other joints, another model file's digest)."""


class BVHError(HumanoidIKError, ValueError):
    """A BVH file that cannot be read: a syntax error (the message names the line and
    what was expected there), a bad conversion option or an unknown joint name.

    Attributes:
        path: the file as the caller named it (``"<text>"`` for a string).
        line: the line number of the error (1 for the first line; 0 when no line is to
            blame).
    """

    def __init__(self, path: object, line: int, message: str):
        self.path = str(path)
        self.line = line
        where = f"{self.path}: line {line}" if line else self.path
        super().__init__(f"{where}: {message}")


class RetargetError(HumanoidIKError, ValueError):
    """A retarget that cannot run: a skeleton without arms (the names looked for are
    given), a bad mapping file or solver, a robot without arms."""


def renamed(module: str, names: dict[str, str], namespace: dict[str, Any]) -> Any:
    """A module ``__getattr__`` (PEP 562) for names kept one release after a rename:
    ``names`` maps each former name to its new one in ``namespace`` (the module's
    ``globals()``); a former name warns (``DeprecationWarning`` at the caller's line,
    naming the new one) and gives the new object. Use:
    ``__getattr__ = renamed(__name__, {"old": "new"}, globals())``."""

    def __getattr__(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        new = names[name]
        warnings.warn(
            f"{module}.{name} is deprecated; use {module}.{new}", DeprecationWarning, stacklevel=2
        )
        return namespace[new]

    return __getattr__


__getattr__ = renamed(__name__, {"TrajectoryError": "MotionError"}, globals())
