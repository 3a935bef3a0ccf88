"""Time the closed-form arm solver: one target at a time and vectorised batches.

Targets are FK of seeded random in-range joint vectors of the bundled humanoid's right
arm (pose targets unless ``--task position``), as in ``humanoid-ik bench``. Single: the
median of ``ClosedForm.solve`` (the solver's full call, MuJoCo FK check included) over
all targets, each from the home pose, after ``prepare`` (the chain's geometry is read
before the clock starts); the median over ``--repeats`` passes is printed. Batch:
``solve_batch`` on all targets at once (start: home), targets per second as the median
over ``--repeats`` calls. Both as wall time (``perf_counter``) and as this process's CPU
time (``process_time``; on a shared machine the two part when other work runs). Also
the fraction solved, the worst position and orientation errors (MuJoCo FK of the batch
result), and joint-range violations.

    .venv/bin/python benchmarks/closed_form.py [--n 1000] [--batch 20000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from humanoid_ik import Chain
from humanoid_ik.core.rotations import rotation_log
from humanoid_ik.experiments.bench import make_targets
from humanoid_ik.solvers.analytic.closed_form import ClosedForm, solve_batch


def single(chain: Chain, targets, repeats: int) -> dict:
    """Median wall and CPU time per ``solve`` [ms] (medians over passes), the fraction
    converged."""
    solver = ClosedForm()
    solver.prepare(chain)
    wall, cpu = time.perf_counter, time.process_time
    medians, p95s, cpu_medians = [], [], []
    converged = 0
    for _ in range(repeats):
        times = np.empty(len(targets))
        cpu_times = np.empty(len(targets))
        converged = 0
        for i, tgt in enumerate(targets):
            chain.reset()
            t0, c0 = wall(), cpu()
            res = solver.solve(chain, tgt)
            c1, t1 = cpu(), wall()
            times[i], cpu_times[i] = t1 - t0, c1 - c0
            converged += res.converged
        medians.append(float(np.median(times)) * 1e3)
        p95s.append(float(np.percentile(times, 95)) * 1e3)
        cpu_medians.append(float(np.median(cpu_times)) * 1e3)
    return {
        "median_ms": float(np.median(medians)),
        "p95_ms": float(np.median(p95s)),
        "cpu_median_ms": float(np.median(cpu_medians)),
        "converged": converged / len(targets),
    }


def batch(chain: Chain, targets, repeats: int) -> dict:
    """Targets per second of ``solve_batch`` in wall and CPU time (medians over calls)
    and the result's errors."""
    P = np.array([t.position for t in targets])
    Q = None if targets[0].quat is None else np.array([t.quat for t in targets])
    rates, cpu_rates = [], []
    for _ in range(repeats):
        chain.reset()
        t0, c0 = time.perf_counter(), time.process_time()
        q, ok = solve_batch(chain, P, Q)
        c1, t1 = time.process_time(), time.perf_counter()
        rates.append(len(targets) / (t1 - t0))
        cpu_rates.append(len(targets) / max(c1 - c0, 1e-9))
    checker = Chain(chain.model, chain.ee_name)
    worst_p = worst_r = 0.0
    violations = 0
    for i in range(len(targets)):
        p, R = checker.fk(q[i])
        worst_p = max(worst_p, float(np.linalg.norm(p - P[i])))
        if Q is not None:
            worst_r = max(worst_r, float(np.linalg.norm(rotation_log(targets[i].rotation @ R.T))))
        violations += not checker.within_limits(q[i])
    return {
        "targets_per_s": float(np.median(rates)),
        "cpu_targets_per_s": float(np.median(cpu_rates)),
        "ok": float(np.mean(ok)),
        "max_position_error_m": worst_p,
        "max_orientation_error_rad": worst_r if Q is not None else None,
        "limit_violations": violations,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="pose", choices=["pose", "position"])
    parser.add_argument("--n", type=int, default=1000, help="single targets (default 1000)")
    parser.add_argument("--batch", type=int, default=20000, help="batch size (default 20000)")
    parser.add_argument("--repeats", type=int, default=5, help="passes / calls (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="target seed (default 0)")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = parser.parse_args()

    chain = Chain()
    pose = args.task == "pose"
    one = single(chain, make_targets(chain, args.n, args.seed, pose), args.repeats)
    many = batch(chain, make_targets(chain, args.batch, args.seed + 1, pose), args.repeats)
    print(f"closed_form  task {args.task}  right arm  python {platform.python_version()}")
    print(
        f"{'mode':<8} {'targets':>8} {'median ms':>10} {'p95 ms':>8} {'targets/s':>11} "
        f"{'cpu ms':>8} {'cpu targets/s':>14} {'ok':>7}"
    )
    print(
        f"{'single':<8} {args.n:>8d} {one['median_ms']:>10.4f} {one['p95_ms']:>8.4f} "
        f"{1e3 / one['median_ms']:>11,.0f} {one['cpu_median_ms']:>8.4f} "
        f"{1e3 / one['cpu_median_ms']:>14,.0f} {100 * one['converged']:>6.1f}%"
    )
    print(
        f"{'batch':<8} {args.batch:>8d} {1e3 / many['targets_per_s']:>10.4f} {'':>8} "
        f"{many['targets_per_s']:>11,.0f} {1e3 / many['cpu_targets_per_s']:>8.4f} "
        f"{many['cpu_targets_per_s']:>14,.0f} {100 * many['ok']:>6.1f}%"
    )
    rot = many["max_orientation_error_rad"]
    print(
        f"batch: max position error {many['max_position_error_m']:.2e} m"
        + (f", max orientation error {rot:.2e} rad" if rot is not None else "")
        + f", {many['limit_violations']} range violations"
    )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"task": args.task, "single": one, "batch": many}, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
