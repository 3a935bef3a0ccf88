"""The seed library's ranking (``_lm_kernel.seed_nearest``, ``docs/lm.md``) on real arms
of example-robot-data: CPU time per ranking of the 8 poses nearest a pose target, each
ranking checked against a full numpy sort.

Per arm: ``--n`` pose targets, FK of seeded random in-range joint vectors, every third
moved by a normal offset of 0.3 m (targets off the library's poses); each ranked 200
times, median and p95 over the targets of the mean time per ranking.

    .venv/bin/python benchmarks/seed_ranking.py [--n 100] [--arms baxter,g1,panda,ur5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from peers import real_chain  # benchmarks/peers.py, beside this script

from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.solvers.jacobian import _lm_kernel
from humanoid_ik.solvers.jacobian.seeds import ROTATION_LENGTH, seed_library

ARMS = {"baxter": "left_arm", "g1": "left_arm", "panda": "arm", "ur5": "arm"}
"""``tests/robots.py`` name -> the limb."""
REPEATS = 200


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--arms", default=",".join(ARMS))
    args = ap.parse_args()
    for robot in args.arms.split(","):
        chain = real_chain(robot, ARMS[robot])
        lib = seed_library(chain)
        rotations = lib.rotations.reshape(-1, 9)
        rng = np.random.default_rng(0)
        times, wrong = [], 0
        for i in range(args.n):
            p, R = chain.fk(chain.random_q(rng))
            if i % 3 == 0:
                p = p + rng.normal(size=3) * 0.3
            target = Target(p, mat_to_quat(R))
            cost = np.linalg.norm(lib.positions - target.position, axis=1)
            cost += ROTATION_LENGTH * (1.0 - (rotations @ R.reshape(9) - 1.0) / 2.0)
            index = np.empty(8, dtype=np.int64)
            rot = target.rotation.reshape(9)
            call = (*lib.packed[:4], target.position, rot, ROTATION_LENGTH, index)
            t0 = time.process_time()
            for _ in range(REPEATS):
                _lm_kernel.seed_nearest(*call)
            times.append((time.process_time() - t0) / REPEATS)
            wrong += not np.array_equal(index, np.argsort(cost, kind="stable")[:8])
        us = np.array(times) * 1e6
        side, dims = lib.grid[3], lib.grid[4:].astype(int).tolist()
        print(
            f"{robot:7s} {len(lib.q)} poses, cells {dims} of {side:.3f} m: CPU median "
            f"{np.median(us):.2f} us, p95 {np.percentile(us, 95):.2f} us; "
            f"{wrong} of {args.n} rankings unlike a full sort"
        )


if __name__ == "__main__":
    main()
