"""What ``auto`` runs on the arms of real robots, and how well: its choice, success and
time per solve on reachable targets, next to ``lm`` alone; then the near-miss question.

Arms: every arm limb (``core.limbs.find_limbs``, ``limb_chain``) of the robots of
``tests/robots.py`` (example-robot-data) and of the two H1-like upper bodies of
``tests/models`` (``h1_arms.xml``: shoulder axes that nearly meet, as on Unitree H1;
``h1_arms_spherical.xml``: the same arm with axes that meet). Targets: FK of ``--n``
seeded random in-range joint vectors (reachable by construction), position and pose;
every solve starts from the home pose, after ``prepare``. Per arm and task: the solver
``auto`` runs first and why, its success, CPU time (``time.process_time``) and wall time
per solve (mean and median), and ``lm``'s on the same targets.

Near miss: where the shoulder (and wrist) axes nearly meet, the exact solver of the
*nearest arm whose axes meet* (the same model with those hinges' anchors moved onto the
point nearest to their axes; ``two_link`` for a 4-joint arm, ``closed_form`` for a
7-joint one) gives a start that ``lm`` polishes on the real arm. Measured against
``lm`` alone from home on the same targets: success and CPU time per solve.

    .venv/bin/python benchmarks/real_arms.py [--n 300] [--robots romeo,icub,h1] [--json]
"""

from __future__ import annotations

import argparse
import copy
import json
import platform
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from humanoid_ik import make_solver  # noqa: E402
from humanoid_ik.core.chain import Chain  # noqa: E402
from humanoid_ik.core.limbs import Profile, find_limbs, limb_chain  # noqa: E402
from humanoid_ik.core.models import load_model  # noqa: E402
from humanoid_ik.core.robot import Robot  # noqa: E402
from humanoid_ik.core.rotations import axes_meeting_point  # noqa: E402
from humanoid_ik.experiments.bench import make_targets  # noqa: E402
from humanoid_ik.solvers.auto import Auto  # noqa: E402
from tests.robots import ROBOTS, robot_file  # noqa: E402

H1 = {
    "h1": ROOT / "tests" / "models" / "h1_arms.xml",
    "h1_spherical": ROOT / "tests" / "models" / "h1_arms_spherical.xml",
}
"""The H1-like upper bodies: shoulder axes 16.5 mm apart, and meeting."""
NEAR = {"h1": (slice(0, 3),), "g1": (slice(0, 3), slice(4, 7))}
"""Arms whose axes nearly meet, and the hinge groups the nearest exact arm makes meet."""


def load(name: str) -> tuple[Robot, Profile]:
    path = H1[name] if name in H1 else robot_file(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a home pose outside the ranges, said by load_model
        model = load_model(str(path))
    return Robot(model), find_limbs(model)


def arms(profile: Profile) -> list[str]:
    return [n for n, lb in profile.limbs.items() if n.endswith("arm") and lb.frame and lb.joints]


def timed(solve, targets) -> dict[str, Any]:
    """Run ``solve(target) -> IKResult`` on each target; success and times per solve [us]
    (after a warm-up on the first five, untimed)."""
    for tgt in targets[:5]:
        solve(tgt)
    cpu, wall, ok, used = [], [], 0, {}
    for tgt in targets:
        c0, w0 = time.process_time(), time.perf_counter()
        res = solve(tgt)
        w1, c1 = time.perf_counter(), time.process_time()
        cpu.append(c1 - c0)
        wall.append(w1 - w0)
        ok += res.converged
        used[res.solver] = used.get(res.solver, 0) + 1
    cpu_us, wall_us = np.array(cpu) * 1e6, np.array(wall) * 1e6
    return {
        "ok": ok,
        "n": len(targets),
        "cpu_mean_us": float(cpu_us.mean()),
        "cpu_median_us": float(np.median(cpu_us)),
        "wall_mean_us": float(wall_us.mean()),
        "wall_median_us": float(np.median(wall_us)),
        "answered_by": used,
    }


def from_home(chain: Chain, solver):
    solver.prepare(chain)

    def solve(tgt):
        chain.reset()
        return solver.solve(chain, tgt)

    return solve


def nearest_exact(robot: Robot, chain: Chain, limb: str, profile: Profile, groups) -> Chain:
    """The limb on a copy of the model whose hinge groups' anchors are moved onto the
    point nearest to their axes (at the chain's zero pose): the nearest arm whose axes
    meet. Same links, same frames at zero; at other poses off by about the miss."""
    model = copy.deepcopy(robot.model)
    keep = chain.q
    chain.set_q(np.zeros(chain.n))
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    for g in groups:
        S = axes_meeting_point(anchors[g], axes[g], tol=np.inf)
        for j in np.asarray(chain.joint_ids)[g]:
            b = model.jnt_bodyid[j]
            model.jnt_pos[j] = chain.data.xmat[b].reshape(3, 3).T @ (S - chain.data.xpos[b])
    chain.set_q(keep)
    return limb_chain(Robot(model), limb, profile=profile)


def near_miss(robot: Robot, profile: Profile, name: str, n: int, seed: int) -> list[dict]:
    """lm alone vs the nearest exact arm's answer polished by lm, per task, on one arm."""
    limb = arms(profile)[0]
    chain = limb_chain(robot, limb, profile=profile)
    twin = nearest_exact(robot, chain, limb, profile, NEAR[name])
    lm = make_solver("lm")
    lm.prepare(chain)
    out = []
    for pose in (False, True):
        exact = make_solver("closed_form" if chain.n == 7 else "two_link")
        if exact.applicable(twin, pose) is not None:
            continue
        exact.prepare(twin)
        targets = make_targets(chain, n, seed, pose)
        home = chain.q_home

        def polished(tgt, exact=exact, home=home):
            start = exact.solve(twin, tgt, home)
            return lm.solve(chain, tgt, start.q)

        miss = [
            float(np.linalg.norm(chain.fk(exact.solve(twin, t, home).q)[0] - t.position))
            for t in targets
        ]
        for label, solve in (
            ("lm alone", from_home(chain, lm)),
            (f"{exact.name} (nearest exact arm) + lm", polished),
        ):
            row = {"robot": name, "arm": limb, "task": "pose" if pose else "position"}
            row |= {"variant": label, **timed(solve, targets)}
            row["start_error_mm"] = float(np.median(miss)) * 1e3 if "+" in label else None
            out.append(row)
    return out


def choices(robot: Robot, profile: Profile, name: str, n: int, seed: int) -> list[dict]:
    """auto's choice, reason, success and times per arm and task, and lm's."""
    out = []
    auto = Auto()
    for limb in arms(profile):
        chain = limb_chain(robot, limb, profile=profile)
        for pose in (False, True):
            targets = make_targets(chain, n, seed, pose)
            row = {"robot": name, "arm": limb, "task": "pose" if pose else "position"}
            row["chosen"] = auto.choice(chain, pose).name
            row["why"] = auto.reason(chain, pose)
            row["auto"] = timed(from_home(chain, auto), targets)
            row["lm"] = timed(from_home(chain, make_solver("lm")), targets)
            out.append(row)
            print(
                f"{name:12s} {limb:9s} {row['task']:8s} {row['chosen']:11s} "
                f"{row['auto']['ok']}/{n} {row['auto']['cpu_mean_us']:.0f} us "
                f"(lm {row['lm']['ok']}/{n} {row['lm']['cpu_mean_us']:.0f} us)",
                file=sys.stderr,
                flush=True,
            )
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=300, help="targets per arm and task")
    p.add_argument("--seed", type=int, default=0)
    every = [*ROBOTS.keys(), *H1.keys()]
    p.add_argument("--robots", default=",".join(every), help=f"of {', '.join(every)}")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = p.parse_args()
    names = [r for r in args.robots.split(",") if r]
    unknown = [r for r in names if r not in every]
    if unknown:
        p.error(f"unknown robot {unknown[0]!r}; robots: {', '.join(every)}")
    rows, near = [], []
    for name in names:
        robot, profile = load(name)
        rows += choices(robot, profile, name, args.n, args.seed)
        if name in NEAR:
            near += near_miss(robot, profile, name, args.n, args.seed)
    if args.json:
        print(json.dumps({"arms": rows, "near_miss": near, "python": platform.python_version()}))
        return
    print(f"{args.n} reachable targets per arm and task (seed {args.seed}), from home")
    print()
    print(
        "| robot | arm | task | auto runs | why | auto ok | auto CPU mean / median [us] "
        "| auto wall median [us] | lm ok | lm CPU mean / median [us] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        a, m = r["auto"], r["lm"]
        print(
            f"| {r['robot']} | {r['arm']} | {r['task']} | `{r['chosen']}` | {r['why']} "
            f"| {a['ok']}/{a['n']} | {a['cpu_mean_us']:.0f} / {a['cpu_median_us']:.0f} "
            f"| {a['wall_median_us']:.0f} | {m['ok']}/{m['n']} "
            f"| {m['cpu_mean_us']:.0f} / {m['cpu_median_us']:.0f} |"
        )
    if near:
        print()
        print(
            "| robot | arm | task | variant | ok | CPU mean / median [us] | wall median [us] "
            "| start's error (median) [mm] |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for r in near:
            err = "" if r["start_error_mm"] is None else f"{r['start_error_mm']:.1f}"
            print(
                f"| {r['robot']} | {r['arm']} | {r['task']} | {r['variant']} "
                f"| {r['ok']}/{r['n']} | {r['cpu_mean_us']:.0f} / {r['cpu_median_us']:.0f} "
                f"| {r['wall_median_us']:.0f} | {err} |"
            )


if __name__ == "__main__":
    main()
