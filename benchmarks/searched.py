"""``subproblem``'s search on 7-hinge arms against ``lm``, on real arms of
example-robot-data (``docs/subproblem.md``, "Seven hinges").

Per arm: ``--n`` pose targets at FK of seeded random in-range joint vectors, each solved
from the arm's home pose by ``subproblem`` (its first or last joint searched) and by
``lm``, the two interleaved target by target in one process (a noisy neighbour slows
both alike); CPU time per solve (``time.process_time``), median and p95, the ratio of
the medians, the successes, and how many values of the held joint the search tried.

    .venv/bin/python benchmarks/searched.py [--n 300] [--arms panda,talos,romeo,icub,pr2,tiago_dual]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from peers import real_chain  # benchmarks/peers.py, beside this script

from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.solvers.registry import make_solver

ARMS = {
    "panda": "arm",
    "talos": "left_arm",
    "romeo": "left_arm",
    "icub": "left_arm",
    "pr2": "left_arm",
    "tiago_dual": "left_arm",
}
"""``tests/robots.py`` name -> the limb solved."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--arms", default=",".join(ARMS))
    args = ap.parse_args()
    for robot in args.arms.split(","):
        chain = real_chain(robot, ARMS[robot])
        rng = np.random.default_rng(0)
        home = chain.q.copy()
        targets = []
        for _ in range(args.n):
            p, R = chain.fk(chain.random_q(rng))
            targets.append(Target(p.copy(), mat_to_quat(R)))
        solvers = {"subproblem": make_solver("subproblem"), "lm": make_solver("lm")}
        for s in solvers.values():
            s.prepare(chain)
        cpu: dict[str, list[float]] = {k: [] for k in solvers}
        ok = dict.fromkeys(solvers, 0)
        tried = []
        for target in targets:
            for name, solver in solvers.items():
                t0 = time.process_time()
                res = solver.solve(chain, target, home)
                cpu[name].append(time.process_time() - t0)
                ok[name] += res.converged
                if name == "subproblem":
                    tried.append(res.details["tried"])
        med = {k: float(np.median(v)) * 1e6 for k, v in cpu.items()}
        p95 = {k: float(np.percentile(v, 95)) * 1e6 for k, v in cpu.items()}
        print(
            f"{robot:6s} subproblem {ok['subproblem']}/{args.n} median {med['subproblem']:.1f} us "
            f"p95 {p95['subproblem']:.1f} | lm {ok['lm']}/{args.n} median {med['lm']:.1f} us "
            f"p95 {p95['lm']:.1f} | ratio {med['subproblem'] / med['lm']:.2f} | values tried "
            f"median {np.median(tried):.0f}, max {max(tried)}"
        )


if __name__ == "__main__":
    main()
