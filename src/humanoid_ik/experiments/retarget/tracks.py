"""The path of an ``lm`` arm tracked once over the whole clip before the frame loop,
without the speed limits: the branch the human's motion leads the arm along.

In the frame loop, a frame the speed limits cut leaves the arm off the exact answer, and
the next frames' ``lm``, started from there, may settle on another branch of the
redundant arm and stay on it: on Talos's reach across the body the elbow ended 18
degrees from the human's. So the clip is first tracked without the limits, every
frame from the previous frame's answer, with the frame loop's own steps (the elbow's
pull, then ``lm``; the position alone where the pose is out of reach), and a hand lost
(more than :data:`LOST` off: ``lm`` stalled against a range) found again by ``lm`` with
its restarts. The frame loop then starts each frame's ``lm`` from this path's joints, so
that it lands on the path's branch, and follows it within the limits.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.retarget.elbow import elbow_steps
from humanoid_ik.experiments.retarget.plan import elbow_weight
from humanoid_ik.experiments.retarget.robot import RobotArm
from humanoid_ik.experiments.retarget.targets import ArmTargets
from humanoid_ik.solvers.jacobian.lm import LM

__all__ = ["LOST", "track_path"]

LOST = 0.01
"""A tracked hand this far from its target position [m] is lost and looked for again."""


def track_path(
    arm: RobotArm, targets: ArmTargets, q_start: NDArray[np.float64], steps: int
) -> NDArray[np.float64]:
    """The tracked joints ``(F, n)`` of every frame (see the module), from the first
    frame's posture ``q_start``, with ``steps`` elbow steps per frame."""
    c = arm.chain
    track, again = LM(restarts=0), LM()
    w = elbow_weight(targets.bend)
    path = np.empty((len(targets.position), c.n))
    q = c.clip(q_start)
    path[0] = q
    for f in range(1, len(path)):
        R = targets.rotation(f) if arm.pose else None
        p = targets.position[f]
        tgt = Target(p, mat_to_quat(R)) if R is not None else Target(p)
        res = track.solve(c, tgt, elbow_steps(c, q, p, R, targets.elbow[f], steps, float(w[f])))
        if not res.converged and R is not None:
            pos = track.solve(c, Target(p), res.q)
            res = pos if pos.position_error < res.position_error else res
        if res.position_error > LOST:
            found = again.solve(c, Target(p), q)
            res = found if found.position_error < res.position_error else res
        q = path[f] = res.q
    return path
