"""Pose solves per second with ``solve_batch`` on real arms, on 1 and on 2 workers.

Arms from example-robot-data (the test extra): G1's left arm (7 hinges, ``auto`` picks
``lm``: its compiled loop, on 1 and 2 threads) and UR5 (6 hinges, ``subproblem``: its C
solve and the kernel's measure, on 1 and 2 threads); the bundled arm through
``closed_form``'s vectorised batch for comparison. Targets are FK poses of seeded
random in-range joints, every solve from the home pose. Each timed call follows an
untimed one on the first ``WARM`` targets with the same workers, which builds what the
robot state keeps for later calls (``lm``'s kernel per thread, a copy of the model:
about 30 ms each on G1; its seed library, about 60 ms); ``--cold`` times the first call
instead. Each arm's targets go in both forms ``solve_batch`` takes: :class:`Target`
objects, and positions ``(N, 3)`` with quaternions ``(N, 4)`` (which stay arrays on
``subproblem``'s path); the solved share is read from the batch's arrays, so no
:class:`IKResult` is made. Prints targets/s by wall time and the calling process's CPU
time (``time.process_time``: its threads' too)::

    python benchmarks/batch.py --targets 100000 [--cold]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from humanoid_ik import Chain, load_model, solve_batch  # noqa: E402
from humanoid_ik.solvers.analytic.closed_form import solve_batch as closed_form_batch  # noqa: E402
from tests.chains import fk_poses  # noqa: E402
from tests.robots import robot_file  # noqa: E402

WARM = 200
"""Targets of the untimed call before each timed one."""


def arms() -> dict[str, Chain]:
    g1 = Chain(load_model(robot_file("g1")), body="left_rubber_hand")
    ur5 = load_model(robot_file("ur5"))
    return {
        "g1 left arm": Chain(g1.robot, body="left_rubber_hand", joints=g1.joint_names[3:]),
        "ur5": Chain(ur5, body="tool0"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cold", action="store_true", help="time the first call (no warm-up)")
    args = ap.parse_args()
    print("| arm | solver | targets as | workers | solved | targets/s wall | CPU s (caller) |")
    print("|---|---|---|---|---|---|---|")
    for name, chain in arms().items():
        targets = fk_poses(chain, args.targets, args.seed)
        p = np.array([t.position for t in targets])
        qt = np.array([t.quat for t in targets])
        forms = {"objects": (targets, None), "arrays": (p, qt)}
        for form, (given, quats) in forms.items():
            for workers in (1, 2):
                if not args.cold:
                    solve_batch(
                        chain, given[:WARM], quats=None if quats is None else quats[:WARM],
                        q0=chain.q_home, workers=workers,
                    )  # fmt: skip
                t0, c0 = time.perf_counter(), time.process_time()
                res = solve_batch(chain, given, quats=quats, q0=chain.q_home, workers=workers)
                ok = res.converged.mean()  # the batch's arrays: no result object made
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                print(
                    f"| {name} | auto | {form} | {workers} | {ok:.1%} "
                    f"| {len(res) / wall:,.0f} | {cpu:.2f} |"
                )
    bundled = Chain()
    targets = fk_poses(bundled, args.targets, args.seed)
    p = np.array([t.position for t in targets])
    qt = np.array([t.quat for t in targets])
    t0, c0 = time.perf_counter(), time.process_time()
    _q, ok = closed_form_batch(bundled, p, qt, bundled.q_home)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(
        f"| bundled arm | closed_form (vectorised) | arrays | 1 | {ok.mean():.1%} "
        f"| {len(p) / wall:,.0f} | {cpu:.2f} |"
    )


if __name__ == "__main__":
    main()
