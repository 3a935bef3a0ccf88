"""The ``export-bvh`` and ``export-keyframes`` subcommands of ``humanoid-ik``.

``humanoid-ik export-bvh TRAJECTORY --out motion.bvh [--units m|cm] [--model PATH]``
writes the motion as a BVH skeleton; ``humanoid-ik export-keyframes TRAJECTORY --out
keys.xml [--every K] [--model PATH]`` as MuJoCo ``<key>`` elements. Both check the
trajectory against its model first (joints and the model file's digest).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from humanoid_ik.cli.args import check_writable, int_at_least, nonempty_path, package_paths

__all__ = ["register"]


def _checked(args: argparse.Namespace) -> tuple[Any, Any]:
    """The trajectory and its model, checked against each other, after ``--out`` is
    checked writable."""
    from humanoid_ik.outputs.trajectory import open_trajectory

    check_writable(Path(args.out))
    traj, model, _ = open_trajectory(args.trajectory, args.model, packages=package_paths(args))
    return traj, model


def _cmd_bvh(args: argparse.Namespace) -> int:
    from humanoid_ik.outputs.atomic import write_text
    from humanoid_ik.outputs.bvh import bvh_text

    traj, model = _checked(args)
    path = write_text(args.out, bvh_text(traj, model, args.units))
    print(f"{traj.scene}: {traj.n_frames} frame(s) at {traj.fps:g} frames/s, units {args.units}")
    print(f"wrote {path}")
    return 0


def _cmd_keyframes(args: argparse.Namespace) -> int:
    from humanoid_ik.outputs.atomic import write_text
    from humanoid_ik.outputs.keyframes import keyframes_xml

    traj, _ = _checked(args)
    path = write_text(args.out, keyframes_xml(traj, args.every))
    keys = len(range(0, traj.n_frames, args.every))
    print(f"{traj.scene}: {keys} key(s) of {traj.n_frames} frame(s)")
    print(f"wrote {path}")
    return 0


def _common(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("trajectory", metavar="TRAJECTORY", help="a trajectory .npz or .csv file")
    p.add_argument("--out", type=nonempty_path, required=True, metavar="FILE", help=what)
    p.add_argument(
        "--model",
        type=nonempty_path,
        metavar="PATH",
        help="the model file it was recorded on (default: the one it names)",
    )


def register(subparsers: Any) -> None:
    """Add ``export-bvh`` and ``export-keyframes`` to the ``humanoid-ik`` subcommands."""
    from humanoid_ik.outputs.bvh import BVH_UNITS

    p = subparsers.add_parser(
        "export-bvh",
        help="write a trajectory as a BVH skeleton for animation tools",
        description="Write a trajectory.npz (or .csv) as a BVH file: the model's joint "
        "tree, one rotation channel per hinge along a world axis (three for a slanted "
        "hinge or a ball joint), fixed links folded in, Y up (see docs/formats.md). A "
        "model BVH cannot hold (a slide joint that moves, hinges of one body about two "
        "points) is refused: export-keyframes writes any model's motion.",
    )
    _common(p, "the .bvh file to write")
    p.add_argument(
        "--units", choices=tuple(BVH_UNITS), default="m", help="length unit (default: m)"
    )
    p.set_defaults(func=_cmd_bvh)

    p = subparsers.add_parser(
        "export-keyframes",
        help="write a trajectory as MuJoCo <key> elements",
        description="Write a trajectory.npz (or .csv) as an MJCF <keyframe> with one "
        "<key> per frame (full qpos and time).",
    )
    _common(p, "the .xml file to write")
    p.add_argument(
        "--every", type=int_at_least(1), default=1, metavar="K", help="keep every K-th frame"
    )
    p.set_defaults(func=_cmd_keyframes)
