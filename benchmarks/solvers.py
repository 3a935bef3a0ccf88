"""Every solver on the bundled right arm (and, with ``--models all``, the ``models/robot``
arm and the fixture arms of ``tests/models/``), position and pose targets, as a
Markdown table.

The same measurement as ``humanoid-ik bench`` (seeded FK targets, every solve from the
``home`` keyframe, success = error below 1 mm / 0.01 rad inside the joint ranges), run
for both tasks: wall and process CPU median per solve (with ``--repeat`` K, the median
of K runs' medians and their range), CPU p95, and each solver's CPU median as a ratio
to ``dls`` on the same model and task.

    .venv/bin/python benchmarks/solvers.py --n 1000 [--models all] [--repeat 3]
        [--solvers auto,lm,dls,closed_form] [--json benchmarks/solvers.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

from humanoid_ik import Chain
from humanoid_ik.experiments.bench import BenchReport, run_bench

ROBOT_ARM = "r_sh_pitch,r_sh_roll,r_sh_yaw,r_elbow,r_wr_roll,r_wr_pitch,r_wr_yaw".split(",")
MODELS = {
    "bundled right arm (7)": {},
    "models/robot arm (7)": {
        "model": "models/robot/robot.xml",
        "site": "right_hand_site",
        "joints": ROBOT_ARM,
    },
    "models/robot waist + arm (8)": {"model": "models/robot/robot.xml", "site": "right_hand_site"},
    "tests/models/three_hinge_arm (5)": {
        "model": "tests/models/three_hinge_arm.xml",
        "site": "hand_site",
    },
    "tests/models/two_hinge_arm (4)": {
        "model": "tests/models/two_hinge_arm.xml",
        "site": "hand_site",
    },
    "tests/models/planar_arm (3)": {"model": "tests/models/planar_arm.xml", "site": "hand_site"},
}


def rows(label: str, rep: BenchReport) -> list[str]:
    """The Markdown rows of one report (skipped solvers left out)."""
    base = next((r.cpu_median_ms for r in rep.results if r.solver == "dls"), None)
    out = []
    for r in rep.results:
        if r.skipped or r.cpu_median_ms is None or r.median_ms is None:
            continue
        ratio = f"{r.cpu_median_ms / base:.2f}" if base else "-"
        spread = ""
        if rep.repeat > 1 and r.cpu_median_ms_range is not None:
            spread = f" ({r.cpu_median_ms_range[0]:.3f}-{r.cpu_median_ms_range[1]:.3f})"
        chosen = ""
        if r.chosen and set(r.chosen) != {r.solver}:
            chosen = " (" + ", ".join(f"{k} {v}" for k, v in r.chosen.items()) + ")"
        out.append(
            f"| {label} | `{r.solver}`{chosen} | {rep.task} | {100 * (r.success_rate or 0):.1f} % "
            f"| {r.median_ms:.3f} | {r.cpu_median_ms:.3f}{spread} | {r.cpu_p95_ms:.3f} "
            f"| {ratio} | {r.mean_iterations:.1f} |"
        )
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--solvers", help="comma-separated (default: all)")
    p.add_argument("--models", choices=("bundled", "all"), default="bundled")
    p.add_argument("--json", help="also write the reports as JSON")
    args = p.parse_args(argv)
    names = args.solvers.split(",") if args.solvers else None
    models = MODELS if args.models == "all" else dict(list(MODELS.items())[:1])
    print(
        f"n = {args.n} targets per model and task, seed {args.seed}, repeat {args.repeat}, "
        f"{platform.processor() or platform.machine()}; times per solve [ms]"
    )
    print()
    print(
        "| model | solver | task | success | wall median | CPU median | CPU p95 "
        "| CPU / dls | mean iterations |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    reports = []
    for label, spec in models.items():
        chain = Chain(**spec)
        for task in ("position", "pose"):
            rep = run_bench(chain, task, names, args.n, args.seed, label, repeat=args.repeat)
            reports.append(rep)
            print("\n".join(rows(label, rep)), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps([r.to_dict() for r in reports], indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
