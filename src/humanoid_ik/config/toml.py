"""Reading TOML files (scene files, sweep files): the document, and how messages name
the file and its keys (``targets[0].motion."a b"``). The documents' values are checked
by the typed models of :mod:`humanoid_ik.config.schema`."""

from __future__ import annotations

import json
import os
import re
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from humanoid_ik.core.names import NAME, name_ok  # the one name rule, re-exported
from humanoid_ik.errors import HumanoidIKError

__all__ = [
    "NAME",
    "ErrorType",
    "display_path",
    "integer_problem",
    "join_key",
    "name_ok",
    "quote_key",
    "read_toml",
]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")

ErrorType = Callable[[str, str, str], HumanoidIKError]
"""``error(file, key, message)``: :class:`SceneError` or :class:`SweepError`."""


def integer_problem(value: Any, low: int, high: int | None = None) -> str | None:
    """What ``value`` must be unless it is an integer (a TOML integer, not a float)
    ``>= low`` and ``<= high``, else ``None``."""
    bad = isinstance(value, bool) or not isinstance(value, int) or value < low
    if bad or (high is not None and value > high):
        return f"an integer >= {low}" + ("" if high is None else f" and <= {high}")
    return None


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
