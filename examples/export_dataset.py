"""Export a small IK dataset for learning: seeded (target pose, joint solution) pairs
from the closed-form solver, as the project's ``.npz`` and as a plain CSV, with every
stored solution checked by MuJoCo's forward kinematics.

Usage: python examples/export_dataset.py [OUT_DIR] [N]

Writes ``ik_pairs.npz`` and ``ik_pairs.csv`` (N rows, default 2,000) into OUT_DIR (a new
temporary folder by default) and prints the largest FK error over the rows. The same
seed and N always give the same file. Exit status 0 when every row checks, else 1.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from humanoid_ik import Chain
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.experiments.dataset import read_dataset, write_dataset

SEED = 0
TOLERANCE_M = 1e-9


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "out", nargs="?", type=Path, help="output folder (default: a new temp folder)"
    )
    parser.add_argument("n", nargs="?", type=int, default=2000, help="pairs (default 2000)")
    args = parser.parse_args(argv)
    out = args.out or Path(tempfile.mkdtemp(prefix="dataset_"))
    n = args.n
    out.mkdir(parents=True, exist_ok=True)

    npz = write_dataset(out / "ik_pairs.npz", n, seed=SEED)  # the bundled right arm
    data = read_dataset(npz)
    joints = data.meta["joints"]

    header = ["x", "y", "z", "qw", "qx", "qy", "qz", *joints]
    table = np.hstack([data.positions, data.quats, data.q])  # (N, 3 + 4 + 7)
    csv = out / "ik_pairs.csv"
    np.savetxt(csv, table, delimiter=",", header=",".join(header), comments="", fmt="%.9g")

    arm = Chain()  # the same chain: FK of every stored solution against its stored pose
    pos_err, rot_err = 0.0, 0.0
    for p, quat, q in zip(data.positions, data.quats, data.q, strict=True):
        p_fk, R_fk = arm.fk(q)
        pos_err = max(pos_err, float(np.linalg.norm(p_fk - p)))
        rot_err = max(rot_err, float(np.abs(R_fk - quat_to_mat(quat)).max()))
    print(f"{len(data.q)} pairs, joints {', '.join(joints)}")
    print(f"closed form solved {int(data.ok.sum())} of {len(data.q)}")
    print(f"max FK error {pos_err:.3e} m, rotation {rot_err:.3e}")
    print(f"wrote {npz}")
    print(f"wrote {csv}")
    return 0 if pos_err < TOLERANCE_M and rot_err < TOLERANCE_M else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
