"""Reading TOML files (scene files, sweep files): the document, and typed access to its
values that fails with one line naming the file, the key and what was expected, e.g.
``scenes/x.toml: targets[0].motion.radius: expected a number > 0, got 'big'``.

The value checks themselves are :mod:`humanoid_ik.core.checks` (shared with the motions'
constructors); :meth:`TomlReader.call` turns their
:class:`~humanoid_ik.errors.MotionError` into the reader's error.
"""

from __future__ import annotations

import json
import os
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from humanoid_ik.core.robot_files import package_problem
from humanoid_ik.errors import HumanoidIKError, MotionError, SceneError, show_value

__all__ = ["NAME", "TomlReader", "display_path", "join_key", "quote_key", "read_toml"]

NAME = "a name of letters, digits, '_', '-' or '.'"
"""What a name (of a scene, a sweep, a target set) must be."""
_NAME_RE = re.compile(r"[A-Za-z0-9_.-]+")
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")

ErrorType = Callable[[str, str, str], HumanoidIKError]
"""``error(file, key, message)``: :class:`SceneError` or :class:`SweepError`."""


def display_path(path: str | os.PathLike) -> str:
    """``path`` relative to the working folder when it lies inside it, else as given."""
    p = Path(path)
    try:
        return str(p.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(p)


def join_key(prefix: str, key: str) -> str:
    """The dotted key ``prefix.key`` (``key`` alone at the top level)."""
    return f"{prefix}.{key}" if prefix else key


def quote_key(key: Any) -> str:
    """A table key as TOML writes it: bare (``radius``) when it can be, else quoted
    (``"a b"``, control characters escaped), so a message names it on one line."""
    if isinstance(key, str) and _BARE_KEY.fullmatch(key):
        return key
    return json.dumps(str(key))


def read_toml(path: Path, source: str, error: ErrorType) -> dict[str, Any]:
    """The TOML document at ``path``.

    Args:
        path: the file.
        source: how messages name it.
        error: the error type, e.g. :class:`SceneError`.

    Raises:
        HumanoidIKError: ``error(source, "", message)`` when the file cannot be read or
            is not valid TOML.
    """
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise error(source, "", f"not valid TOML: {exc}") from None
    except OSError as exc:
        raise error(source, "", f"cannot be read: {exc.strerror or exc}") from None


class TomlReader:
    """Typed access to a parsed TOML document, failing with file + key + expectation.

    Args:
        source: how messages name the file.
        error: the error raised, ``error(source, key, message)``: :class:`SceneError`
            (the default) or :class:`~humanoid_ik.errors.SweepError`.
    """

    def __init__(self, source: str, error: ErrorType = SceneError):
        self.source = source
        self.error = error

    def fail(self, key: str, message: str) -> HumanoidIKError:
        """The error for ``key`` with ``message`` (to raise), kept on one line (a line
        break in a message from elsewhere is shown as ``\\n``)."""
        message = message.replace("\r", "\\r").replace("\n", "\\n")
        return self.error(self.source, key, message)

    def expect(self, key: str, expected: str, got: Any) -> HumanoidIKError:
        """The error ``key: expected <expected>, got <got>`` (to raise)."""
        return self.fail(key, f"expected {expected}, got {show_value(got)}")

    def table(self, key: str, value: Any) -> dict[str, Any]:
        """``value`` when it is a table."""
        if not isinstance(value, dict):
            raise self.expect(key, "a table", value)
        return value

    def keys(
        self,
        prefix: str,
        table: Any,
        allowed: Mapping[str, str],
        required: Sequence[str] = (),
    ) -> dict[str, Any]:
        """``table`` once checked: a table, no unknown key, every required one present.

        Args:
            prefix: the table's own key (``""`` for the document).
            table: the value.
            allowed: key -> what it must be (for the message of a missing key).
            required: keys that must be present.
        """
        table = self.table(prefix, table)
        for k in table:
            if k not in allowed:
                raise self.fail(
                    join_key(prefix, quote_key(k)),
                    f"unknown key; expected one of {', '.join(sorted(allowed))}",
                )
        for k in required:
            if k not in table:
                raise self.fail(join_key(prefix, k), f"missing; expected {allowed[k]}")
        return table

    def call(self, prefix: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``fn(*args, **kwargs)`` (a ``check_*`` or a motion's constructor), with a
        :class:`MotionError` for parameter ``field`` turned into the reader's error
        at key ``prefix.field``."""
        try:
            return fn(*args, **kwargs)
        except MotionError as exc:
            raise self.expect(join_key(prefix, exc.field), exc.expected, exc.got) from None

    def string(self, key: str, value: Any, what: str = "a string") -> str:
        """``value`` when it is a non-empty string."""
        if not isinstance(value, str) or not value:
            raise self.expect(key, what, value)
        return value

    def integer(self, key: str, value: Any, low: int, high: int | None = None) -> int:
        """``value`` when it is an integer (not a float) ``>= low`` and ``<= high``."""
        bad = isinstance(value, bool) or not isinstance(value, int) or value < low
        if bad or (high is not None and value > high):
            upper = "" if high is None else f" and <= {high}"
            raise self.expect(key, f"an integer >= {low}{upper}", value)
        return value

    def name(self, key: str, value: Any, *, first_alphanumeric: bool = False) -> str:
        """``value`` when it is a :data:`NAME` (starting with a letter or digit when
        ``first_alphanumeric``)."""
        ok = isinstance(value, str) and _NAME_RE.fullmatch(value) is not None
        if ok and first_alphanumeric and value[0] in "_.-":
            ok = False
        if not ok:
            raise self.expect(key, NAME, value)
        return value

    def package_paths(self, key: str, value: Any, base: Path | None) -> dict[str, Path]:
        """``value`` when it is a ``package_path`` table ``{ NAME = "DIR" }``: ROS package
        folders (``core/robot_files.py``), a relative ``DIR`` relative to ``base`` (the
        file's folder; the working folder for ``None``), each an existing folder."""
        table = self.table(key, value)
        out: dict[str, Path] = {}
        for name, folder in table.items():
            at = join_key(key, quote_key(name))
            if not isinstance(folder, str) or not folder:
                raise self.expect(at, "a package folder (a string)", folder)
            path = Path(folder).expanduser()
            path = path if path.is_absolute() else (base or Path(".")) / path
            problem = package_problem(str(name), path)
            if problem is not None:
                raise self.fail(at, problem)
            out[str(name)] = path
        return out

    def array(self, key: str, doc: Mapping[str, Any], what: str) -> list:
        """``doc[key]`` when it is an array (an empty one when absent)."""
        value = doc.get(key, [])
        if not isinstance(value, list):
            raise self.expect(key, what, value)
        return value
