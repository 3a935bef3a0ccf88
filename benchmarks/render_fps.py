"""Frames per second of the whole render pipeline against ``mujoco.Renderer`` alone.

In one process and at one frame size, alternating rounds of:

- **renderer alone**: ``mujoco.Renderer.update_scene`` + ``render`` on the scene's poses
  (the joint values of each frame are computed beforehand and set outside the timing);
- **pipeline**: :func:`humanoid_ik.outputs.render.render_scene` on the same scene and frames:
  per frame of the runner's loop (``SceneRunner.run`` with the film as a sink) move
  targets, solve, ``mj_forward``, metrics, markers and trails, render, and hand the frame
  to the MP4 encoder thread (per-frame loop time), plus the whole run including set-up
  and writing every output (end to end).

Prints the median time per frame of each, the frames per second and the ratio
pipeline fps / renderer fps (goal: >= 0.8)::

    MUJOCO_GL=egl python benchmarks/render_fps.py --scene circle --width 640 --height 480
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402

from humanoid_ik.config.scene import load_scene  # noqa: E402
from humanoid_ik.outputs.render import render_scene, select_backend  # noqa: E402
from humanoid_ik.run.runner import SceneRunner  # noqa: E402


def renderer_alone(model, poses, width, height, camera) -> list[float]:
    """Per-frame wall time [s] of update_scene + render over the given qpos."""
    data = mujoco.MjData(model)
    r = mujoco.Renderer(model, height, width)
    times = []
    try:
        for q in poses:
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            t0 = time.perf_counter()
            r.update_scene(data, camera=camera)
            r.render()
            times.append(time.perf_counter() - t0)
    finally:
        r.close()
    return times


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="circle", help="bundled scene name or file")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--frames", type=int, default=60, help="frames per round")
    p.add_argument("--rounds", type=int, default=3, help="alternating rounds of each")
    args = p.parse_args(argv)

    sc = load_scene(args.scene).with_overrides(
        frames=args.frames, width=args.width, height=args.height
    )
    runner = SceneRunner(sc)
    poses = []
    for i in range(sc.n_frames):
        runner.step(i)
        poses.append(runner.data.qpos.copy())
    backend = select_backend()

    alone: list[float] = []
    loop: list[float] = []
    e2e: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.rounds):
            alone += renderer_alone(runner.model, poses, args.width, args.height, sc.render.camera)
            out = render_scene(sc, os.path.join(tmp, f"round{k}"))
            loop += out.frame_times
            e2e.append(out.total_time / out.frames)

    a, b, c = statistics.median(alone), statistics.median(loop), statistics.median(e2e)
    print(
        f"scene {sc.name}  {args.width}x{args.height}  camera {sc.render.camera}  "
        f"backend {backend.name}  {args.rounds} rounds x {args.frames} frames"
    )
    print(f"mujoco.Renderer alone      median {a * 1e3:7.2f} ms/frame  {1 / a:6.2f} fps")
    print(f"pipeline (render loop)     median {b * 1e3:7.2f} ms/frame  {1 / b:6.2f} fps")
    print(f"pipeline (end to end)      median {c * 1e3:7.2f} ms/frame  {1 / c:6.2f} fps")
    print(f"ratio pipeline / renderer  loop {a / b:.3f}  end to end {a / c:.3f}  (goal >= 0.8)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
