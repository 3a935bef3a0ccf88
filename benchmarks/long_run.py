"""A long tracking run: a target moves on a path that leaves the reachable workspace and
comes back; every step is solved warm-started from the previous one.

Reports: steps, NaN count, joint-range violations, the steps whose target lies within
5 cm of the arm's reach (some of those still lie outside the joint ranges) and how many
of them were missed by more than 1 mm, the worst error among them, time per step
(median, p95) and memory: the process's peak resident set after warm-up (1000 steps)
and at the end, and with ``--heap`` the Python heap traced by tracemalloc (which slows
every step several times over; times are then not comparable).

    .venv/bin/python benchmarks/long_run.py --steps 100000 --solver dls
"""

from __future__ import annotations

import argparse
import math
import resource
import sys
import time
import tracemalloc

import numpy as np

from humanoid_ik import Chain, make_solver


def target_at(step: int) -> np.ndarray:
    """A Lissajous path around the right shoulder whose radius swells past the reach."""
    t = step * 0.01
    radius = 0.45 + 0.3 * math.sin(0.05 * t)  # 0.15 .. 0.75 m; the arm reaches 0.63 m
    return np.array(
        [
            0.05 + radius * abs(math.cos(0.7 * t)),
            -0.19 + radius * math.sin(1.3 * t) * 0.6,
            1.40 + radius * math.sin(0.7 * t) * 0.8,
        ]
    )


def rss_mib() -> float:
    """Peak resident set size of this process [MiB] (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run(steps: int, solver_name: str, heap: bool = False, **options) -> dict:
    chain = Chain()
    solver = make_solver(solver_name, **options)
    shoulder = np.array([0.0, -0.19, 1.40])
    reach = make_solver("two_link").shell(chain).r_max
    times = np.empty(steps)
    nan = violations = misses = reachable = 0
    worst_reachable = 0.0
    q = chain.q_home.copy()
    if heap:
        tracemalloc.start()
    heap_warm = rss_warm = math.nan
    for i in range(steps):
        target = target_at(i)
        t0 = time.perf_counter()
        res = solver.solve(chain, target, q0=q)
        times[i] = time.perf_counter() - t0
        q = res.q
        nan += not np.all(np.isfinite(q))
        violations += not chain.within_limits(q)
        if np.linalg.norm(target - shoulder) < reach - 0.05:
            reachable += 1
            misses += res.position_error >= 1e-3
            worst_reachable = max(worst_reachable, res.position_error)
        if i == min(1000, steps - 1):
            heap_warm = tracemalloc.get_traced_memory()[0] / 1024.0 if heap else math.nan
            rss_warm = rss_mib()
    heap_end = math.nan
    if heap:
        heap_end = tracemalloc.get_traced_memory()[0] / 1024.0
        tracemalloc.stop()
    return {
        "steps": steps,
        "solver": solver_name,
        "nan": nan,
        "limit_violations": violations,
        "reachable_steps": reachable,
        "reachable_misses_over_1mm": misses,
        "worst_reachable_error_m": worst_reachable,
        "median_ms": float(np.median(times) * 1e3),
        "p95_ms": float(np.percentile(times, 95) * 1e3),
        "heap_kib_after_1000": heap_warm,
        "heap_kib_end": heap_end,
        "rss_mib_after_1000": rss_warm,
        "rss_mib_end": rss_mib(),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=100_000)
    p.add_argument("--solver", default="dls")
    p.add_argument("--heap", action="store_true", help="trace the Python heap (slow)")
    args = p.parse_args(argv)
    r = run(args.steps, args.solver, args.heap)
    for k, v in r.items():
        print(f"{k:<26} {v:.6g}" if isinstance(v, float) else f"{k:<26} {v}")
    return 0 if r["nan"] == 0 and r["limit_violations"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
