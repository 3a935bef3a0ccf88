"""The ``humanoid-ik`` command line. ``main(argv) -> int`` serves the console script and
``python -m humanoid_ik`` alike; each command lives in its own module of this package.

Exit codes: 0 success; 1 a solve that did not converge; 2 bad input (one line on
stderr, no traceback unless ``--debug``); 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
import traceback
from collections.abc import Sequence
from importlib.metadata import version

from humanoid_ik.cli import bench, dataset, scenes, solve, sweep
from humanoid_ik.cli.args import Parser
from humanoid_ik.errors import HumanoidIKError

__all__ = ["build_parser", "main"]

_COMMANDS = (solve, bench, scenes, sweep, dataset)


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command."""
    parser = Parser(
        prog="humanoid-ik", description="Inverse kinematics for humanoid arms on MuJoCo."
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    parser.add_argument(
        "--version", action="version", version=f"humanoid-ik {version('humanoid-ik')}"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for command in _COMMANDS:
        command.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args_list
    try:
        args = build_parser().parse_args(args_list)
        return int(args.func(args))
    except HumanoidIKError as exc:
        if debug:
            traceback.print_exc()
        print(f"humanoid-ik: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        if debug:
            traceback.print_exc()
        print(
            f"humanoid-ik: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print("humanoid-ik: interrupted", file=sys.stderr)
        return 130
    except SystemExit as exc:  # --help
        return int(exc.code or 0)


if __name__ == "__main__":
    sys.exit(main())
