"""What a scene's frame costs beyond its solves: the runner's bookkeeping per effector.

Runs each scene without rendering (``SceneRunner.run``: solve, write ``qpos``,
``mj_forward``, measure, the metrics sink) and reads, per frame, the loop's wall time
and the solvers' own time (``EffectorSample.solve_time``); the difference is the
bookkeeping. Prints medians over the frames of ``--rounds`` runs, per frame and per
effector, and the whole run's CPU time (``time.process_time``) per frame beside it::

    python benchmarks/frame_overhead.py --scenes circle,showcase --rounds 5

To compare two checkouts in one session, run the same command in each, alternating
(the figures in ``docs/benchmarks.md`` were measured that way).
"""

from __future__ import annotations

import argparse
import statistics
import time

from humanoid_ik.config.scene import load_scene
from humanoid_ik.run.runner import SceneRunner


def measure(scene: str, rounds: int) -> dict[str, float]:
    """Median per-frame figures [µs] of ``rounds`` runs of ``scene``."""
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
    us = 1e6
    return {
        "effectors": effectors,
        "frame": statistics.median(frame) * us,
        "solve": statistics.median(solve) * us,
        "overhead": statistics.median(over) * us,
        "per_effector": statistics.median(over) * us / effectors,
        "cpu_frame": statistics.median(cpu) * us,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", default="circle,showcase", help="comma-separated scenes")
    p.add_argument("--rounds", type=int, default=5, help="runs of each scene")
    args = p.parse_args(argv)
    print(
        f"{'scene':<12} {'eff':>3} {'frame µs':>9} {'solves µs':>9} "
        f"{'overhead µs':>11} {'per eff µs':>10} {'CPU/frame µs':>12}"
    )
    for name in args.scenes.split(","):
        r = measure(name, args.rounds)
        print(
            f"{name:<12} {r['effectors']:>3} {r['frame']:>9.1f} {r['solve']:>9.1f} "
            f"{r['overhead']:>11.1f} {r['per_effector']:>10.1f} {r['cpu_frame']:>12.1f}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
