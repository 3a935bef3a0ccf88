"""The ``render`` subcommand of ``humanoid-ik``.

``humanoid-ik render SCENE [--model PATH] [--out DIR] [--solver NAME] [--frames N] [--until S]
[--width W] [--height H] [--camera NAME] [--fps F] [--gif] [--no-video]`` runs a scene
and films it. Heavy imports (MuJoCo's renderer, matplotlib) happen only when it runs.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from humanoid_ik.cli.args import UsageError
from humanoid_ik.cli.scene_args import (
    add_scene_args,
    frame_size,
    print_summary,
    report_files,
    run_progress,
    scene_from_args,
    scene_source,
)

__all__ = ["register"]


def _cmd_render(args: argparse.Namespace) -> int:
    from humanoid_ik.outputs.render.backend import select_backend
    from humanoid_ik.outputs.render.pipeline import render_scene
    from humanoid_ik.outputs.run_files import check_output_dir

    if args.camera is not None:
        from humanoid_ik.config.scene import load_scene, scene_model
        from humanoid_ik.core.models import staged_cameras

        cams = staged_cameras(scene_model(load_scene(args.scene, **scene_source(args))))
        if args.camera not in cams:
            raise UsageError(f"--camera '{args.camera}' not in model; cameras: {', '.join(cams)}")
    scene, out = scene_from_args(
        args,
        create=False,
        width=args.width,
        height=args.height,
        camera=args.camera,
        gif=True if args.gif else None,
    )
    backend = select_backend()  # a bad MUJOCO_GL is said before any folder is made
    if backend.note:
        print(f"humanoid-ik: note: {backend.note}", file=sys.stderr)
    check_output_dir(out)
    progress, close = run_progress(scene)
    try:
        result = render_scene(scene, out, video=not args.no_video, progress=progress)
    finally:
        close()
    loop = sum(result.frame_times)
    fps = result.frames / loop if loop > 0 else 0.0
    print(
        f"{scene.name}: {result.frames} frame(s) {scene.render.width}x{scene.render.height} "
        f"camera {scene.render.camera}, {fps:.1f} frames/s ({result.backend.name})"
    )
    print_summary(result.metrics)
    return report_files(result.files(), result.notes, result.interrupted, result.frames)


def register(subparsers: Any) -> None:
    """Add ``render`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "render",
        help="run a scene and film it (MP4, PNG frames, contact sheet, metrics, trajectory)",
        description="Run a scene file (or a bundled scene by name) and write its video, "
        "frames, contact sheet, metrics and trajectory into renders/<scene>/ (or --out).",
    )
    add_scene_args(p)
    p.add_argument("--width", type=frame_size, metavar="W", help="frame width [px]")
    p.add_argument("--height", type=frame_size, metavar="H", help="frame height [px]")
    p.add_argument("--camera", metavar="NAME", help="a named camera of the model")
    p.add_argument("--gif", action="store_true", help="also write an animated GIF")
    p.add_argument("--no-video", action="store_true", help="skip the MP4")
    p.set_defaults(func=_cmd_render)
