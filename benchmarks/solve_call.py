"""What the one-call ``solve(chain, target, "auto", q0=...)`` costs against a solver
object made once and reused (``Auto().solve``), on the bundled arm.

Both run the same seeded targets (FK of random in-range joints), interleaved call by
call so the machine's load falls on both alike; prints the median CPU time
(``time.process_time``) and wall time per call [µs] and their ratio::

    python benchmarks/solve_call.py --targets 300 --rounds 3
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from humanoid_ik import Chain, Target, solve
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.solvers.registry import make_solver


def targets(chain: Chain, n: int, pose: bool, seed: int) -> list[Target]:
    """``n`` reachable targets: FK of seeded random in-range joint vectors."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        chain.set_q(chain.random_q(rng))
        quat = mat_to_quat(chain.rotation) if pose else None
        out.append(Target(chain.position.copy(), quat))
    return out


def measure(solver: str, pose: bool, n: int, rounds: int) -> dict[str, float]:
    """Median per-call CPU and wall times [µs] of ``solve(...)`` and of a reused object."""
    chain = Chain()
    q0 = chain.q_home
    reused = make_solver(solver)
    tgts = targets(chain, n, pose, seed=1)
    solve(chain, tgts[0], solver, q0=q0)  # warm-up: kernel, seed library, caches
    reused.solve(chain, tgts[0], q0)
    cpu: dict[str, list[float]] = {"call": [], "reused": []}
    wall: dict[str, list[float]] = {"call": [], "reused": []}
    for _ in range(rounds):
        for t in tgts:
            order = ("call", "reused") if len(cpu["call"]) % 2 == 0 else ("reused", "call")
            for kind in order:
                c0, w0 = time.process_time(), time.perf_counter()
                if kind == "call":
                    solve(chain, t, solver, q0=q0)
                else:
                    reused.solve(chain, t, q0)
                cpu[kind].append(time.process_time() - c0)
                wall[kind].append(time.perf_counter() - w0)
    med = {k: statistics.median(v) * 1e6 for k, v in cpu.items()}
    medw = {k: statistics.median(v) * 1e6 for k, v in wall.items()}
    return {
        "call_cpu": med["call"],
        "reused_cpu": med["reused"],
        "call_wall": medw["call"],
        "reused_wall": medw["reused"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--targets", type=int, default=300)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--solvers", default="auto,lm,closed_form")
    a = ap.parse_args()
    print(
        f"{'solver':<12}{'task':<9}{'solve() cpu':>12}{'reused cpu':>12}{'ratio':>7}"
        f"{'solve() wall':>14}{'reused wall':>13}   [µs per call, medians]"
    )
    for name in a.solvers.split(","):
        for pose in (False, True):
            r = measure(name, pose, a.targets, a.rounds)
            print(
                f"{name:<12}{'pose' if pose else 'position':<9}{r['call_cpu']:>12.1f}"
                f"{r['reused_cpu']:>12.1f}{r['call_cpu'] / r['reused_cpu']:>7.2f}"
                f"{r['call_wall']:>14.1f}{r['reused_wall']:>13.1f}"
            )


if __name__ == "__main__":
    main()
