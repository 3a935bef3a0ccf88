"""The ``view`` subcommand of ``humanoid-ik``: MuJoCo's interactive viewer, live.

``humanoid-ik view [SCENE | --model PATH --site NAME | --body NAME [--joints J1,J2...]]
[--package-path NAME=DIR] [--solver NAME] [--duration S] [--out DIR]`` opens the viewer
with the targets as mocap bodies: the scene's motions play (space pauses them), any
target can be dragged (double-click it, then Ctrl + right-drag; Backspace hands it back
to its motion) and the solver tracks it live. With
``--model``/``--site`` (or ``--body``, a URDF link) there is one target, still at the end
effector's home position until dragged. ``--out`` publishes the trajectory of the frames
shown on exit, as one set in place of the previous run's files there.

Everything that can be refused is checked before the window opens: the display (one line,
exit 2), the scene, ``--duration`` (finite, at most ``MAX_FRAMES`` frames at the scene's
frame rate: ``docs/limits.md``) and ``--out`` (writable, and holding no file of the user's
that the trajectory would replace). A folder ``--out`` created for a session that wrote
nothing (stopped before its first frame) is removed again.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import (
    UsageError,
    add_limb_args,
    chain_from_args,
    nonempty_path,
    package_paths,
)
from humanoid_ik.cli.scene_args import report_files

__all__ = ["register"]


def _point_scene(args: argparse.Namespace) -> Any:
    """A one-target scene on ``--model`` at ``--site`` or ``--body``: the target waits at
    the end effector's home position until dragged."""
    from humanoid_ik.config.specs import EffectorSpec, Scene, SolverSpec
    from humanoid_ik.core.models import bundled_model_path
    from humanoid_ik.motion import TargetTrack
    from humanoid_ik.motion.paths import Points

    packages = package_paths(args)
    chain = chain_from_args(args)
    home = chain.position.copy()
    site, body = (chain.ee_name, None) if chain.ee_kind == "site" else (None, chain.ee_name)
    return Scene(
        name="view",
        duration=60.0,
        fps=30.0,
        solver=SolverSpec(args.solver or "auto"),
        targets=(TargetTrack("target", Points(points=home[None, :])),),
        effectors=(EffectorSpec(site, "target", joints=tuple(chain.joint_names), body=body),),
        model=Path(args.model) if args.model is not None else bundled_model_path(),
        packages=packages,
    )


def _cmd_view(args: argparse.Namespace) -> int:
    from humanoid_ik.config.scene import check_scene, load_scene
    from humanoid_ik.outputs.viewer import check_display, duration_rule, view_scene

    chain_args = (args.model, args.site, args.body, args.joints, args.arm, args.limb)
    if args.scene is not None and (any(a is not None for a in chain_args) or args.with_torso):
        raise UsageError(
            "give a SCENE or --model/--site/--body/--arm/--limb, not both (--joints goes "
            "with --model)"
        )
    if args.scene is None:
        scene = _point_scene(args)
    else:
        scene = load_scene(args.scene, packages=package_paths(args))
        if args.solver is not None:
            from humanoid_ik.solvers import SOLVERS

            if args.solver not in SOLVERS:
                raise UsageError(f"--solver '{args.solver}' unknown; solvers: {', '.join(SOLVERS)}")
            scene = scene.with_overrides(solver=args.solver)
    check_scene(scene)
    if args.duration is not None and (rule := duration_rule(args.duration, scene.fps)):
        raise UsageError(f"view: argument --duration: expected {rule}, got '{args.duration:g}'")
    if args.out is not None:
        _check_out(Path(args.out))
    check_display()  # before --out is made: a bad display leaves nothing behind
    made = args.out is not None and not os.path.lexists(args.out)
    if args.out is not None:
        from humanoid_ik.outputs.run_files import check_output_dir

        check_output_dir(args.out)

    def opened() -> None:
        print(
            "humanoid-ik: viewer open: space pauses the motions; double-click a target, "
            "then Ctrl + right-drag moves it; Backspace hands it back; close the window "
            "to stop",
            file=sys.stderr,
            flush=True,
        )

    try:
        result = view_scene(scene, args.out, duration=args.duration, on_open=opened)
    finally:
        if made:  # a folder of ours that received nothing goes again
            try:
                os.rmdir(args.out)
            except OSError:  # it holds the trajectory (or is gone)
                pass
    print(f"{scene.name}: {result.frames} frame(s) shown")
    return report_files(result.trajectory or (), (), result.recorded.interrupted, result.frames)


def _check_out(folder: Path) -> None:
    """``--out`` before the session: no trajectory file there but one an earlier run
    published (``outputs/atomic.py`` would refuse the set after the session)."""
    from humanoid_ik.outputs.atomic import published

    ours = set(published(folder))
    for name in ("trajectory.npz", "trajectory.csv"):
        if name not in ours and os.path.lexists(folder / name):
            raise UsageError(
                f"view: --out '{folder}' holds '{name}', which no earlier run wrote there; "
                "remove it or choose another output folder"
            )


def _duration(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = -1.0
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds > 0, got '{text}'")
    return v


def register(subparsers: Any) -> None:
    """Add ``view`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser(
        "view",
        help="MuJoCo's interactive viewer: drag the targets, the solver tracks them live",
        description="Open MuJoCo's viewer on a scene (or a model and site) with the targets "
        "as mocap bodies: motions play (space pauses), targets can be dragged "
        "(double-click, Ctrl + right-drag; Backspace releases), the solver tracks live. "
        "Needs a display.",
    )
    p.add_argument(
        "scene", nargs="?", metavar="SCENE", help="a scene .toml file or a bundled scene name"
    )
    p.add_argument(
        "--model", type=nonempty_path, help="MJCF or URDF path (default: the bundled humanoid)"
    )
    ee = p.add_mutually_exclusive_group()
    ee.add_argument("--site", help="end-effector site (default: right_palm_site)")
    ee.add_argument("--body", help="end-effector body, e.g. a URDF link (instead of --site)")
    add_limb_args(p, ee)
    p.add_argument("--solver", metavar="NAME", help="the solver (default: the scene's, or auto)")
    p.add_argument(
        "--duration", type=_duration, metavar="S", help="close after S seconds of frames"
    )
    p.add_argument(
        "--out",
        type=nonempty_path,
        metavar="DIR",
        help="publish the trajectory here on exit (in place of the previous run's files)",
    )
    p.set_defaults(func=_cmd_view)
