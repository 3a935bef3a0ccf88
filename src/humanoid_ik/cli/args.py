"""Argument types and shared arguments of the ``humanoid-ik`` commands."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from humanoid_ik.core.chain import Chain
from humanoid_ik.errors import HumanoidIKError

__all__ = [
    "Parser",
    "UsageError",
    "add_chain_args",
    "chain_from_args",
    "check_writable",
    "floats",
    "int_at_least",
    "names",
    "options",
]


class UsageError(HumanoidIKError):
    """Bad command-line arguments."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line (a :class:`UsageError`)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message}")


def floats(text: str, n: int, what: str) -> list[float]:
    """``n`` comma-separated numbers, else a :class:`UsageError` naming ``what``."""
    parts = [p for p in text.replace(" ", "").split(",") if p != ""]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"{what} '{text}' is not {n} comma-separated numbers") from None
    if len(vals) != n:
        raise UsageError(f"{what} '{text}' has {len(vals)} value(s); expected {n}")
    return vals


def int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer >= ``minimum``, else a one-line error."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got '{text}'")
        return value

    return parse


def names(text: str | None) -> list[str] | None:
    """A comma-separated name list (``None`` stays ``None``)."""
    if text is None:
        return None
    out = [p.strip() for p in text.split(",") if p.strip()]
    if not out:
        raise UsageError(f"empty name list '{text}'")
    return out


def _option_value(text: str) -> Any:
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    if "," in text:
        return [_option_value(t) for t in text.split(",")]
    return text


def options(items: Sequence[str] | None) -> dict[str, Any]:
    """``KEY=VALUE`` items as a dict (booleans, numbers and comma lists converted)."""
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"option '{item}' is not KEY=VALUE")
        out[key.strip()] = _option_value(value.strip())
    return out


def add_chain_args(p: argparse.ArgumentParser) -> None:
    """``--model``, ``--site`` and ``--joints``: which chain a command works on."""
    p.add_argument("--model", help="MJCF path (default: the bundled humanoid)")
    p.add_argument("--site", help="end-effector site (default: right_palm_site)")
    p.add_argument("--joints", help="comma-separated joint names (default: the path rule)")


def chain_from_args(args: argparse.Namespace) -> Chain:
    """The chain named by :func:`add_chain_args`' arguments."""
    return Chain(args.model, args.site, names(args.joints))


def check_writable(path: Path) -> None:
    """Fail with a :class:`UsageError` unless ``path``'s folder exists and is writable."""
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"cannot write '{path}': folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"cannot write '{path}': folder '{parent}' is not writable")
