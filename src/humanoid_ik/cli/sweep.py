"""``humanoid-ik sweep SWEEP.toml|NAME [--out DIR] [--workers N] [--ray ADDRESS|local]
[--no-plot]``: run a sweep's grid of jobs (resumable) and write its summary. ``NAME`` is
a bundled sweep (``sweeps/``, :func:`~humanoid_ik.config.sweep_file.find_sweep`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import UsageError, int_in, nonempty_path, ray_address
from humanoid_ik.cli.progress import progress_bar
from humanoid_ik.config.sweep_file import load_sweep
from humanoid_ik.experiments.sweep import check_out, damaged_results, read_results, run_sweep
from humanoid_ik.experiments.sweep.executors import MAX_WORKERS
from humanoid_ik.experiments.sweep.summary import percent

__all__ = ["register"]


def _fmt(value, scale: float = 1.0, spec: str = ".3g") -> str:
    return "-" if value is None else format(value * scale, spec)


def _cmd_sweep(args: argparse.Namespace) -> int:
    sweep = load_sweep(args.sweep)
    out = Path("renders") / "sweeps" / sweep.name if args.out is None else Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out '{out}' is a file; expected a folder")
    check_out(out)  # before anything is announced or run
    todo = len(sweep.jobs)
    if out.is_dir():
        todo -= len(read_results(out, sweep.jobs))
        for path, why in damaged_results(out, sweep.jobs).items():
            print(
                f"humanoid-ik: note: {path} is not a whole job result ({why}); that job runs again",
                file=sys.stderr,
            )
    where = "local pool" if args.ray is None else f"Ray ({args.ray})"
    print(
        f"sweep {sweep.name}: {len(sweep.jobs)} job(s), {len(sweep.jobs) - todo} already done, "
        f"{todo} to run on {where}"
    )
    bar = progress_bar(todo, "job", sweep.name)
    failed: list[dict] = []

    def progress(done: int, total: int, result: dict) -> None:
        if result["status"] == "failed":
            failed.append(result)
        if bar is not None:
            bar.update(1)

    try:
        result = run_sweep(
            sweep,
            out,
            workers=args.workers,
            ray_address=args.ray,
            progress=progress,
            plot=not args.no_plot,
        )
    finally:
        if bar is not None:
            bar.close()
    # one line per solver configuration, pooled over every set and seed
    by_config: dict[str, list[dict]] = {}
    for r in result.results:
        if r["status"] == "ok":
            by_config.setdefault(r["config"], []).append(r)
    if by_config:
        width = max(len(c) for c in by_config)
        print(f"  {'configuration':<{width}}  jobs  mean success  median ms  worst error m")
        for cfg in sorted(by_config):
            rs = by_config[cfg]
            succ = [r["success_rate"] for r in rs if r["success_rate"] is not None]
            ms = sorted(r["median_solve_ms"] for r in rs if r["median_solve_ms"] is not None)
            errs = [r["max_error_m"] for r in rs if r["max_error_m"] is not None]
            print(
                f"  {cfg:<{width}}  {len(rs):>4}  "
                f"{percent(sum(succ) / len(succ) if succ else None, '11.1f')}%  "
                f"{_fmt(ms[len(ms) // 2] if ms else None, 1, '9.3f')}  "
                f"{_fmt(max(errs) if errs else None, 1, '13.3e')}"
            )
    counts = result.counts()
    print(
        f"{len(result.executed)} run, {len(result.cached)} skipped as done; "
        f"ok {counts['ok']}, failed {counts['failed']}, not applicable {counts['skipped']}; "
        f"{result.wall_s:.1f} s"
    )
    for r in failed:
        print(f"humanoid-ik: job {r['id']} failed: {r['error']}", file=sys.stderr)
    for f in result.files:
        print(f"wrote {f}")
    return 1 if counts["failed"] else 0


def register(subparsers: Any) -> None:
    """Add ``sweep`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "sweep",
        help="run a grid of scenes/target sets x solvers x seeds (local pool or Ray)",
        description="Expand a sweep file (or a bundled sweep, by name) into jobs, run the "
        "ones without a result yet on a local process pool (default) or on Ray, and write "
        "summary.csv, summary.json and summary.png into renders/sweeps/<sweep> (or --out).",
    )
    p.add_argument(
        "sweep",
        metavar="SWEEP.toml|NAME",
        help="a sweep file, or a bundled sweep's name (compare_solvers: sweeps/<NAME>.toml; "
        "HUMANOID_IK_SWEEPS sets that folder)",
    )
    p.add_argument(
        "--out",
        type=nonempty_path,
        metavar="DIR",
        help="output folder (default: renders/sweeps/<name>)",
    )
    p.add_argument(
        "--workers",
        type=int_in(1, MAX_WORKERS),
        metavar="N",
        help=f"processes (local pool) or CPUs (--ray local), at most {MAX_WORKERS}; "
        "default: all cores",
    )
    p.add_argument(
        "--ray",
        type=ray_address,
        metavar="ADDRESS",
        help="run on Ray: 'local' starts a local instance, else a cluster address ('auto')",
    )
    p.add_argument("--no-plot", action="store_true", help="skip summary.png")
    p.set_defaults(func=_cmd_sweep)
