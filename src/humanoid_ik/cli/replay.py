"""The ``replay`` subcommand of ``humanoid-ik``: film a trajectory file without solving.

``humanoid-ik replay TRAJECTORY [--out DIR] [--camera NAME] [--width W] [--height H]
[--model PATH] [--gif] [--no-video]`` writes the same video, PNG snapshots and contact
sheet as the render that recorded it, into ``renders/<scene>_replay/`` (or ``--out``).
A trajectory recorded on another model (other joints, or another digest of the model
file) is refused in one line.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import UsageError, nonempty_path, package_paths
from humanoid_ik.cli.scene_args import frame_size, report_files

__all__ = ["register"]


def _cmd_replay(args: argparse.Namespace) -> int:
    from humanoid_ik.core.models import model_cameras
    from humanoid_ik.outputs.atomic import published
    from humanoid_ik.outputs.render.backend import select_backend
    from humanoid_ik.outputs.render.pipeline import replay_trajectory
    from humanoid_ik.outputs.run_files import check_output_dir
    from humanoid_ik.outputs.trajectory import open_trajectory

    traj, model, digest = open_trajectory(
        args.trajectory, args.model, staged=True, packages=package_paths(args)
    )
    rs = traj.render
    rs = replace(
        rs,
        camera=rs.camera if args.camera is None else args.camera,
        width=rs.width if args.width is None else args.width,
        height=rs.height if args.height is None else args.height,
        gif=rs.gif or args.gif,
    )
    cams = model_cameras(model)
    if rs.camera not in cams:
        where = (
            "--camera"
            if args.camera is not None
            else f"trajectory '{args.trajectory}': render.camera"
        )
        raise UsageError(f"{where} '{rs.camera}' not in model; cameras: {', '.join(cams)}")
    buffer = {"width": int(model.vis.global_.offwidth), "height": int(model.vis.global_.offheight)}
    for key, limit in buffer.items():
        if getattr(rs, key) > limit:
            where = (
                f"--{key}"
                if getattr(args, key) is not None
                else f"trajectory '{args.trajectory}': render.{key}"
            )
            raise UsageError(
                f"{where} {getattr(rs, key)}: expected at most {limit} (the model's off-screen "
                "buffer, visual/global); pass a smaller --width/--height"
            )
    out = Path("renders") / f"{traj.scene}_replay" if args.out is None else Path(args.out)
    source = Path(args.trajectory)
    if out.resolve() == source.resolve().parent and source.name in published(out):
        raise UsageError(
            f"--out '{out}' holds the set '{source}' belongs to, which a replay there would "
            "replace: choose another --out"
        )
    backend = select_backend()  # a bad MUJOCO_GL is said before any folder is made
    if backend.note:
        print(f"humanoid-ik: note: {backend.note}", file=sys.stderr)
    check_output_dir(out)
    result = replay_trajectory(traj, model, out, digest=digest, render=rs, video=not args.no_video)
    print(
        f"{traj.scene}: replayed {result.frames} frame(s) {rs.width}x{rs.height} camera "
        f"{rs.camera} ({result.backend.name})"
    )
    return report_files(result.files(), result.notes, result.interrupted, result.frames)


def register(subparsers: Any) -> None:
    """Add ``replay`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "replay",
        help="film a trajectory file without solving (MP4, PNG frames, contact sheet)",
        description="Render a trajectory.npz (or .csv) written by render or run, without "
        "solving anything: the same video, frames and contact sheet as its render.",
    )
    p.add_argument("trajectory", metavar="TRAJECTORY", help="a trajectory .npz or .csv file")
    p.add_argument(
        "--out",
        type=nonempty_path,
        metavar="DIR",
        help="output folder (default: renders/<scene>_replay)",
    )
    p.add_argument("--camera", metavar="NAME", help="a named camera of the model")
    p.add_argument("--width", type=frame_size, metavar="W", help="frame width [px]")
    p.add_argument("--height", type=frame_size, metavar="H", help="frame height [px]")
    p.add_argument(
        "--model",
        type=nonempty_path,
        metavar="PATH",
        help="the model file it was recorded on (default: the one it names)",
    )
    p.add_argument("--gif", action="store_true", help="also write an animated GIF")
    p.add_argument("--no-video", action="store_true", help="skip the MP4")
    p.set_defaults(func=_cmd_replay)
