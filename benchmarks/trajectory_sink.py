"""What recording the trajectory costs a render: the same scene rendered with and without
the trajectory sink, in alternating rounds in one process.

Per round and variant: :func:`humanoid_ik.outputs.render.render_scene` end to end
(``trajectory=False``: video, stills, metrics; ``trajectory=True``: the same plus the
recorder in the runner's loop and ``trajectory.npz``/``.csv`` written at the end). Prints
the median loop time per frame, the end-to-end wall time and CPU time
(``time.process_time``: this process's threads; ffmpeg runs in its own process) of
each, and the ratios with / without (1.0: no cost)::

    MUJOCO_GL=egl python benchmarks/trajectory_sink.py --scene showcase --frames 90
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

os.environ.setdefault("MUJOCO_GL", "egl")

from humanoid_ik.config.scene import load_scene  # noqa: E402
from humanoid_ik.outputs.render import render_scene, select_backend  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="showcase", help="bundled scene name or file")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--frames", type=int, default=90, help="frames per render")
    p.add_argument("--rounds", type=int, default=3, help="alternating rounds of each")
    args = p.parse_args(argv)

    sc = load_scene(args.scene).with_overrides(
        frames=args.frames, width=args.width, height=args.height
    )
    backend = select_backend()
    loop: dict[bool, list[float]] = {False: [], True: []}
    wall: dict[bool, list[float]] = {False: [], True: []}
    cpu: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory() as tmp:
        render_scene(sc, os.path.join(tmp, "warm-up"), plot=False)
        for k in range(args.rounds):
            for rec in (False, True) if k % 2 == 0 else (True, False):
                c0, w0 = time.process_time(), time.perf_counter()
                out = render_scene(sc, os.path.join(tmp, f"{k}-{rec}"), plot=False, trajectory=rec)
                wall[rec].append((time.perf_counter() - w0) / out.frames)
                cpu[rec].append((time.process_time() - c0) / out.frames)
                loop[rec] += out.frame_times

    print(
        f"scene {sc.name}  {args.width}x{args.height}  backend {backend.name}  "
        f"{args.rounds} rounds x {sc.n_frames} frames each way"
    )
    med = {
        r: (statistics.median(loop[r]), statistics.median(wall[r]), statistics.median(cpu[r]))
        for r in (False, True)
    }
    for r, name in ((False, "without trajectory"), (True, "with trajectory   ")):
        a, b, c = med[r]
        print(
            f"{name}  loop {a * 1e3:7.2f} ms/frame  end to end wall {b * 1e3:7.2f} ms/frame"
            f"  cpu {c * 1e3:7.2f} ms/frame"
        )
    (a0, b0, c0), (a1, b1, c1) = med[False], med[True]
    print(
        f"ratio with / without  loop {a1 / a0:.3f}  end to end wall {b1 / b0:.3f}  "
        f"cpu {c1 / c0:.3f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
