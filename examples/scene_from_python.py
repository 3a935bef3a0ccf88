"""A scene built in Python: a target placed from the model's own kinematics (a
figure-eight in front of the right shoulder, well inside the arm's reach), written in
the scene file format, run for its numbers, then filmed at a tiny size.

Usage: python examples/scene_from_python.py [OUT_DIR]

Writes ``wave.toml``, the run's outputs (``film/``: contact sheet, frames, metrics,
trajectory) into OUT_DIR (a new temporary folder by default) and prints the tracking
summary. Exit status 0 when the hand stayed on the target, else 1.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from humanoid_ik import Chain
from humanoid_ik.config.scene import load_scene
from humanoid_ik.outputs.render import render_scene
from humanoid_ik.run.runner import run_scene

SCENE = """\
name = "wave"
description = "right hand draws a figure-eight in front of the right shoulder"
duration = 3.0
fps = 20

[solver]
name = "dls"

[render]
camera = "front"
contact_sheet = 4

[[targets]]
name = "eight"

[targets.motion]
kind = "figure8"
center = [{x:.4f}, {y:.4f}, {z:.4f}]
width = 0.16
height = 0.10
period = 3.0

[[effectors]]
site = "right_palm_site"
target = "eight"
"""


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "out", nargs="?", type=Path, help="output folder (default: a new temp folder)"
    )
    out = parser.parse_args(argv).out or Path(tempfile.mkdtemp(prefix="scene_"))
    out.mkdir(parents=True, exist_ok=True)

    arm = Chain()  # the bundled humanoid's right arm; its data is at the home posture
    shoulder = arm.data.site("right_shoulder_site").xpos  # (3,) [m], from MuJoCo
    x, y, z = shoulder + [0.40, -0.10, -0.15]  # in front, outward and lower
    path = out / "wave.toml"
    path.write_text(SCENE.format(x=x, y=y, z=z), encoding="utf-8")
    scene = load_scene(path)  # checked like any scene file

    metrics = run_scene(scene)  # every frame solved, no rendering
    summary = metrics.summary()[0]
    on_target = summary["on_target_when_reachable"]
    print(f"{scene.name}: {summary['frames']} frames, {summary['reachable_frames']} reachable")
    print(
        f"on target {on_target:.1%}, worst error {summary['max_position_error_reachable_m']:.3e} m"
    )

    film = render_scene(scene.with_overrides(frames=8, width=160, height=120), out / "film")
    print(f"filmed {film.frames} frames: {film.contact_sheet}")
    return 0 if on_target == 1.0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
