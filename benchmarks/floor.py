"""The floor of an iteration: one FK + site Jacobian from MuJoCo, against the cost of one
iteration of ``lm`` and ``dls``, per model (process CPU time, microseconds).

- ``floor``: from Python, write the chain's joints into ``qpos``, then ``mj_kinematics``,
  ``mj_comPos`` and ``mj_jacSite`` (``mj_jacBody``): what any solver built on MuJoCo
  pays per iteration; ``C calls`` the three MuJoCo calls alone.
- ``numpy columns``: the same Jacobian from the chain's hinges,
  ``J_pos = axis x (p - anchor)``, ``J_rot = axis`` (``xaxis``, ``xanchor``), vectorised
  in numpy after ``mj_kinematics``, the alternative to ``mj_comPos`` + ``mj_jacSite``.
- ``lm`` and ``dls``: the best of three slopes of a solve's CPU time over its iteration
  count (solves of K and of 0 iterations from the same starts, tolerances 0 so none
  stops early), for position (3 rows) and pose (6 rows) targets, and the ratio to
  ``floor``; ``lm``'s loop is its compiled kernel (``solvers/jacobian/_lm_kernel.c``),
  ``dls``'s is Python.

    .venv/bin/python benchmarks/floor.py [--k 200] [--n 20]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable

import mujoco
import numpy as np
from solvers import MODELS as ARMS  # benchmarks/solvers.py, beside this script

from humanoid_ik import Chain, make_solver
from humanoid_ik.experiments.bench import make_targets

MODELS = dict(list(ARMS.items())[:4])  # the 7- and 8-hinge arms and a 5-hinge one


def cpu_us(f: Callable[[], object], n: int = 20_000) -> float:
    """CPU time of one call of ``f`` [us], the best of three runs of ``n`` calls."""
    best = float("inf")
    for _ in range(3):
        t0 = time.process_time()
        for _ in range(n):
            f()
        best = min(best, (time.process_time() - t0) / n * 1e6)
    return best


def floor_calls(c: Chain) -> tuple[Callable[[], None], Callable[[], None], Callable[[], None]]:
    """The floor from Python, the three C calls alone, and the numpy-columns Jacobian."""
    m, d, q, adr = c.model, c.data, c.q_home.copy(), c.qpos_adr
    jacp, jacr, eid = np.zeros((3, m.nv)), np.zeros((3, m.nv)), c.ee_id
    jac = mujoco.mj_jacSite if c.ee_kind == "site" else mujoco.mj_jacBody
    kin, com = mujoco.mj_kinematics, mujoco.mj_comPos
    ids, J = c.joint_ids, np.empty((6, c.n))

    def floor() -> None:
        d.qpos[adr] = q
        kin(m, d)
        com(m, d)
        jac(m, d, jacp, jacr, eid)

    def c_only() -> None:
        kin(m, d)
        com(m, d)
        jac(m, d, jacp, jacr, eid)

    def columns() -> None:
        d.qpos[adr] = q
        kin(m, d)
        axes, anchors = d.xaxis[ids], d.xanchor[ids]
        J[:3] = np.cross(axes, c.position - anchors).T
        J[3:] = axes.T

    return floor, c_only, columns


def per_iteration(c: Chain, name: str, pose: bool, k: int, n: int) -> float:
    """CPU time of one iteration of solver ``name`` [us] (the slope over ``k``)."""
    targets = make_targets(c, n, 1, pose)
    starts = [c.random_q(np.random.default_rng(i)) for i in range(n)]
    solvers = []
    for iters in (0, k):
        s = make_solver(
            name, tol=0.0, rot_tol=0.0, restarts=0, max_iterations=iters, stall_window=k + 1
        )
        s.solve(c, targets[0], starts[0])  # buffers built before the clock starts
        solvers.append(s)
    slopes = []
    for _ in range(3):  # the best of three slopes, as cpu_us takes the best of three
        spent = []
        for s in solvers:
            t0 = time.process_time()
            for tgt, q0 in zip(targets, starts, strict=True):
                s.solve(c, tgt, q0)
            spent.append(time.process_time() - t0)
        slopes.append((spent[1] - spent[0]) / (n * k) * 1e6)
    return min(slopes)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--k", type=int, default=200, help="iterations per timed solve")
    p.add_argument("--n", type=int, default=20, help="solves per measurement")
    args = p.parse_args(argv)
    print("CPU time per call or iteration [us]; (ratio) = per iteration / floor")
    print()
    print(
        "| model | floor | C calls | numpy columns | lm position | lm pose "
        "| dls position | dls pose |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, spec in MODELS.items():
        c = Chain(**spec)
        floor, c_only, columns = floor_calls(c)
        f, co, cols = cpu_us(floor), cpu_us(c_only), cpu_us(columns)
        cells = [
            per_iteration(c, name, pose, args.k, args.n)
            for name in ("lm", "dls")
            for pose in (False, True)
        ]
        lm_cells = " | ".join(f"{t:.2f} ({t / f:.1f}x)" for t in cells[:2])
        print(
            f"| {label} | {f:.2f} | {co:.2f} | {cols:.2f} | {lm_cells} "
            f"| {cells[2]:.2f} | {cells[3]:.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
