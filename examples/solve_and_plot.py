"""Solve along a path and plot the joint angles: the bundled humanoid's right hand
traces a circle in front of the body, each point solved warm-started from the previous
one, and the elbow angle and the position error are plotted against the path.

Usage: python examples/solve_and_plot.py [OUT_DIR]

Writes ``joint_angles.png`` into OUT_DIR (a new temporary folder by default) and prints
the largest position error and the elbow's range over the path. Exit status 0 when every
point converged, else 1.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from humanoid_ik import Chain, Status, solve  # noqa: E402

N_POINTS = 60
CENTER = np.array([0.40, -0.30, 1.20])  # [m], in front of the right shoulder
RADIUS = 0.12  # [m], in the frontal (y, z) plane


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "out", nargs="?", type=Path, help="output folder (default: a new temp folder)"
    )
    out = parser.parse_args(argv).out or Path(tempfile.mkdtemp(prefix="solve_plot_"))
    out.mkdir(parents=True, exist_ok=True)

    arm = Chain()  # right arm, right_palm_site
    elbow = arm.joint_names.index("right_elbow_joint")
    s = np.linspace(0.0, 2.0 * np.pi, N_POINTS)  # path parameter [rad]
    path = CENTER + RADIUS * np.stack([0 * s, np.cos(s), np.sin(s)], axis=1)  # (N, 3)

    q = arm.q_home
    angles, errors, ok = [], [], True
    for point in path:
        res = solve(arm, point, "dls", q0=q)  # warm start: the previous answer
        ok &= res.status == Status.CONVERGED
        q = res.q
        angles.append(q[elbow])
        errors.append(res.position_error)
    angles_deg = np.degrees(angles)

    fig, (ax_q, ax_e) = plt.subplots(2, 1, sharex=True, figsize=(6, 4.5))
    ax_q.plot(np.degrees(s), angles_deg)
    ax_q.set_ylabel("right elbow [deg]")
    ax_e.semilogy(np.degrees(s), np.maximum(errors, 1e-16))
    ax_e.set_ylabel("position error [m]")
    ax_e.set_xlabel("angle along the circle [deg]")
    fig.suptitle("right hand on a 12 cm circle (dls, warm-started)")
    fig.tight_layout()
    png = out / "joint_angles.png"
    fig.savefig(png, dpi=80)
    plt.close(fig)

    print(f"{N_POINTS} points, max position error {max(errors):.3e} m")
    print(f"right elbow from {angles_deg.min():.2f} to {angles_deg.max():.2f} deg")
    print(f"wrote {png}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
