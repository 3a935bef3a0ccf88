"""``humanoid-ik retarget MOTION.bvh|FOLDER --model ROBOT [--out DIR] [--solver auto|mink]
[--mapping FILE] [--limbs FILE] [--frames N] [--no-plot]``: a human motion capture clip
(or every clip of a folder) retargeted onto a robot's arms and head
(``docs/retarget.md``)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    UsageError,
    add_package_arg,
    int_at_least,
    nonempty_path,
    package_paths,
)

__all__ = ["register"]


def _mm(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e3:.3g} mm"


def _deg(v: float | None) -> str:
    return "-" if v is None else f"{v:.3g} deg"


def _cmd(args: argparse.Namespace) -> int:
    from humanoid_ik.experiments.retarget import retarget, retarget_folder
    from humanoid_ik.experiments.retarget.robot import model_label

    src = Path(args.motion)
    if not src.exists():
        raise UsageError(f"MOTION '{src}' does not exist; give a .bvh file or a folder of them")
    label = model_label(args.model)
    options: dict[str, Any] = {
        "solver": args.solver,
        "mapping": args.mapping,
        "frames": args.frames,
        "packages": package_paths(args) or None,
        "limbs": args.limbs,
    }
    if src.is_dir():
        out = Path(args.out) if args.out else Path("renders") / "retarget" / label / src.name
        if out.exists() and not out.is_dir():
            raise UsageError(f"--out '{out}' is a file; expected a folder")

        def progress(clip: str, status: str) -> None:
            print(f"  {clip}: {status}")

        rows, path = retarget_folder(
            src, args.model, out, progress=progress, plot=not args.no_plot, **options
        )
        failed = [r for r in rows if r["status"] == "failed"]
        for r in failed:
            print(f"humanoid-ik: {r['clip']}: {r['error']}", file=sys.stderr)
        print(f"{len(rows)} clip(s): {len(rows) - len(failed)} ok or done, {len(failed)} failed")
        print(f"wrote {path}")
        return 1 if failed else 0
    out = Path(args.out) if args.out else Path("renders") / "retarget" / label / src.stem
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out '{out}' is a file; expected a folder")
    res = retarget(src, args.model, out, plot=not args.no_plot, **options)
    s = res.summary
    print(f"{src.name} -> {label}: {s['frames']} frame(s), solvers {res.doc['methods']}")
    for side in ("left", "right"):
        if side in s:
            h = s[side]
            pe = h["position_error_reachable_m"]
            print(
                f"  {side} hand: median {_mm(pe['median'])}, p99 {_mm(pe['p99'])} "
                f"({h['reachable_frames']} reachable frames); elbow median "
                f"{_deg(h['elbow_error_deg']['median'])}"
            )
    if "gaze_error_deg" in s:
        print(f"  gaze: median {_deg(s['gaze_error_deg']['median'])}")
    print(
        f"  out of range {s['frames_out_of_range']}, over a speed limit "
        f"{s['frames_over_speed_limit']} (cut to it: {s['frames_speed_cut']}), "
        f"self-collision {s['collision_frames']} frame(s); "
        f"{s['frames_per_s_cpu']:.0f} frames/s (CPU)"
    )
    for f in res.files:
        print(f"wrote {f}")
    return 0


def register(subparsers: Any) -> None:
    """Add ``retarget`` to the ``humanoid-ik`` subcommands."""
    from humanoid_ik.experiments.retarget.solve import SOLVERS

    p = subparsers.add_parser(
        "retarget",
        help="retarget human motion capture (BVH) onto a robot's arms and head",
        description="Map a BVH clip's arms and head onto the robot's limbs (scaled to its "
        "arm lengths), solve every frame (hands, elbows, gaze) within the joint speed "
        "limits and free of self-collision, and write trajectory.npz/csv, keys.xml, "
        "metrics.csv/json and metrics.png into renders/retarget/<model>/<clip> (or --out). "
        "A folder runs every .bvh in it (resumable) and writes summary.csv.",
    )
    p.add_argument("motion", metavar="MOTION", help="a .bvh file, or a folder of them")
    p.add_argument(
        "--model",
        type=nonempty_path,
        metavar="ROBOT",
        help="the robot's model file, MJCF or URDF (default: the bundled humanoid)",
    )
    p.add_argument("--out", type=nonempty_path, metavar="DIR", help="output folder")
    p.add_argument(
        "--solver",
        choices=SOLVERS,
        default="auto",
        help="auto: the exact per-arm solvers where they apply (else lm), the QP for "
        "frames that would collide; mink: the QP every frame (default: auto)",
    )
    p.add_argument("--mapping", type=nonempty_path, metavar="FILE", help="a mapping file (TOML)")
    p.add_argument(
        "--limbs", type=nonempty_path, metavar="FILE", help="a robot limb profile (TOML)"
    )
    p.add_argument(
        "--frames", type=int_at_least(1), metavar="N", help="retarget the first N frames"
    )
    p.add_argument("--no-plot", action="store_true", help="skip metrics.png")
    add_package_arg(p)
    p.set_defaults(func=_cmd)
