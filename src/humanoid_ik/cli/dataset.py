"""``humanoid-ik dataset --n N --out FILE [--seed S] [--chunk C] [--model PATH]
[--site NAME | --body NAME | --arm SIDE | --limb NAME] [--joints a,b] [--solver NAME]``:
write (target pose, joint solution) pairs on any arm."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    UsageError,
    add_chain_args,
    chain_from_args,
    check_writable,
    int_at_least,
    int_in,
    nonempty_path,
)
from humanoid_ik.cli.progress import progress_bar
from humanoid_ik.experiments.dataset import MAX_CHUNK, MAX_PAIRS, write_dataset

__all__ = ["register"]


def _cmd_dataset(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.suffix != ".npz":
        raise UsageError(f"--out '{out}' must end in .npz")
    check_writable(out)
    chain = chain_from_args(args)  # --site, --body, --arm or --limb, with --joints
    bar = progress_bar(args.n, "pair", out.name)

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)

    t0 = time.perf_counter()
    try:
        write_dataset(
            out,
            args.n,
            args.seed,
            chunk=args.chunk,
            model=args.model,
            progress=progress,
            chain=chain,
            solver=args.solver,
        )
    finally:
        if bar is not None:
            bar.close()
    dt = time.perf_counter() - t0
    print(
        f"wrote {out}: {args.n} pairs (seed {args.seed}) in {dt:.2f} s, {args.n / dt:,.0f} pairs/s"
    )
    return 0


def register(subparsers: Any) -> None:
    """Add ``dataset`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "dataset",
        help="write N (target pose, joint solution) pairs of an arm",
        description="Write N seeded (target pose, joint solution) pairs into an .npz file, "
        "in chunks; the same seed and N always give the same file. The solver is "
        "closed_form where it fits the arm (7 hinges), else auto.",
    )
    p.add_argument(
        "--n",
        type=int_in(1, MAX_PAIRS),
        required=True,
        metavar="N",
        help=f"pairs (at most {MAX_PAIRS:,})",
    )
    p.add_argument(
        "--out", type=nonempty_path, required=True, metavar="FILE", help="output .npz file"
    )
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed (default: 0)")
    p.add_argument(
        "--chunk",
        type=int_in(1, MAX_CHUNK),
        default=65536,
        metavar="C",
        help=f"pairs per chunk (at most {MAX_CHUNK:,})",
    )
    p.add_argument(
        "--solver",
        metavar="NAME",
        help="the solver of every pair (default: closed_form where it fits, else auto)",
    )
    add_chain_args(p)
    p.set_defaults(func=_cmd_dataset)
