"""The ``sweep`` and ``dataset`` subcommands of ``humanoid-ik``.

``humanoid-ik sweep SWEEP.toml [--out DIR] [--workers N] [--ray ADDRESS|local]
[--no-plot]`` runs a sweep's grid of jobs (resumable) and writes its summary;
``humanoid-ik dataset --n N --out FILE [--seed S] [--chunk C] [--model PATH] [--site NAME]
[--joints a,b]`` writes (target pose, joint solution) pairs. A progress bar goes to
stderr when it is a terminal.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from humanoid_ik.cli import UsageError, _names, int_at_least

__all__ = ["register"]

_positive_int = int_at_least(1)
_seed = int_at_least(0)


def _bar(total: int, unit: str, desc: str):
    if not sys.stderr.isatty() or total < 1:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, dynamic_ncols=True)


def _fmt(value, scale: float = 1.0, spec: str = ".3g") -> str:
    return "-" if value is None else format(value * scale, spec)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from humanoid_ik.sweep import load_sweep, read_records, run_sweep

    sweep = load_sweep(args.sweep)
    out = Path(args.out) if args.out else Path("renders") / "sweeps" / sweep.name
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out '{out}' is a file; expected a folder")
    todo = len(sweep.jobs) - len(read_records(out, sweep.jobs)) if out.is_dir() else len(sweep.jobs)
    where = "local pool" if args.ray is None else f"Ray ({args.ray})"
    print(
        f"sweep {sweep.name}: {len(sweep.jobs)} job(s), {len(sweep.jobs) - todo} already done, "
        f"{todo} to run on {where}"
    )
    bar = _bar(todo, "job", sweep.name)
    failed: list[dict] = []

    def progress(done: int, total: int, record: dict) -> None:
        if record["status"] == "failed":
            failed.append(record)
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
    for r in result.records:
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
                f"{_fmt(sum(succ) / len(succ) if succ else None, 100, '11.1f')}%  "
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


def _cmd_dataset(args: argparse.Namespace) -> int:
    import time

    from humanoid_ik.dataset import write_dataset

    out = Path(args.out)
    if out.suffix != ".npz":
        raise UsageError(f"--out '{out}' must end in .npz")
    bar = _bar(args.n, "pair", out.name)

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
            site=args.site,
            joints=_names(args.joints),
            progress=progress,
        )
    finally:
        if bar is not None:
            bar.close()
    dt = time.perf_counter() - t0
    print(
        f"wrote {out}: {args.n} pairs (seed {args.seed}) in {dt:.2f} s, {args.n / dt:,.0f} pairs/s"
    )
    return 0


def register(subparsers) -> None:
    """Add ``sweep`` and ``dataset`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "sweep",
        help="run a grid of scenes/target sets x solvers x seeds (local pool or Ray)",
        description="Expand a sweep file into jobs, run the ones without a result yet on a "
        "local process pool (default) or on Ray, and write summary.csv, summary.json and "
        "summary.png into renders/sweeps/<sweep> (or --out).",
    )
    p.add_argument("sweep", metavar="SWEEP.toml", help="a sweep file")
    p.add_argument("--out", metavar="DIR", help="output folder (default: renders/sweeps/<name>)")
    p.add_argument(
        "--workers",
        type=_positive_int,
        metavar="N",
        help="processes (local pool) or CPUs (--ray local); default: all cores",
    )
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="run on Ray: 'local' starts a local instance, else a cluster address ('auto')",
    )
    p.add_argument("--no-plot", action="store_true", help="skip summary.png")
    p.set_defaults(func=_cmd_sweep)

    p = subparsers.add_parser(
        "dataset",
        help="write N (target pose, joint solution) pairs with the closed-form solver",
        description="Write N seeded (target pose, joint solution) pairs into an .npz file, "
        "in chunks; the same seed and N always give the same file.",
    )
    p.add_argument("--n", type=_positive_int, required=True, metavar="N", help="pairs")
    p.add_argument("--out", required=True, metavar="FILE", help="output .npz file")
    p.add_argument("--seed", type=_seed, default=0, help="seed (default: 0)")
    p.add_argument(
        "--chunk", type=_positive_int, default=65536, metavar="C", help="pairs per chunk"
    )
    p.add_argument("--model", help="MJCF path (default: the bundled humanoid)")
    p.add_argument("--site", help="end-effector site (default: right_palm_site)")
    p.add_argument("--joints", help="comma-separated joint names (default: the path rule)")
    p.set_defaults(func=_cmd_dataset)
