"""``humanoid-ik inspect [--model M] [--json]``: the end effectors a model offers, the
joints of each, which solvers apply, the reach, and what looks wrong in the model."""

from __future__ import annotations

import argparse
import json
from typing import Any

from humanoid_ik.cli.args import nonempty_path
from humanoid_ik.experiments.inspection import inspect_model

__all__ = ["register"]


def _cmd_inspect(args: argparse.Namespace) -> int:
    report = inspect_model(args.model)
    if args.json:
        print(json.dumps(report.to_dict(), indent=2))
    else:
        print(report.text())
    return 0


def register(subparsers: Any) -> None:
    """Add ``inspect`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "inspect",
        help="end effectors, joints, applicable solvers and warnings of a model",
        description="Show what a model offers: each site and leaf body that can be an end "
        "effector, the joints the default rule picks for it (type, axis, range in rad and "
        "deg, whether qpos0 is inside), which solvers apply and why the others do not, the "
        "chain's reach, and suspicious ranges or joints.",
    )
    p.add_argument(
        "--model", type=nonempty_path, help="MJCF or URDF path (default: the bundled humanoid)"
    )
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=_cmd_inspect)
