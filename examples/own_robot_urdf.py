"""Your own robot from a URDF: a chain ending at a body (URDF links have no sites), one
reachable pose solved with the default solver, the answer checked by MuJoCo's FK.

Usage: python examples/own_robot_urdf.py [OUT_DIR]

Prints the joint values and the errors, and writes ``solution.json`` into OUT_DIR (a new
temporary folder by default). Exit status 0 when the solve converged, else 1.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from humanoid_ik import Chain, Target, solve
from humanoid_ik.core.rotations import mat_to_quat

URDF = Path(__file__).resolve().parent / "urdf_arm" / "arm7.urdf"
POSTURE = [0.4, 0.6, -0.3, -1.1, 0.2, 0.7, 0.1]  # [rad], inside every range of arm7.urdf


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "out", nargs="?", type=Path, help="output folder (default: a new temp folder)"
    )
    out = parser.parse_args(argv).out or Path(tempfile.mkdtemp(prefix="own_robot_"))
    out.mkdir(parents=True, exist_ok=True)

    arm = Chain(URDF, body="tool_link")  # the hinges from the world to the tool link
    p, R = arm.fk(POSTURE)  # a pose the arm can take: (3,) [m], (3, 3)
    target = Target(p, quat=mat_to_quat(R))
    res = solve(arm, target, q0=arm.q_home)  # from the home posture (zeros), default solver

    p_got, _ = arm.fk(res.q)  # independent check: MuJoCo FK of the answer
    fk_error = float(np.linalg.norm(p_got - p))
    for name, value in zip(arm.joint_names, res.q, strict=True):
        print(f"  {name:8s} {value:+.6f} rad")
    print(f"status {res.status}")
    print(f"position error {res.position_error:.3e} m (FK check {fk_error:.3e} m)")
    print(f"orientation error {res.orientation_error:.3e} rad")
    print(f"within ranges {arm.within_limits(res.q)}")

    solution = {
        "model": URDF.name,
        "body": "tool_link",
        "target_position_m": p.tolist(),
        "target_quat_wxyz": target.quat.tolist(),
        "joints": dict(zip(arm.joint_names, res.q.tolist(), strict=True)),
        "status": str(res.status),
        "position_error_m": res.position_error,
        "orientation_error_rad": res.orientation_error,
    }
    path = out / "solution.json"
    path.write_text(json.dumps(solution, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {path}")
    return 0 if res.converged else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
