"""The ``run`` subcommand of ``humanoid-ik``: a scene run without rendering.

``humanoid-ik run SCENE [--model PATH] [--out DIR] [--solver NAME] [--frames N] [--until S]
[--fps F]``
runs the scene's frame loop and writes ``metrics.csv``, ``metrics.json``,
``trajectory.npz`` and ``trajectory.csv`` into ``renders/<scene>/`` (or ``--out``).
"""

from __future__ import annotations

import argparse
from typing import Any

from humanoid_ik.cli.scene_args import (
    add_scene_args,
    print_summary,
    report_files,
    run_progress,
    scene_from_args,
)

__all__ = ["register"]


def _cmd_run(args: argparse.Namespace) -> int:
    from humanoid_ik.outputs.run_files import write_run

    scene, out = scene_from_args(args)
    progress, close = run_progress(scene)
    try:
        result = write_run(scene, out, progress=progress)
    finally:
        close()
    print(f"{scene.name}: {result.frames} frame(s) at {scene.fps:g} frames/s")
    print_summary(result.metrics)
    return report_files(result.files(), (), result.interrupted, result.frames)


def register(subparsers: Any) -> None:
    """Add ``run`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "run",
        help="run a scene without rendering (metrics and joint trajectory)",
        description="Run a scene file (or a bundled scene by name) without rendering and "
        "write its metrics and joint trajectory (trajectory.npz, trajectory.csv) into "
        "renders/<scene>/ (or --out).",
    )
    add_scene_args(p)
    p.set_defaults(func=_cmd_run)
