"""dm_control's ``qpos_from_site_pose`` on the targets of ``benchmarks/peers.py``.

dm_control 1.0.50 needs MuJoCo 3.x while the project runs on MuJoCo 4, so this script
runs in its own venv (see ``docs/benchmarks.md``) and does not import the project::

    benchmarks/.venv-dm/bin/python benchmarks/dm_control_peer.py REQUEST.json RESULT.json
    benchmarks/.venv-dm/bin/python benchmarks/dm_control_peer.py --package-dir

The request (written by ``peers.py``) lists, per arm and task: the MJCF file, the site
(or a body to put a site on, at the body's frame), the chain's joint names, the full
start ``qpos`` and the targets (position, and wxyz quaternion or null). For each target
the script restores the start, calls ``qpos_from_site_pose`` with its defaults (100
steps, ``tol`` 1e-14) and records the chain's joint values it returns, its step count,
and the CPU (``time.process_time``) and wall time of the call. Whether an answer is on
target and inside the joint ranges is decided by ``peers.py``, with its own MuJoCo FK.
``--package-dir`` prints where dm_control's files are (for the arms it ships).
"""

from __future__ import annotations

import json
import os
import sys
import time

import dm_control
import mujoco
import numpy as np
from dm_control.mujoco import Physics, wrapper
from dm_control.utils.inverse_kinematics import qpos_from_site_pose


def _physics(arm: dict) -> Physics:
    spec = mujoco.MjSpec.from_file(arm["xml"])
    if arm.get("site_on_body"):
        body = spec.body(arm["site_on_body"])
        body.add_site(name=arm["site"])
    return Physics.from_model(wrapper.MjModel(spec.compile()))


def run(request: dict) -> dict:
    out = []
    for job in request["jobs"]:
        physics = _physics(job)
        start = np.array(job["start_qpos"])
        joints = job["joints"]
        adr = [physics.model.jnt_qposadr[physics.model.name2id(j, "joint")] for j in joints]
        answers = []
        for position, quat in job["targets"]:
            physics.data.qpos[:] = start
            physics.forward()
            c0, w0 = time.process_time(), time.perf_counter()
            res = qpos_from_site_pose(
                physics,
                job["site"],
                target_pos=np.array(position),
                target_quat=None if quat is None else np.array(quat),
                joint_names=joints,
                inplace=False,
            )
            cpu, wall = time.process_time() - c0, time.perf_counter() - w0
            answers.append(
                {
                    "q": [float(res.qpos[a]) for a in adr],
                    "steps": int(res.steps),
                    "cpu_s": cpu,
                    "wall_s": wall,
                }
            )
        out.append({"arm": job["arm"], "task": job["task"], "answers": answers})
    return {
        "versions": {"mujoco": mujoco.__version__},
        "results": out,
    }


def main(argv: list[str]) -> int:
    if argv == ["--package-dir"]:
        print(os.path.dirname(dm_control.__file__))
        return 0
    if len(argv) != 2:
        print(__doc__.splitlines()[0], file=sys.stderr)
        print("usage: dm_control_peer.py REQUEST.json RESULT.json | --package-dir", file=sys.stderr)
        return 2
    with open(argv[0]) as fh:
        request = json.load(fh)
    result = run(request)
    tmp = argv[1] + ".part"
    with open(tmp, "w") as fh:
        json.dump(result, fh)
    os.replace(tmp, argv[1])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
