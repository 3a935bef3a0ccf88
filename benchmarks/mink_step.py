"""Time one mink QP step: both hands (right pose, left position) + gaze + posture +
collision avoidance + joint range and velocity limits, on the bundled humanoid.

The targets move on smooth loops in front of the body (a tracking run at 100 Hz), so
each step solves a fresh QP from a warm configuration. Prints the median and p95 of
``UpperBodyIK.step`` (targets parsed, QP built and solved, step integrated and checked
against the collision pairs, errors measured) over ``--steps`` steps after a warm-up.

    python benchmarks/mink_step.py [--steps 5000] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time

import numpy as np

from humanoid_ik.core.rotations import axis_angle_matrix, mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.solvers.mink import UpperBodyIK


def targets_at(t: float) -> dict[str, object]:
    """Hand and gaze targets at time ``t`` [s]: loops of 0.10-0.15 m at 0.5 Hz, the gaze
    on a point 1.2 m ahead that follows the hands sideways."""
    w = 2.0 * math.pi * 0.5
    right = np.array([0.40 + 0.05 * math.sin(w * t), -0.25 + 0.15 * math.cos(w * t), 1.15])
    left = np.array([0.40 + 0.05 * math.cos(w * t), 0.25 + 0.10 * math.sin(w * t), 1.20])
    R = axis_angle_matrix((0.0, 1.0, 0.0), -math.pi / 2) @ axis_angle_matrix(
        (1.0, 0.0, 0.0), 0.3 * math.sin(w * t)
    )
    gaze = np.array([1.2, right[1] + left[1], 1.35 + 0.1 * math.sin(w * t)])
    return {
        "right_palm_site": Target(right, mat_to_quat(R)),
        "left_palm_site": left,
        "gaze_site": gaze,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="timed steps (default 5000)")
    parser.add_argument("--warmup", type=int, default=200, help="untimed steps first")
    parser.add_argument("--dt", type=float, default=0.01, help="step duration [s]")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = parser.parse_args()

    ik = UpperBodyIK()
    clock = time.perf_counter
    times = np.empty(args.steps)
    errors = np.empty((args.steps, 3))
    for i in range(args.warmup + args.steps):
        tg = targets_at(i * args.dt)
        t0 = clock()
        res = ik.step(tg, args.dt)
        t1 = clock()
        k = i - args.warmup
        if k >= 0:
            times[k] = t1 - t0
            errors[k] = [
                res["right_palm_site"].position_error,
                res["left_palm_site"].position_error,
                res["gaze_site"].orientation_error,
            ]
    figures = {
        "steps": args.steps,
        "dt_s": args.dt,
        "median_ms": float(np.median(times) * 1e3),
        "p95_ms": float(np.percentile(times, 95) * 1e3),
        "max_ms": float(times.max() * 1e3),
        "median_right_error_mm": float(np.median(errors[:, 0]) * 1e3),
        "median_left_error_mm": float(np.median(errors[:, 1]) * 1e3),
        "median_gaze_error_deg": float(np.degrees(np.median(errors[:, 2]))),
        "collision_pairs": len(ik.collision_limit.geom_id_pairs) if ik.collision_limit else 0,
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
    }
    for key, value in figures.items():
        print(f"{key:<24} {value:.4f}" if isinstance(value, float) else f"{key:<24} {value}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(figures, fh, indent=2)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
