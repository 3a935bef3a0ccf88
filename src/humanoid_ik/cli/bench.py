"""``humanoid-ik bench``: success rate, wall and CPU time per solve on random targets."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    add_chain_args,
    chain_from_args,
    check_writable,
    int_at_least,
    int_in,
    names,
    nonempty_path,
)
from humanoid_ik.cli.progress import progress_bar
from humanoid_ik.core.checks import MAX_TARGETS
from humanoid_ik.core.models import display_model
from humanoid_ik.core.types import TARGET_KINDS
from humanoid_ik.experiments.bench import MAX_REPEAT, run_bench
from humanoid_ik.outputs.atomic import write_json

__all__ = ["register"]


def _cmd_bench(args: argparse.Namespace) -> int:
    if args.json is not None:
        check_writable(Path(args.json))
    chain = chain_from_args(args)
    bar = progress_bar(args.n * args.repeat, "solve")

    def progress(name: str, done: int, total: int) -> None:
        if bar is None:
            return
        if bar.total != total or bar.desc != name:
            bar.reset(total=total)
            bar.set_description(name)
        bar.update(1)

    try:
        report = run_bench(
            chain,
            args.task,
            names(args.solvers),
            args.n,
            args.seed,
            display_model(args.model),
            progress,
            args.repeat,
        )
    finally:
        if bar is not None:
            bar.close()
    print(
        f"model {report.model}  {report.effector} {report.site}  task {report.task}  n {report.n}  "
        f"seed {report.seed}" + (f"  repeat {report.repeat}" if report.repeat > 1 else "")
    )
    print(report.table())
    if args.json is not None:
        write_json(args.json, report.to_dict(), indent=2)
        print(f"wrote {args.json}")
    return 0


def register(subparsers: Any) -> None:
    """Add ``bench`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "bench", help="success rate, wall and CPU time per solve on random targets"
    )
    add_chain_args(p)
    p.add_argument("--task", default="position", choices=list(TARGET_KINDS))
    p.add_argument("--solvers", metavar="a,b", help="solvers to run (default: all)")
    p.add_argument(
        "--n",
        type=int_in(1, MAX_TARGETS),
        default=500,
        help=f"number of targets, at most {MAX_TARGETS:,} (default: 500)",
    )
    p.add_argument("--seed", type=int_at_least(0), default=0, help="target seed (default: 0)")
    p.add_argument(
        "--repeat",
        type=int_in(1, MAX_REPEAT),
        default=1,
        metavar="K",
        help=f"solve the targets K times and show the spread of the medians, K at most "
        f"{MAX_REPEAT} (default: 1)",
    )
    p.add_argument(
        "--json", type=nonempty_path, metavar="PATH", help="also write the results as JSON"
    )
    p.set_defaults(func=_cmd_bench)
