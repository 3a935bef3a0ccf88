"""Retargeting benchmark: CMU-style clips of 1,200 frames at 120 Hz (``human_bvh``:
reach, wave, arm_circles) onto the bundled humanoid, ``models/robot`` (its limbs found
from the names: ``sh``, ``wr`` are arm words), G1 and Talos, with the exact per-arm
solvers (``auto``) and with the QP (``mink``), the human arm mapped onto each ``--reach``
fraction of the robot's full-stretch arm length (1: the ratio of arm lengths).

Per robot, solver and clip: hand position error median / p99 over reachable frames,
the frames feasible (within the joint ranges, as far as a swivel plan knows:
``closed_form`` arms) and the p99 over them,
elbow direction error median, frames out of range, over a speed limit, cut to one, in
self-collision, frames solved by the QP fallback, the hands' RMS jerk against the
scaled human source's, frames per second (wall and CPU, ``time.process_time``).

    .venv/bin/python benchmarks/retarget.py [--frames 1200] [--robots humanoid,robot,g1,talos]
        [--solvers auto,mink] [--motions reach,wave,arm_circles] [--reach 1,0.95]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=1200)
    ap.add_argument("--robots", default="humanoid,robot,g1,talos")
    ap.add_argument("--solvers", default="auto,mink")
    ap.add_argument("--motions", default="reach,wave,arm_circles")
    ap.add_argument("--reach", default="1,0.95", help="fractions of the robot's arm length")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    from robots import robot_file

    from humanoid_ik.experiments.retarget import retarget
    from humanoid_ik.motion.human import human_bvh

    tmp = Path(tempfile.mkdtemp(prefix="retarget_bench_"))
    repo = Path(__file__).resolve().parents[1]
    models = {
        "humanoid": None,
        "robot": repo / "models" / "robot" / "robot.xml",
        "g1": robot_file("g1"),
        "talos": robot_file("talos"),
    }
    clips = {}
    for motion in args.motions.split(","):
        p = tmp / f"{motion}.bvh"
        p.write_text(human_bvh(motion, seconds=args.frames / 120.0))
        clips[motion] = p
    print(
        "| robot | solver | reach | clip | hand median / p99 [mm] | feasible frames: p99 [mm] | "
        "elbow median [deg] | "
        "out of range | over speed (cut) | collision frames (QP fallback) | "
        "jerk robot / source [m/s^3] | frames/s wall (CPU) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.robots.split(","):
        model = models[name]
        for solver, reach, (motion, clip) in itertools.product(
            args.solvers.split(","), [float(r) for r in args.reach.split(",")], clips.items()
        ):
            res = retarget(clip, model, None, solver=solver, reach=reach, plot=False)
            s = res.summary
            hands, elbows, jerks, feas = [], [], [], []
            for side in ("left", "right"):
                if side not in s:
                    continue
                h = s[side]
                pe = h["position_error_reachable_m"]
                if pe["median"] is not None:
                    hands.append(f"{side[0]} {pe['median'] * 1e3:.3g} / {pe['p99'] * 1e3:.3g}")
                fe = h["position_error_feasible_m"]["p99"]
                p99 = "-" if fe is None else format(fe * 1e3, ".3g")
                feas.append(f"{side[0]} {h['feasible_frames']}: {p99}")
                m = h["elbow_error_deg"]["median"]
                elbows.append(f"{side[0]} {'-' if m is None else format(m, '.3g')}")
                jerks.append(f"{h['jerk_rms_m_s3']:.3g} / {h['source_jerk_rms_m_s3']:.3g}")
            print(
                f"| {name} | {solver} | {reach:g} | {motion} | {'; '.join(hands)} | "
                f"{'; '.join(feas)} | "
                f"{'; '.join(elbows)} | "
                f"{s['frames_out_of_range']} | {s['frames_over_speed_limit']} "
                f"({s['frames_speed_cut']}) | {s['collision_frames']} "
                f"({s['qp_fallback_frames']}) | {'; '.join(jerks)} | "
                f"{s['frames_per_s_wall']:.0f} ({s['frames_per_s_cpu']:.0f}) |",
                flush=True,
            )


if __name__ == "__main__":
    main()
