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

__all__ = ["LOST", "ROT_TOL", "TOL", "track_path", "tracking_lm"]

LOST = 0.01
"""A tracked hand this far from its target position [m] is lost and looked for again."""
TOL = 1e-9
"""``lm``'s position tolerance [m] in a retarget. Its default, 0.1 mm, leaves the hand up
to that far off at random from frame to frame: noise that a third difference at 120 Hz
turns into up to 5 % more jerk than the human's (1e-7 m still 0.1 % on a hand that
barely moves); ``lm`` converges quadratically, so the tighter tolerance costs an
iteration or two (``docs/benchmarks.md``)."""
ROT_TOL = 1e-8
"""``lm``'s orientation tolerance [rad] in a retarget (its default: 1e-3)."""


def tracking_lm(**options: int) -> LM:
    """``lm`` at the retarget's tolerances (:data:`TOL`, :data:`ROT_TOL`)."""
    return LM(tol=TOL, rot_tol=ROT_TOL, **options)


def track_path(
    arm: RobotArm, targets: ArmTargets, q_start: NDArray[np.float64], steps: int
) -> NDArray[np.float64]:
    """The tracked joints ``(F, n)`` of every frame (see the module), from the first
    frame's posture ``q_start``, with ``steps`` elbow steps per frame."""
    c = arm.chain
    track, again = tracking_lm(restarts=0), tracking_lm()
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
