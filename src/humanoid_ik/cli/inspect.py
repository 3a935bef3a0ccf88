"""``humanoid-ik inspect [--model M] [--joints J1,J2...] [--package-path NAME=DIR]
[--json]``: the end effectors a model offers, the joints of each, which solvers apply,
the reach, the frames that are not end effectors, and what looks wrong in the model."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    add_limbs_file_arg,
    check_writable,
    names,
    nonempty_path,
    package_paths,
)
from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.models import HomeWarning, load_model
from humanoid_ik.experiments.inspection import inspect_model
from humanoid_ik.outputs.atomic import json_text, write_text

__all__ = ["register"]


def _cmd_inspect(args: argparse.Namespace) -> int:
    if args.save_limbs is not None:
        check_writable(Path(args.save_limbs))
    report = inspect_model(
        args.model, names(args.joints), packages=package_paths(args), limbs=args.limbs
    )
    if args.save_limbs is not None:
        with warnings.catch_warnings():  # the report has the home pose's line
            warnings.simplefilter("ignore", HomeWarning)
            model = load_model(args.model, packages=package_paths(args))
        write_text(args.save_limbs, profile_for(model, args.model, args.limbs).to_toml())
    if args.json:
        print(json_text(report.to_dict(), indent=2))
    else:
        print(report.text())
    return 0


def register(subparsers: Any) -> None:
    """Add ``inspect`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "inspect",
        help="end effectors, joints, applicable solvers and warnings of a model",
        description="Show what a model offers: each site, leaf body and hand link that is "
        "an end effector (sensor, camera, finger and helper frames are listed apart, with "
        "the reason), the joints the default rule (or --joints) picks for it (type, axis "
        "in the world frame at home, range in rad and deg, whether qpos0 is inside), which "
        "solvers apply and why the others do not, the chain's reach, and suspicious "
        "ranges, joints or a home pose outside the ranges.",
    )
    p.add_argument(
        "--model", type=nonempty_path, help="MJCF or URDF path (default: the bundled humanoid)"
    )
    add_limbs_file_arg(p)
    p.add_argument(
        "--save-limbs",
        type=nonempty_path,
        metavar="FILE",
        help="write the limbs found (with --limbs applied) as a profile to edit (TOML)",
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=_cmd_inspect)
