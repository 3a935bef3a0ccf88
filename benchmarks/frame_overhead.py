"""What a scene's frame costs beyond its solves: the runner's bookkeeping per effector.

Runs each scene without rendering (``SceneRunner.run``: targets, solve, write ``qpos``,
``mj_kinematics``, measure, the recording) and reads, per frame, the loop's wall time
and the solvers' own time (``EffectorSample.solve_time``); the difference is the
bookkeeping. Prints medians over the frames of ``--rounds`` runs, per frame and per
effector, and the whole run's CPU time (``time.process_time``) per frame beside it.
Then the same frames once more with every solve replayed (each solver object hands back
the result it gave in the first run, so the loop does everything but solve): the CPU
and wall time per effector of the bookkeeping alone, with warm caches (the solves no
longer evict them), over ``--replays`` passes::

    python benchmarks/frame_overhead.py --scenes circle,showcase --rounds 5

``--against SRC`` compares with another copy of the package (``SRC``, a folder holding
``humanoid_ik/``, e.g. the previous release's ``src/``): both sides run in turn,
``--pairs`` times, each in a fresh interpreter (``SRC`` first on ``PYTHONPATH`` for the
old side), and the ratios new / old of the medians are printed. On a shared, noisy
machine compare those ratios, not the figures (``docs/benchmarks.md``)::

    python benchmarks/frame_overhead.py --scenes circle,showcase --against /tmp/old/src
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from typing import Any

from humanoid_ik.config.scene import load_scene
from humanoid_ik.run.runner import SceneRunner

FIELDS = ("per_effector", "replay_cpu", "replay_wall", "overhead", "solve", "cpu_frame")


class _Replay:
    """Stands in for one solver object's solve method: records what the real one returns,
    then hands the same results back in the same order (one list per pass)."""

    def __init__(self, solver: Any) -> None:
        self.name = "solve_effectors" if solver.solves_effectors else "solve"
        self.real = getattr(solver, self.name)
        self.given: list[Any] = []
        self.calls: Any = None  # None: record; else an iterator over ``given``
        solver.__dict__[self.name] = self

    def __call__(self, *args: Any, **kw: Any) -> Any:
        if self.calls is not None:
            return next(self.calls)
        out = self.real(*args, **kw)
        self.given.append(list(out) if self.name == "solve_effectors" else out)
        return out


def _replayed(runner: SceneRunner, passes: int) -> tuple[float, float]:
    """CPU and wall time [s] per frame and effector of ``passes`` runs of ``runner``'s
    scene with every solve replayed from one real run."""
    # one stand-in per solver object (effectors with the same spec share one); the
    # previous release's runner has no ``solvers`` property yet
    groups = runner.solvers if hasattr(runner, "solvers") else runner._groups
    solvers = list({id(s): s for s, _members in groups}.values())
    stand_ins = [_Replay(solver) for solver in solvers]
    runner.run()
    frames = 0
    c0, w0 = time.process_time(), time.perf_counter()
    for _ in range(passes):
        for r in stand_ins:
            r.calls = iter(r.given)
        frames += len(runner.run().frames)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    for solver, r in zip(solvers, stand_ins, strict=True):
        del solver.__dict__[r.name]
    n = frames * len(runner.chains)
    return cpu / n, wall / n


def measure(scene: str, rounds: int, replays: int = 20) -> dict[str, float]:
    """Median per-frame figures [µs] of ``rounds`` runs of ``scene``, and the replayed
    bookkeeping's CPU and wall time per effector [µs] over ``replays`` passes."""
    runner = SceneRunner(load_scene(scene))
    effectors = len(runner.chains)
    runner.run()  # warm-up: imports, caches
    frame, solve, cpu = [], [], []
    for _ in range(rounds):
        c0 = time.process_time()
        metrics = runner.run()
        cpu.append((time.process_time() - c0) / len(metrics.frames))
        for t, rec in zip(metrics.frame_times, metrics.frames, strict=True):
            frame.append(t)
            solve.append(rec.solve_time)
    over = [f - s for f, s in zip(frame, solve, strict=True)]
    replay_cpu, replay_wall = _replayed(runner, replays)
    us = 1e6
    return {
        "effectors": effectors,
        "frame": statistics.median(frame) * us,
        "solve": statistics.median(solve) * us,
        "overhead": statistics.median(over) * us,
        "per_effector": statistics.median(over) * us / effectors,
        "cpu_frame": statistics.median(cpu) * us,
        "replay_cpu": replay_cpu * us,
        "replay_wall": replay_wall * us,
    }


HEADER = (
    f"{'scene':<12} {'eff':>3} {'frame µs':>9} {'solves µs':>9} {'overhead µs':>11} "
    f"{'per eff µs':>10} {'CPU/frame µs':>12} {'replay CPU/eff':>14} {'replay wall/eff':>15}"
)


def row(name: str, r: dict[str, float]) -> str:
    """One scene's figures as a line of the table."""
    return (
        f"{name:<12} {r['effectors']:>3} {r['frame']:>9.1f} {r['solve']:>9.1f} "
        f"{r['overhead']:>11.1f} {r['per_effector']:>10.1f} {r['cpu_frame']:>12.1f} "
        f"{r['replay_cpu']:>14.2f} {r['replay_wall']:>15.2f}"
    )


def _side(src: str | None, args: argparse.Namespace) -> dict[str, dict[str, float]]:
    """One side's figures, from a fresh interpreter (``src`` first on ``PYTHONPATH``)."""
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    cmd = [sys.executable, __file__, "--scenes", args.scenes, "--rounds", str(args.rounds)]
    cmd += ["--replays", str(args.replays), "--json"]
    return json.loads(subprocess.run(cmd, env=env, check=True, capture_output=True).stdout)


def compare(args: argparse.Namespace) -> None:
    """Old (``args.against``) and new in turn, ``args.pairs`` times; then, per figure, the
    medians of each side and the ratio new / old of each pair (its median and range)."""
    runs: dict[str, list[dict[str, dict[str, float]]]] = {"old": [], "new": []}
    for k in range(args.pairs):
        for side, src in (("old", args.against), ("new", None)):
            runs[side].append(out := _side(src, args))
            print(f"-- pair {k + 1}, {side}")
            for name, r in out.items():
                print(row(name, r))
    print("\nmedian new / median old [µs], ratio new / old: median of the pairs (range)")
    for name in args.scenes.split(","):
        print(name)
        for f in FIELDS:
            old = [r[name][f] for r in runs["old"]]
            new = [r[name][f] for r in runs["new"]]
            ratios = [n / o for n, o in zip(new, old, strict=True)]
            print(
                f"  {f:<13} {statistics.median(new):9.2f} / {statistics.median(old):9.2f}"
                f"   {statistics.median(ratios):5.2f} ({min(ratios):.2f}-{max(ratios):.2f})"
            )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", default="circle,showcase", help="comma-separated scenes")
    p.add_argument("--rounds", type=int, default=5, help="runs of each scene")
    p.add_argument("--replays", type=int, default=20, help="passes with the solves replayed")
    p.add_argument("--against", metavar="SRC", help="compare with the package in SRC")
    p.add_argument("--pairs", type=int, default=3, help="old/new turns with --against")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = p.parse_args(argv)
    if args.against:
        compare(args)
        return 0
    out = {name: measure(name, args.rounds, args.replays) for name in args.scenes.split(",")}
    if args.json:
        print(json.dumps(out))
        return 0
    print(HEADER)
    for name, r in out.items():
        print(row(name, r))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
