"""The damping rule of ``lm``, chosen by measurement: a grid of ``error_damping``,
``min_damping`` and ``orientation_weight`` on pose targets of three arms.

``lambda = error_damping * E + min_damping`` with ``E = e' W e / 2``: Chan and
Lawrence's error-damped rule is ``min_damping = 0`` (here its floor, 1e-12), Sugihara's
adds a small constant. Each cell is the bench's measurement (seeded FK targets from
``home``, success = 1 mm / 0.01 rad inside the ranges) with the process CPU time per
solve; the last lines name the fastest cell at full success on every arm.

    .venv/bin/python benchmarks/lm_damping.py --n 200
"""

from __future__ import annotations

import argparse
import itertools
import sys

import numpy as np
from solvers import MODELS  # benchmarks/solvers.py, beside this script

from humanoid_ik import Chain, make_solver
from humanoid_ik.experiments.bench import make_targets, run_trials

ARMS = dict(list(MODELS.items())[:3])  # the bundled arm and the two models/robot chains
GRID = {
    "error_damping": (0.01, 0.1, 1.0, 10.0),
    "min_damping": (1e-12, 1e-6, 1e-4, 1e-2),
    "orientation_weight": (0.1, 0.2, 0.5),
}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=200)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    chains = {name: Chain(**spec) for name, spec in ARMS.items()}
    targets = {name: make_targets(c, args.n, args.seed, True) for name, c in chains.items()}
    print(f"pose targets, n = {args.n} per arm, seed {args.seed}; CPU median [ms] per solve")
    print()
    print("| error_damping | min_damping | orientation_weight | " + " | ".join(ARMS) + " |")
    print("|---|---|---|" + "---|" * len(ARMS))
    best: tuple[float, str] | None = None
    for values in itertools.product(*GRID.values()):
        options = dict(zip(GRID, values, strict=True))
        cells, worst, total = [], 1.0, 0.0
        for name, chain in chains.items():
            tr = run_trials(chain, make_solver("lm", **options), targets[name])
            rate = float(tr.success.mean())
            cpu = float(np.median(tr.cpu_times) * 1e3)
            worst, total = min(worst, rate), total + cpu
            cells.append(f"{100 * rate:.1f} %, {cpu:.3f} ms, {tr.iterations.mean():.1f} it")
        print(f"| {values[0]:g} | {values[1]:g} | {values[2]:g} | " + " | ".join(cells) + " |")
        if worst == 1.0 and (best is None or total < best[0]):
            best = (total, ", ".join(f"{k} = {v:g}" for k, v in options.items()))
    print()
    print("fastest at full success on every arm:", best[1] if best else "none")
    return 0


if __name__ == "__main__":
    sys.exit(main())
