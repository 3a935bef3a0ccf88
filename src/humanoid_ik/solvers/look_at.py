"""Look-at: aim a forward axis of the end-effector frame at a target (the head's gaze)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import mujoco
import numpy as np

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import gaze_error
from humanoid_ik.core.rotations import SIGNED_AXES, hinge_angle_between
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.options import SolverOptions, option

__all__ = ["LookAt"]


@dataclass(frozen=True)
class LookAtOptions(SolverOptions):
    """Options of ``look_at``.

    Attributes:
        rot_tol: the gaze's angle off the target that counts as aimed [rad].
        forward_axis: the site axis aimed at the target: ``x``, ``y``, ``z`` or an
            opposite, ``-x``, ``-y``, ``-z`` (a head whose frame looks backwards).
        max_iterations: sweeps over the chain's hinges.
    """

    rot_tol: float = 1e-6
    forward_axis: str = option("x", valid=SIGNED_AXES)
    max_iterations: int = 200


class LookAt(Solver):
    """Turn the chain's hinges so the site's ``forward_axis`` points at the target.

    The direction to reach is the forward column of the look-at frame
    (:func:`humanoid_ik.core.rotations.look_at`), ``(target - site) / |target - site|``. Each
    sweep turns every hinge (tip to root) by the angle that takes the current forward
    axis closest to that direction about the hinge, re-reading FK from MuJoCo, until the
    angle between them is below ``rot_tol`` (for a yaw/pitch neck this converges in a
    few sweeps; the gaze site's offset from the neck is accounted for by re-aiming from
    the site's new position). Only the pointing is solved: the roll about the forward
    axis (what an up vector would fix) is left where the chain has it.
    """

    name: ClassVar[str] = "look_at"
    reaches: ClassVar[bool] = False
    summary: ClassVar[str] = "aim a forward axis of the site at the target (gaze)"
    Options: ClassVar[type[SolverOptions]] = LookAtOptions
    options: LookAtOptions

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        if pose:
            return "look_at aims an axis at a point; it takes position targets only"
        return None

    def _solve(self, chain: Chain, target: Target, q0: np.ndarray) -> IKResult:
        m, d = chain.model, chain.data
        axis = self.gaze_axis()
        q = q0.copy()
        chain.set_q(q)
        jids, qadr = chain.joint_ids, chain.qpos_adr
        lo, hi = chain.lower, chain.upper
        pd = target.position
        angle = math.pi
        for sweep in range(1, self.options.max_iterations + 1):
            for i in range(chain.n - 1, -1, -1):
                j = jids[i]
                want = pd - chain.position  # the look-at frame's forward column, unnormalised
                fwd = chain.rotation @ axis
                phi = hinge_angle_between(d.xaxis[j], fwd, want)
                q[i] = min(max(q[i] + phi, lo[i]), hi[i])
                d.qpos[qadr[i]] = q[i]
                mujoco.mj_kinematics(m, d)
            angle = gaze_error(chain.position, chain.rotation, axis, pd).angle
            if angle < self.options.rot_tol:
                return self._gaze_result(chain, target, q, sweep)
        return self._gaze_result(chain, target, q, self.options.max_iterations)

    def _gaze_result(self, chain: Chain, target: Target, q: np.ndarray, it: int) -> IKResult:
        chain.set_q(q)
        miss, ang = gaze_error(chain.position, chain.rotation, self.gaze_axis(), target.position)
        ok = ang < self.options.rot_tol
        return IKResult(
            q=q.copy(),
            converged=ok,
            iterations=it,
            position_error=miss,
            orientation_error=ang,
            status=Status.CONVERGED if ok else Status.MAX_ITERATIONS,
            solver=self.name,
            message="" if ok else "the gaze cannot turn far enough within the joint ranges",
        )
