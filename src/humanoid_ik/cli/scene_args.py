"""What the commands that take a scene share (``render``, ``run``, ``replay``, ``view``):
the scene arguments, the frame-size and frame-rate types, the progress bar of a run, the
summary and the list of files written."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from humanoid_ik.cli.args import (
    UsageError,
    add_limbs_file_arg,
    add_package_arg,
    int_in,
    nonempty_path,
    package_paths,
)
from humanoid_ik.cli.progress import progress_bar
from humanoid_ik.config.specs import (
    MAX_FPS,
    MAX_FRAMES,
    MAX_IMAGE_SIZE,
    MIN_FPS,
    MIN_IMAGE_SIZE,
)

if TYPE_CHECKING:
    from humanoid_ik.config.specs import Scene
    from humanoid_ik.run.recording import Recording

__all__ = [
    "add_scene_args",
    "frame_size",
    "print_summary",
    "report_files",
    "run_progress",
    "scene_from_args",
    "scene_source",
]


def frame_size(text: str) -> int:
    """A frame width or height: even, :data:`MIN_IMAGE_SIZE` to :data:`MAX_IMAGE_SIZE`."""
    try:
        v = int(text)
    except ValueError:
        v = None
    if v is None or v < MIN_IMAGE_SIZE or v % 2:
        raise argparse.ArgumentTypeError(
            f"expected an even integer >= {MIN_IMAGE_SIZE}, got '{text}'"
        )
    if v > MAX_IMAGE_SIZE:
        raise argparse.ArgumentTypeError(
            f"expected an even integer >= {MIN_IMAGE_SIZE} and <= {MAX_IMAGE_SIZE}, got '{text}'"
        )
    return v


def _fps(text: str) -> float:
    """A frame rate from :data:`MIN_FPS` to :data:`MAX_FPS`."""
    try:
        v = float(text)
    except ValueError:
        v = None
    if v is None or not MIN_FPS <= v <= MAX_FPS:
        raise argparse.ArgumentTypeError(
            f"expected a number >= {MIN_FPS:g} and <= {MAX_FPS:g}, got '{text}'"
        )
    return v


def _seconds(text: str) -> float:
    """A time > 0 [s]."""
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a number of seconds > 0, got '{text}'")
    return v


def add_scene_args(p: argparse.ArgumentParser) -> None:
    """``SCENE`` and what a run of it may change: ``--model`` (with ``--package-path`` and
    ``--limbs``), ``--out``, ``--solver``, ``--frames``, ``--until``, ``--fps`` (shared by
    ``render`` and ``run``)."""
    p.add_argument("scene", metavar="SCENE", help="a scene .toml file or a bundled scene name")
    p.add_argument(
        "--model",
        type=nonempty_path,
        metavar="PATH",
        help="run the scene on this MJCF, URDF or xacro model instead of its own (its limbs "
        "and limb-relative targets are placed on it: docs/scenes.md)",
    )
    add_package_arg(p)
    add_limbs_file_arg(p)
    p.add_argument(
        "--out",
        type=nonempty_path,
        metavar="DIR",
        help="output folder (default: renders/<scene>)",
    )
    p.add_argument("--solver", metavar="NAME", help="replace the scene's solver")
    p.add_argument(
        "--frames",
        type=int_in(1, MAX_FRAMES),
        metavar="N",
        help=f"N frames spread over the whole scene (at most {MAX_FRAMES:,}); sets the frame rate",
    )
    p.add_argument(
        "--until", type=_seconds, metavar="S", help="stop the scene at S seconds (cut it short)"
    )
    p.add_argument("--fps", type=_fps, metavar="F", help="frames per second")


def scene_from_args(
    args: argparse.Namespace, *, create: bool = True, **render: Any
) -> tuple[Scene, Path]:
    """The scene of :func:`add_scene_args`' arguments with the command line's choices
    applied and checked, and its output folder (created and checked writable).

    Args:
        args: the parsed arguments.
        create: create and check the output folder; ``False`` leaves that to the caller
            (``render`` first chooses the OpenGL backend, so a bad ``MUJOCO_GL`` leaves
            no empty folder).
        render: render choices for :meth:`Scene.with_overrides` (width, height...).

    Raises:
        UsageError: an unknown solver, ``--until`` past the scene's end, ``--frames``
            with ``--fps``.
        SceneError: the scene (with the choices) does not check.
    """
    from humanoid_ik.config.scene import check_scene, load_scene
    from humanoid_ik.outputs.run_files import check_output_dir

    scene = load_scene(args.scene, **scene_source(args))
    for note in scene.notes:
        print(f"humanoid-ik: note: {note}", file=sys.stderr)
    if args.solver is not None:
        from humanoid_ik.solvers import SOLVERS

        if args.solver not in SOLVERS:
            raise UsageError(f"--solver '{args.solver}' unknown; solvers: {', '.join(SOLVERS)}")
    if args.frames is not None and args.fps is not None:
        raise UsageError(
            f"--frames {args.frames} sets the frame rate (frames / duration); give --frames "
            "or --fps, not both"
        )
    if args.until is not None and args.until > scene.duration:
        raise UsageError(
            f"--until {args.until:g} is after the end of scene '{scene.name}' "
            f"({scene.duration:g} s); expected a time > 0 and <= {scene.duration:g}"
        )
    scene = scene.with_overrides(
        solver=args.solver, fps=args.fps, frames=args.frames, until=args.until, **render
    )
    check_scene(scene)
    out = Path("renders") / scene.name if args.out is None else Path(args.out)
    if create:
        check_output_dir(out)
    return scene, out


def scene_source(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of :func:`~humanoid_ik.config.scene.load_scene` that
    :func:`add_scene_args`' ``--model``, ``--package-path`` and ``--limbs`` give."""
    return {
        "packages": package_paths(args),
        "model": getattr(args, "model", None),
        "limbs": getattr(args, "limbs", None),
    }


def run_progress(scene: Scene) -> tuple[Callable[[int, int], None], Callable[[], None]]:
    """A progress callback ``(done, total)`` for a run of ``scene`` (a bar on a terminal)
    and the function that closes the bar."""
    bar = progress_bar(scene.n_frames if scene.n_frames > 1 else 0, "frame", scene.name)

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.update(done - bar.n)

    def close() -> None:
        if bar is not None:
            bar.close()

    return progress, close


def print_summary(metrics: Recording) -> None:
    """One line per effector: reachable frames, worst error, share on target, solve time."""
    for s in metrics.summary():
        err = s["max_position_error_reachable_m"]
        share = s["on_target_when_reachable"]
        err_txt = "no reachable frame" if err is None else f"max error {err * 1e3:.3f} mm"
        share_txt = "" if share is None else f", on target {100 * share:.0f}%"
        print(
            f"  {s['effector']} -> {s['target']} ({s['solver']}): reachable "
            f"{s['reachable_frames']}/{s['frames']}, {err_txt}{share_txt}, median solve "
            f"{(s['median_solve_time_s'] or 0) * 1e3:.2f} ms"
        )


def report_files(
    files: Sequence[Path], notes: Sequence[str], interrupted: bool, frames: int
) -> int:
    """Print each note on stderr (``humanoid-ik: note: ...``), ``wrote <file>`` for each
    file, and on Ctrl-C how many frames were done; returns the exit code (130 when
    interrupted, else 0)."""
    for note in notes:
        print(f"humanoid-ik: note: {note}", file=sys.stderr)
    for f in files:
        print(f"wrote {f}")
    if interrupted:
        print(f"humanoid-ik: interrupted after {frames} frame(s)", file=sys.stderr)
        return 130
    return 0
