"""Box limits on the position of chosen joints."""

from __future__ import annotations

from collections.abc import Sequence

import mink
import mujoco
import numpy as np

__all__ = ["JointRangeLimit"]


class JointRangeLimit(mink.Limit):
    """Box limits on chosen hinge or slide joints only::

        gain (q_min - q) <= dq <= gain (q_max - q)      for the chosen joints

    i.e. ``G = [I_S; -I_S]`` ``(2k, nv)`` (``I_S`` the rows of the identity at the
    chosen joints' dofs) and ``h = gain [q_max - q; q - q_min]`` ``(2k,)`` [rad].

    Joints left out (those the solver freezes) get no row, so a frozen joint outside
    its range cannot make the QP infeasible (mink's ``ConfigurationLimit`` covers every
    limited joint). Unlimited joints get no row either. ``G`` is built once; ``h`` is
    refilled in place.

    Args:
        model: the MuJoCo model.
        joint_ids: hinge or slide joint ids.
        gain: fraction in (0, 1] of the distance to a range end a step may cover.
    """

    def __init__(self, model: mujoco.MjModel, joint_ids: Sequence[int], gain: float = 0.95):
        ids = [int(j) for j in joint_ids if model.jnt_limited[j]]
        self.joint_ids = np.array(ids, dtype=np.int64)
        self.qpos_adr = model.jnt_qposadr[self.joint_ids].astype(np.int64)
        dof_adr = model.jnt_dofadr[self.joint_ids].astype(np.int64)
        self.lower = model.jnt_range[self.joint_ids, 0].copy()
        self.upper = model.jnt_range[self.joint_ids, 1].copy()
        self.gain = float(gain)
        k = len(ids)
        G = np.zeros((2 * k, model.nv))  # (2k, nv)
        G[np.arange(k), dof_adr] = 1.0
        G[k + np.arange(k), dof_adr] = -1.0
        self.G = G
        self._h = np.empty(2 * k)

    def compute_qp_inequalities(
        self, configuration: mink.Configuration, dt: float
    ) -> mink.Constraint:
        """``G dq <= h`` at the configuration's ``q`` (``dt`` unused: a position limit)."""
        del dt
        if self.G.shape[0] == 0:
            return mink.Constraint()
        k = self.G.shape[0] // 2
        q = configuration.data.qpos[self.qpos_adr]
        h = self._h
        np.subtract(self.upper, q, out=h[:k])
        np.subtract(q, self.lower, out=h[k:])
        h *= self.gain
        return mink.Constraint(G=self.G, h=h)
