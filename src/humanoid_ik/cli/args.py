"""Argument types and shared arguments of the ``humanoid-ik`` commands."""

from __future__ import annotations

import argparse
import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.limbs import LIMB_NAMES, limb_chain, profile_for
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot_files import package_item, package_problem
from humanoid_ik.errors import HumanoidIKError
from humanoid_ik.outputs.atomic import output_file

__all__ = [
    "Parser",
    "UsageError",
    "add_chain_args",
    "add_joints_arg",
    "add_limb_args",
    "add_limbs_file_arg",
    "add_package_arg",
    "chain_from_args",
    "check_writable",
    "floats",
    "int_at_least",
    "int_in",
    "limb_from_args",
    "names",
    "options",
    "nonempty_path",
    "package_path",
    "package_paths",
    "ray_address",
]


class UsageError(HumanoidIKError):
    """Bad command-line arguments."""


_NUMBER_LIKE = re.compile(r"^-\.?\d")
"""A token that is a value, not an option: ``-`` then a digit (``-0.1,0,1``, ``-.5``)."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line (a :class:`UsageError`) and which
    reads ``--target -0.1,0,1`` as a value (argparse alone takes only a single negative
    number, ``-0.1``, for a value; no option of ours starts with a digit)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NUMBER_LIKE

    def error(self, message: str) -> NoReturn:
        # main prints "humanoid-ik: error: ", so only a command's name goes before it
        command = self.prog.partition(" ")[2]
        raise UsageError(f"{command}: {message}" if command else message)


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


def int_in(minimum: int, maximum: int) -> Callable[[str], int]:
    """An argparse type: an integer from ``minimum`` to ``maximum``, else a one-line error
    naming the bound it breaks (both bounds when it is too large)."""
    at_least = int_at_least(minimum)

    def parse(text: str) -> int:
        value = at_least(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(
                f"expected an integer >= {minimum} and <= {maximum}, got '{text}'"
            )
        return value

    return parse


def nonempty_path(text: str) -> str:
    """An argparse type: a file or folder path, not empty (an empty ``--out`` is a
    mistake, never the default)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a path, got '{text}'")
    return text


def package_path(text: str) -> tuple[str, Path]:
    """An argparse type: ``NAME=DIR``, a ROS package's name and its existing folder."""
    try:
        name, folder = package_item(text)
    except HumanoidIKError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    problem = package_problem(name, folder)
    if problem is not None:
        raise argparse.ArgumentTypeError(f"package path '{text}': {problem}")
    return name, folder


def package_paths(args: argparse.Namespace) -> dict[str, Path]:
    """The ``--package-path`` folders of :func:`add_package_arg` as ``{NAME: DIR}`` (a
    name given twice: the last one)."""
    return dict(getattr(args, "package_path", None) or [])


def ray_address(text: str) -> str:
    """An argparse type: ``local``, ``auto`` or a cluster address (no spaces)."""
    if not text.strip() or any(c.isspace() for c in text):
        raise argparse.ArgumentTypeError(
            "expected 'local', 'auto' or a cluster address (HOST:PORT, ray://HOST:PORT), "
            f"got '{text}'"
        )
    return text


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


def add_package_arg(p: argparse.ArgumentParser) -> None:
    """``--package-path NAME=DIR`` (repeatable): where a URDF's ``package://NAME/...``
    meshes are (every command that takes ``--model`` has it)."""
    p.add_argument(
        "--package-path",
        type=package_path,
        action="append",
        metavar="NAME=DIR",
        help="the folder of the ROS package NAME, for a URDF's package://NAME/... paths "
        "(repeatable; looked in before ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and the folders "
        "above the URDF)",
    )


def add_joints_arg(p: argparse.ArgumentParser) -> None:
    """``--joints``: the chain's joints, instead of the default path rule."""
    p.add_argument("--joints", help="comma-separated joint names (default: the path rule)")


def add_chain_args(p: argparse.ArgumentParser) -> None:
    """``--model``, ``--package-path``, ``--site`` or ``--body`` or a limb (``--arm``,
    ``--limb``, with ``--with-torso`` and ``--limbs``), and ``--joints``: which chain a
    command works on."""
    p.add_argument(
        "--model",
        type=nonempty_path,
        help="MJCF, URDF or xacro path (default: the bundled humanoid)",
    )
    add_package_arg(p)
    ee = p.add_mutually_exclusive_group()
    ee.add_argument("--site", help="end-effector site (default: right_palm_site)")
    ee.add_argument("--body", help="end-effector body, e.g. a URDF link (instead of --site)")
    add_limb_args(p, ee)
    add_joints_arg(p)


def add_limb_args(p: argparse.ArgumentParser, group: Any) -> None:
    """``--arm left|right`` or ``--limb NAME`` (in ``group``, the end-effector choice),
    ``--with-torso`` and ``--limbs FILE``: a limb found from the model
    (``docs/limbs.md``) as the chain."""
    group.add_argument(
        "--arm", choices=("left", "right"), help="the model's left or right arm (its limb)"
    )
    group.add_argument(
        "--limb",
        choices=LIMB_NAMES,
        metavar="NAME",
        help=f"a limb found from the model: {', '.join(LIMB_NAMES)}",
    )
    p.add_argument(
        "--with-torso", action="store_true", help="the torso's joints help the limb reach"
    )
    add_limbs_file_arg(p)


def add_limbs_file_arg(p: argparse.ArgumentParser) -> None:
    """``--limbs FILE``: a limb profile overriding the limbs found (``docs/limbs.md``)."""
    p.add_argument(
        "--limbs",
        type=nonempty_path,
        metavar="FILE",
        help="a limb profile (TOML) overriding what is found (default: <model>.limbs.toml "
        "beside the model, if there is one)",
    )


def chain_from_args(args: argparse.Namespace) -> Chain:
    """The chain named by :func:`add_chain_args`' arguments (the model loaded with the
    ``--package-path`` folders)."""
    model = load_model(args.model, packages=package_paths(args))
    limb = limb_from_args(args)
    if limb is None:
        if getattr(args, "with_torso", False):
            raise UsageError("--with-torso goes with --arm or --limb")
        return Chain(model, args.site, names(args.joints), body=args.body)
    if args.joints is not None:
        raise UsageError("--joints goes with --site or --body, not with a limb")
    profile = profile_for(model, args.model, getattr(args, "limbs", None))
    return limb_chain(model, limb, with_torso=args.with_torso, profile=profile)


def limb_from_args(args: argparse.Namespace) -> str | None:
    """The limb ``--arm`` or ``--limb`` names, ``None`` for neither."""
    arm = getattr(args, "arm", None)
    return f"{arm}_arm" if arm is not None else getattr(args, "limb", None)


def check_writable(path: Path) -> None:
    """Fail with a :class:`UsageError` unless ``path`` is not a folder and its folder exists
    and is writable (checked before a command runs, so nothing is computed in vain and
    no temporary file is left)."""
    if path.is_dir():
        raise UsageError(f"cannot write '{path}': it is a folder; expected a file path")
    path = output_file(path)  # a link written through; a device or FIFO refused
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"cannot write '{path}': folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"cannot write '{path}': folder '{parent}' is not writable")
