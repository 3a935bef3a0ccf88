"""``humanoid-ik solve``: solve one target and print the joint values, the errors and the
solve's CPU and wall time."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from typing import Any

import numpy as np

from humanoid_ik.cli.args import add_chain_args, chain_from_args, floats, options
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import HomeWarning, bundled_model_path, display_model, home_warning
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.experiments.inspection import range_hints
from humanoid_ik.outputs.atomic import json_text
from humanoid_ik.solvers import SOLVERS, make_solver

__all__ = ["register"]


def _cmd_solve(args: argparse.Namespace) -> int:
    target = Target.of(
        floats(args.target, 3, "--target"),
        None if args.quat is None else floats(args.quat, 4, "--quat"),
    )
    with warnings.catch_warnings():  # said below as a warning, and in --json
        warnings.simplefilter("ignore", HomeWarning)
        chain = chain_from_args(args)
    home = home_warning(chain.model)
    if home is not None:
        print(f"humanoid-ik: warning: {home}", file=sys.stderr)
    result, cpu, wall = _timed_solve(chain, target, args.solver, options(args.option))
    hints = [] if result.converged else _hints(chain, args.model)
    if args.json:
        doc = {
            "model": display_model(args.model),
            chain.ee_kind: chain.ee_name,
            "target": {
                "position": target.position.tolist(),
                "quat": None if target.quat is None else target.quat.tolist(),
            },
            **result.to_dict(chain.joint_names),
            "solve_cpu_s": cpu,
            "solve_wall_s": wall,
            "hints": hints,
            "warnings": [] if home is None else [home],
        }
        print(json_text(doc, indent=2))
    else:
        width = max(len(n) for n in chain.joint_names)
        name = result.solver
        if name != args.solver:  # the solver auto chose
            name = f"{args.solver} -> {name}"
        print(f"solver {name}: {result.status} after {result.iterations} iteration(s)")
        for name, v in zip(chain.joint_names, result.q, strict=True):
            print(f"  {name:<{width}}  {v:+.6f} rad  {np.degrees(v):+9.3f} deg")
        print(f"position error     {result.position_error:.3e} m")
        if result.orientation_error is not None:
            print(f"orientation error  {result.orientation_error:.3e} rad")
        print(f"solve time         {cpu * 1e3:.3f} ms CPU, {wall * 1e3:.3f} ms wall")
        if result.message:
            print(f"note: {result.message}")
        for hint in hints:
            print(f"hint: {hint}")
    return 0 if result.converged else 1


def _timed_solve(
    chain: Chain, target: Target, solver: str, opts: dict[str, Any]
) -> tuple[IKResult, float, float]:
    """The solve, its process CPU time and its wall time [s] (``time.process_time``,
    ``time.perf_counter``); what the solver builds once per chain (its
    :meth:`~humanoid_ik.solvers.base.Solver.prepare`) is built before the clocks start,
    as ``bench`` does."""
    s = make_solver(solver, **opts)
    s.prepare(chain)
    chain.reset()
    c0, w0 = time.process_time(), time.perf_counter()
    result = s.solve(chain, target)
    return result, time.process_time() - c0, time.perf_counter() - w0


def _hints(chain: Chain, model: str | None) -> list[str]:
    """What in the chain's joint ranges may explain a failed solve (ranges that look like
    the wrong angle unit, joints without a range)."""
    mine = {f"'{n}'" for n in chain.joint_names}
    path = bundled_model_path() if model is None else model
    return [h for h in range_hints(chain.model, path) if h.split()[1] in mine]


def register(subparsers: Any) -> None:
    """Add ``solve`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser("solve", help="solve one target and print the joint values")
    p.add_argument("--target", required=True, metavar="X,Y,Z", help="target position [m]")
    p.add_argument("--quat", metavar="W,X,Y,Z", help="target orientation (unit quaternion)")
    p.add_argument(
        "--solver",
        default="auto",
        choices=list(SOLVERS),
        metavar="NAME",
        help=f"one of: {', '.join(SOLVERS)} (default: auto)",
    )
    add_chain_args(p)
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="solver option, repeatable (e.g. method=angle_axis)",
    )
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=_cmd_solve)
