"""Instructions per ``lm`` pose solve, counted by callgrind: a figure the machine's load
does not move. Solves ``N`` seeded pose targets (FK of random in-range joints) on the
bundled right arm from ``home``; run it twice, with ``N`` and with 0, and divide the
difference of the two totals by ``N``::

    valgrind --tool=callgrind --callgrind-out-file=cg.out python benchmarks/lm_instructions.py 300
    valgrind --tool=callgrind --callgrind-out-file=cg.out python benchmarks/lm_instructions.py 0

(``Collected`` on the last line is the total.)
"""

from __future__ import annotations

import sys

import mujoco
import numpy as np

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import Target
from humanoid_ik.solvers.registry import make_solver


def main(n: int) -> None:
    chain = Chain()
    solver = make_solver("lm")
    solver.prepare(chain)
    rng = np.random.default_rng(0)
    targets = []
    for _ in range(300):
        p, R = chain.fk(chain.random_q(rng))
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, R.ravel())
        targets.append(Target(p, quat))
    start = chain.q_home.copy()
    for k in range(n):
        solver.solve(chain, targets[k % len(targets)], start)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 300)
