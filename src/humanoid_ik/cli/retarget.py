"""``humanoid-ik retarget MOTION.bvh|FOLDER --model ROBOT [--out DIR] [--solver auto|mink]
[--mapping FILE] [--limbs FILE] [--frames N] [--reach K] [--film [--width W] [--height H]]
[--no-plot] [--workers N] [--ray ADDRESS]``: a human motion capture clip (or every clip
of a folder, on the local pool or Ray) retargeted onto a robot's arms and head
(``docs/retarget.md``)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    UsageError,
    add_package_arg,
    int_at_least,
    int_in,
    nonempty_path,
    package_paths,
    ray_address,
)
from humanoid_ik.cli.scene_args import frame_size

__all__ = ["register"]


def _mm(v: float | None) -> str:
    return "-" if v is None else f"{v * 1e3:.3g} mm"


def _deg(v: float | None) -> str:
    return "-" if v is None else f"{v:.3g} deg"


def _reach(text: str) -> float:
    """``--reach``: a fraction from 0.5 to 1."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not 0.5 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a fraction from 0.5 to 1, got '{text}'")
    return v


def _cmd(args: argparse.Namespace) -> int:
    from humanoid_ik.experiments.retarget import FILM, clip_name, retarget, retarget_folder
    from humanoid_ik.experiments.retarget.robot import model_label

    src = Path(args.motion)
    if not src.exists():
        raise UsageError(f"MOTION '{src}' does not exist; give a .bvh file or a folder of them")
    if not args.film and (args.width is not None or args.height is not None):
        raise UsageError("--width and --height size the film: add --film")
    if not src.is_dir() and (args.workers is not None or args.ray is not None):
        raise UsageError("--workers and --ray run the clips of a folder; MOTION is one file")
    label = model_label(args.model)
    film = None
    if args.film:
        from dataclasses import replace

        from humanoid_ik.outputs.render.backend import select_backend

        film = replace(
            FILM,
            width=FILM.width if args.width is None else args.width,
            height=FILM.height if args.height is None else args.height,
        )
        backend = select_backend()  # a bad MUJOCO_GL is said before any clip is solved
        if backend.note:
            print(f"humanoid-ik: note: {backend.note}", file=sys.stderr)
    options: dict[str, Any] = {
        "solver": args.solver,
        "mapping": args.mapping,
        "frames": args.frames,
        "packages": package_paths(args) or None,
        "limbs": args.limbs,
        "reach": args.reach,
        "film": film,
    }
    if src.is_dir():
        out = Path(args.out) if args.out else Path("renders") / "retarget" / label / clip_name(src)
        if out.exists() and not out.is_dir():
            raise UsageError(f"--out '{out}' is a file; expected a folder")

        def progress(clip: str, status: str) -> None:
            print(f"  {clip}: {status}")

        rows, path = retarget_folder(
            src,
            args.model,
            out,
            progress=progress,
            workers=args.workers,
            ray=args.ray,
            plot=not args.no_plot,
            **options,
        )
        failed = [r for r in rows if r["status"] == "failed"]
        for r in failed:
            print(f"humanoid-ik: {r['clip']}: {r['error']}", file=sys.stderr)
        print(f"{len(rows)} clip(s): {len(rows) - len(failed)} ok or done, {len(failed)} failed")
        print(f"wrote {path}")
        return 1 if failed else 0
    out = Path(args.out) if args.out else Path("renders") / "retarget" / label / clip_name(src)
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
    for note in res.doc.get("film", {}).get("notes", []):
        print(f"humanoid-ik: note: {note}", file=sys.stderr)
    for f in res.files:
        print(f"wrote {f}")
    return 0


def register(subparsers: Any) -> None:
    """Add ``retarget`` to the ``humanoid-ik`` subcommands."""
    from humanoid_ik.experiments.retarget.solve import SOLVERS
    from humanoid_ik.experiments.retarget.targets import REACH
    from humanoid_ik.experiments.sweep.executors import MAX_WORKERS

    p = subparsers.add_parser(
        "retarget",
        help="retarget human motion capture (BVH) onto a robot's arms and head",
        description="Map a BVH clip's arms and head onto the robot's limbs (scaled to its "
        "arm lengths), solve every frame (hands, elbows, gaze) within the joint speed "
        "limits and free of self-collision, and write trajectory.npz/csv, keys.xml, "
        "metrics.csv/json and metrics.png (with --film, film.mp4, snapshots and a contact "
        "sheet: the robot with the human skeleton beside it) into "
        "renders/retarget/<model>/<clip> (or --out). A folder runs every .bvh in it "
        "(resumable; one after the other, or on --workers processes or --ray) and writes "
        "summary.csv.",
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
    p.add_argument(
        "--reach",
        type=_reach,
        default=REACH,
        metavar="K",
        help="the fraction of the robot's full-stretch arm length the human's full arm "
        f"maps onto, 0.5 to 1 (default: {REACH}; 1: the ratio of arm lengths)",
    )
    p.add_argument("--no-plot", action="store_true", help="skip metrics.png")
    p.add_argument(
        "--film",
        action="store_true",
        help="also film the robot with the human skeleton beside it (film.mp4, four "
        "frame_NNNN.png, contact_sheet.png)",
    )
    p.add_argument("--width", type=frame_size, metavar="W", help="film width [px] (default: 480)")
    p.add_argument("--height", type=frame_size, metavar="H", help="film height [px] (default: 360)")
    p.add_argument(
        "--workers",
        type=int_in(1, MAX_WORKERS),
        metavar="N",
        help="a folder's clips on N local processes (default: one after the other here)",
    )
    p.add_argument(
        "--ray",
        type=ray_address,
        metavar="ADDRESS",
        help="a folder's clips on Ray: 'local' starts a local instance (--workers CPUs), "
        "else a cluster address ('auto')",
    )
    add_package_arg(p)
    p.set_defaults(func=_cmd)
