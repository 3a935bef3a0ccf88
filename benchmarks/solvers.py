"""Every solver on the bundled right arm, position and pose targets, as a Markdown table.

The same measurement as ``humanoid-ik bench`` (seeded FK targets, every solve from the
``home`` keyframe, success = error below 1 mm / 0.01 rad inside the joint ranges), run
for both tasks, with each solver's median time as a ratio to ``dls`` on the same task.

    .venv/bin/python benchmarks/solvers.py --n 1000 [--json benchmarks/solvers.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

from humanoid_ik import Chain
from humanoid_ik.experiments.bench import run_bench


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--solvers", help="comma-separated (default: all)")
    p.add_argument("--json", help="also write the reports as JSON")
    args = p.parse_args(argv)
    names = args.solvers.split(",") if args.solvers else None
    chain = Chain()
    reports = [run_bench(chain, task, names, args.n, args.seed) for task in ("position", "pose")]
    print(
        f"right arm, n = {args.n}, seed {args.seed}, {platform.processor() or platform.machine()}"
    )
    print()
    print("| solver | task | success | median [ms] | p95 [ms] | median / dls | mean iterations |")
    print("|---|---|---|---|---|---|---|")
    for rep in reports:
        base = next((r.median_ms for r in rep.results if r.solver == "dls"), None)
        for r in rep.results:
            if r.skipped:
                continue
            ratio = f"{r.median_ms / base:.2f}" if base else "-"
            print(
                f"| `{r.solver}` | {rep.task} | {100 * r.success_rate:.1f} % | "
                f"{r.median_ms:.3f} | {r.p95_ms:.3f} | {ratio} | {r.mean_iterations:.1f} |"
            )
    if args.json:
        Path(args.json).write_text(json.dumps([r.to_dict() for r in reports], indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
