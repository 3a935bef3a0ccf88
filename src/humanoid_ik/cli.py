"""The ``humanoid-ik`` command line. ``main(argv) -> int`` serves the console script and
``python -m humanoid_ik`` alike.

Exit codes: 0 success; 1 a solve that did not converge; 2 bad input (one line on
stderr, no traceback unless ``--debug``); 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from humanoid_ik import __version__
from humanoid_ik.errors import HumanoidIKError

__all__ = ["main", "UsageError"]


class UsageError(HumanoidIKError):
    """Bad command-line arguments."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, no usage dump
        raise UsageError(f"{self.prog}: {message}")


def _floats(text: str, n: int, what: str) -> list[float]:
    parts = [p for p in text.replace(" ", "").split(",") if p != ""]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"{what} '{text}' is not {n} comma-separated numbers") from None
    if len(vals) != n:
        raise UsageError(f"{what} '{text}' has {len(vals)} value(s); expected {n}")
    return vals


def int_at_least(minimum: int):
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


def _names(text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [p.strip() for p in text.split(",") if p.strip()]
    if not names:
        raise UsageError(f"empty name list '{text}'")
    return names


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


def _options(items: Sequence[str] | None) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"option '{item}' is not KEY=VALUE")
        out[key.strip()] = _option_value(value.strip())
    return out


def _add_chain_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", help="MJCF path (default: the bundled humanoid)")
    p.add_argument("--site", help="end-effector site (default: right_palm_site)")
    p.add_argument("--joints", help="comma-separated joint names (default: the path rule)")


def _chain(args: argparse.Namespace):
    from humanoid_ik.chain import Chain

    return Chain(args.model, args.site, _names(args.joints))


def _model_name(args: argparse.Namespace) -> str:
    from humanoid_ik.chain import bundled_model_path

    if args.model:
        return str(args.model)
    try:
        return str(bundled_model_path().relative_to(Path.cwd()))
    except ValueError:
        return "models/humanoid/scene.xml"


# ---------------------------------------------------------------------------- solve
def _cmd_solve(args: argparse.Namespace) -> int:
    import numpy as np

    from humanoid_ik.api import solve
    from humanoid_ik.types import Target

    target = Target(
        _floats(args.target, 3, "--target"),
        None if args.quat is None else _floats(args.quat, 4, "--quat"),
    )
    chain = _chain(args)
    result = solve(chain, target, args.solver, **_options(args.option))
    if args.json:
        doc = {
            "model": _model_name(args),
            "site": chain.ee_name,
            "target": {
                "position": target.position.tolist(),
                "quat": None if target.quat is None else target.quat.tolist(),
            },
            **result.to_dict(chain.joint_names),
        }
        print(json.dumps(doc, indent=2))
    else:
        width = max(len(n) for n in chain.joint_names)
        print(f"solver {result.solver}: {result.status} after {result.iterations} iteration(s)")
        for name, v in zip(chain.joint_names, result.q, strict=True):
            print(f"  {name:<{width}}  {v:+.6f} rad  {np.degrees(v):+9.3f} deg")
        print(f"position error     {result.position_error:.3e} m")
        if result.orientation_error is not None:
            print(f"orientation error  {result.orientation_error:.3e} rad")
        if result.message:
            print(f"note: {result.message}")
    return 0 if result.converged else 1


# ---------------------------------------------------------------------------- bench
def _cmd_bench(args: argparse.Namespace) -> int:
    from humanoid_ik.bench import run_bench

    chain = _chain(args)
    progress = None
    bar = None
    if sys.stderr.isatty():
        from tqdm import tqdm

        bar = tqdm(total=0, unit="solve", file=sys.stderr, leave=False)

        def progress(name: str, done: int, total: int) -> None:
            if bar.total != total or bar.desc != name:
                bar.reset(total=total)
                bar.set_description(name)
            bar.update(1)

    if args.json:
        _check_writable(Path(args.json))
    try:
        report = run_bench(
            chain, args.task, _names(args.solvers), args.n, args.seed, _model_name(args), progress
        )
    finally:
        if bar is not None:
            bar.close()
    print(
        f"model {report.model}  site {report.site}  task {report.task}  n {report.n}  "
        f"seed {report.seed}"
    )
    print(report.table())
    if args.json:
        _write_atomic(Path(args.json), json.dumps(report.to_dict(), indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


def _check_writable(path: Path) -> None:
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"cannot write '{path}': folder '{parent}' does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"cannot write '{path}': folder '{parent}' is not writable")


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    from humanoid_ik.solvers import SOLVERS

    parser = _Parser(
        prog="humanoid-ik", description="Inverse kinematics for humanoid arms on MuJoCo."
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    parser.add_argument("--version", action="version", version=f"humanoid-ik {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    p = sub.add_parser("solve", help="solve one target and print the joint values")
    p.add_argument("--target", required=True, metavar="X,Y,Z", help="target position [m]")
    p.add_argument("--quat", metavar="W,X,Y,Z", help="target orientation (unit quaternion)")
    p.add_argument(
        "--solver",
        default="dls",
        choices=list(SOLVERS),
        metavar="NAME",
        help=f"one of: {', '.join(SOLVERS)} (default: dls)",
    )
    _add_chain_args(p)
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="solver option, repeatable (e.g. method=angle_axis)",
    )
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=_cmd_solve)

    p = sub.add_parser("bench", help="success rate and time per solve on random targets")
    _add_chain_args(p)
    p.add_argument("--task", default="position", choices=["position", "pose"])
    p.add_argument("--solvers", metavar="a,b", help="solvers to run (default: all)")
    p.add_argument("--n", type=int, default=500, help="number of targets (default: 500)")
    p.add_argument("--seed", type=int, default=0, help="target seed (default: 0)")
    p.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    p.set_defaults(func=_cmd_bench)

    for register in _EXTRA_COMMANDS:
        register(sub)
    return parser


def _scene_commands(subparsers) -> None:
    from humanoid_ik.scene_cli import register

    register(subparsers)


_EXTRA_COMMANDS: list = [_scene_commands]
_EXTRA_COMMANDS.append(lambda sub: __import__("humanoid_ik.sweep_cli").sweep_cli.register(sub))


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
