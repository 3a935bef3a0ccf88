"""The cost of the ``mink`` solver against mink's own ``solve_ik``, and of one tracking step.

Two measurements, both in CPU time (``time.process_time``) next to wall time:

1. **Per iteration, against a plain mink loop** (``--n`` targets per arm and task). The
   ``mink`` solver (``MinkSolver``: a task on the end effector, a posture task toward
   ``home``, joint range and velocity limits, the joints outside the chain frozen) and a
   plain loop written with mink's public API alone, with the same tasks and limits
   (``FrameTask``, ``PostureTask``, ``ConfigurationLimit``, ``VelocityLimit``,
   ``DofFreezingTask``; ``solve_ik`` with daqp, ``integrate_inplace``, the task error
   checked against the same tolerances after each step), solve the same FK targets from
   the same start, in one run. Each side's cost per iteration is its CPU time over its
   QP steps; the ratio ours / plain is the figure. Success counts answers within 1 mm
   (0.01 rad) inside the ranges, measured by MuJoCo FK.
2. **One tracking step** of ``UpperBodyIK``: both hands (right pose, left position),
   the gaze, posture, the bundled humanoid's collision pairs, range and velocity
   limits, on smooth loops at 100 Hz (``--steps`` steps after a warm-up).

    .venv/bin/python benchmarks/mink_step.py [--n 200] [--steps 5000] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from collections.abc import Callable
from typing import Any

import mink
import numpy as np
from solvers import ROBOT_ARM  # benchmarks/solvers.py, beside this script

from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import on_target
from humanoid_ik.core.models import bundled_dir, load_model
from humanoid_ik.core.rotations import axis_angle_matrix, mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.bench import make_targets
from humanoid_ik.solvers.mink import MinkSolver, UpperBodyIK

ARMS: dict[str, Callable[[], Chain]] = {
    "humanoid": lambda: Chain(),
    "robot": lambda: Chain(
        bundled_dir("models") / "robot" / "robot.xml", "right_hand_site", ROBOT_ARM
    ),
}


class PlainMinkLoop:
    """IK with mink's public API only: the loop a mink user writes, with the tasks and
    limits of ``MinkSolver`` on one chain (one start, no restart).

    ``mink.ConfigurationLimit`` bounds every limited joint of the model, so where a joint
    off the chain starts outside its range the QP is infeasible: the loop then stops
    where it is (``NoSolutionFound``), as a user's loop would."""

    def __init__(self, chain: Chain, opts: Any, pose: bool):
        m = chain.model
        self.chain, self.opts, self.pose = chain, opts, pose
        self.cfg = mink.Configuration(m)
        self.task = mink.FrameTask(
            chain.ee_name,
            chain.ee_kind,
            position_cost=1.0,
            orientation_cost=opts.orientation_cost if pose else 0.0,
        )
        self.posture = mink.PostureTask(m, cost=opts.posture_cost, gain=opts.posture_gain)
        self.start = chain.data.qpos.copy()
        self.posture.set_target(self.start)
        frozen = np.setdiff1d(np.arange(m.nv), chain.dof_adr)
        self.limits = [
            mink.ConfigurationLimit(m, gain=0.95),
            mink.VelocityLimit(m, dict.fromkeys(chain.joint_names, opts.max_velocity)),
        ]
        self.constraints = [mink.DofFreezingTask(m, frozen.tolist())] if frozen.size else None
        self.dt = opts.max_step / opts.max_velocity

    def solve(self, target: Target) -> tuple[np.ndarray, int]:
        """Joint values ``(n,)`` reached and QP steps taken."""
        o, cfg = self.opts, self.cfg
        cfg.update(self.start.copy())
        quat = target.quat if self.pose else np.array([1.0, 0.0, 0.0, 0.0])
        self.task.set_target(mink.SE3(np.concatenate([quat, target.position])))
        tasks = [self.task, self.posture]
        it = 0
        while it < o.max_iterations:
            e = self.task.compute_error(cfg)
            if np.linalg.norm(e[:3]) < o.tol and (
                not self.pose or np.linalg.norm(e[3:]) < o.rot_tol
            ):
                break
            try:
                v = mink.solve_ik(
                    cfg,
                    tasks,
                    self.dt,
                    "daqp",
                    damping=o.damping,
                    limits=self.limits,
                    constraints=self.constraints,
                )
            except mink.NoSolutionFound:  # e.g. a frozen joint outside its range
                break
            cfg.integrate_inplace(v, self.dt)
            it += 1
        return cfg.data.qpos[self.chain.qpos_adr].copy(), it


def _success(chain: Chain, q: np.ndarray, target: Target) -> bool:
    p, R = chain.fk(q)
    ep = float(np.linalg.norm(p - target.position))
    er = None
    if target.quat is not None:
        from humanoid_ik.core.measures import orientation_error

        er = orientation_error(R, target.quat)
    return chain.within_limits(q) and on_target(ep, er)


def per_iteration(arm: str, task: str, n: int, seed: int) -> dict[str, Any]:
    """Both sides on the same targets, from the chain's home pose: CPU and wall time per
    QP step, success, and the ratio ours / plain."""
    chain = ARMS[arm]()
    pose = task == "pose"
    targets = make_targets(chain, n, seed, pose)
    ours = MinkSolver()
    ours.prepare(chain)
    plain = PlainMinkLoop(chain, ours.options, pose)
    out: dict[str, Any] = {"arm": arm, "task": task, "n": n}
    for side in ("ours", "plain"):
        cpu = wall = 0.0
        steps = ok = 0
        for tgt in targets:
            chain.reset()
            w0, c0 = time.perf_counter(), time.process_time()
            if side == "ours":
                res = ours.solve(chain, tgt)
                q, it = res.q, res.iterations
            else:
                q, it = plain.solve(tgt)
            cpu += time.process_time() - c0
            wall += time.perf_counter() - w0
            steps += it
            ok += _success(chain, q, tgt)
        out[side] = {
            "success": ok / n,
            "iterations": steps,
            "cpu_us_per_iteration": 1e6 * cpu / max(steps, 1),
            "wall_us_per_iteration": 1e6 * wall / max(steps, 1),
            "cpu_ms_per_solve": 1e3 * cpu / n,
        }
    chain.reset()
    for clock in ("cpu", "wall"):
        key = f"{clock}_us_per_iteration"
        out[f"ratio_{clock}"] = out["ours"][key] / out["plain"][key]
    return out


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


def tracking(steps: int, warmup: int, dt: float) -> dict[str, Any]:
    """``UpperBodyIK.step`` on the moving targets: median and p95 per step, the errors."""
    pairs = load_scene("upper_body_mink").solver.options["collision_pairs"]  # the humanoid's
    ik = UpperBodyIK(
        load_model(None),
        hands=("right_palm_site", "left_palm_site"),
        gaze="gaze_site",
        collision_pairs=pairs,
    )
    times = np.empty(steps)
    cpu = 0.0
    errors = np.empty((steps, 3))
    for i in range(warmup + steps):
        tg = targets_at(i * dt)
        t0, c0 = time.perf_counter(), time.process_time()
        res = ik.step(tg, dt)
        t1, c1 = time.perf_counter(), time.process_time()
        k = i - warmup
        if k >= 0:
            times[k] = t1 - t0
            cpu += c1 - c0
            errors[k] = [
                res["right_palm_site"].position_error,
                res["left_palm_site"].position_error,
                res["gaze_site"].orientation_error,
            ]
    return {
        "steps": steps,
        "dt_s": dt,
        "median_ms": float(np.median(times) * 1e3),
        "p95_ms": float(np.percentile(times, 95) * 1e3),
        "cpu_mean_ms": 1e3 * cpu / steps,
        "median_right_error_mm": float(np.median(errors[:, 0]) * 1e3),
        "median_left_error_mm": float(np.median(errors[:, 1]) * 1e3),
        "median_gaze_error_deg": float(np.degrees(np.median(errors[:, 2]))),
        "collision_pairs": len(ik.collision_limit.geom_id_pairs) if ik.collision_limit else 0,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200, help="targets per arm and task (200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the targets")
    parser.add_argument("--arms", default="humanoid,robot", help="comma-separated: humanoid,robot")
    parser.add_argument("--steps", type=int, default=5000, help="timed tracking steps (5000)")
    parser.add_argument("--warmup", type=int, default=200, help="untimed tracking steps first")
    parser.add_argument("--dt", type=float, default=0.01, help="tracking step duration [s]")
    parser.add_argument("--json", metavar="PATH", help="also write the figures as JSON")
    args = parser.parse_args()
    arms = args.arms.split(",")
    for arm in arms:
        if arm not in ARMS:
            parser.error(f"arm '{arm}' unknown; arms: {', '.join(ARMS)}")

    rows = [per_iteration(a, t, args.n, args.seed) for a in arms for t in ("position", "pose")]
    print(f"per QP iteration, mink solver vs a plain mink.solve_ik loop, n = {args.n}")
    print()
    print(
        "| arm | task | ours: success, CPU us/it, wall us/it, iterations | "
        "plain: success, CPU us/it, wall us/it, iterations | ours / plain CPU | wall |"
    )
    print("|---|---|---|---|---|---|")
    for r in rows:
        cells = [
            f"{100 * s['success']:.1f} %, {s['cpu_us_per_iteration']:.1f}, "
            f"{s['wall_us_per_iteration']:.1f}, {s['iterations']}"
            for s in (r["ours"], r["plain"])
        ]
        print(
            f"| {r['arm']} | {r['task']} | {cells[0]} | {cells[1]} | "
            f"{r['ratio_cpu']:.2f} | {r['ratio_wall']:.2f} |"
        )
    print()
    track = tracking(args.steps, args.warmup, args.dt) if args.steps > 0 else None
    if track is not None:
        print("one UpperBodyIK tracking step (both hands + gaze + posture + collisions + limits)")
        for key, value in track.items():
            print(
                f"  {key:<24} {value:.4f}" if isinstance(value, float) else f"  {key:<24} {value}"
            )
    doc = {
        "per_iteration": rows,
        "tracking": track,
        "machine": f"{platform.processor() or platform.machine()}, {platform.python_version()}",
    }
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(doc, fh, indent=2)
            fh.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
