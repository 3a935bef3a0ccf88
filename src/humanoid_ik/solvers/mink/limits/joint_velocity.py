"""Box limits on the displacement of chosen joints in one step."""

from __future__ import annotations

from collections.abc import Sequence

import mink
import mujoco
import numpy as np

__all__ = ["JointVelocityLimit"]


class JointVelocityLimit(mink.Limit):
    """Box limits on the displacement of chosen hinge or slide joints in one step::

        -v_max dt <= dq <= v_max dt      for the chosen joints

    i.e. ``G = [I_S; -I_S]`` ``(2k, nv)`` and ``h = v_max dt`` ``(2k,)`` [rad]. mink's
    ``VelocityLimit`` is the same bound, set per joint by name; this one takes joint ids
    and one ``v_max``. ``G`` is built once; ``h`` is refilled in place.

    Args:
        model: the MuJoCo model.
        joint_ids: hinge or slide joint ids.
        max_velocity: ``v_max`` [rad/s] (or [m/s] for slide joints), one for all.
    """

    def __init__(self, model: mujoco.MjModel, joint_ids: Sequence[int], max_velocity: float):
        dof_adr = model.jnt_dofadr[np.asarray(joint_ids, dtype=np.int64)].astype(np.int64)
        k = len(dof_adr)
        G = np.zeros((2 * k, model.nv))  # (2k, nv)
        G[np.arange(k), dof_adr] = 1.0
        G[k + np.arange(k), dof_adr] = -1.0
        self.G = G
        self.max_velocity = float(max_velocity)
        self._h = np.empty(2 * k)

    def compute_qp_inequalities(
        self, configuration: mink.Configuration, dt: float
    ) -> mink.Constraint:
        """``G dq <= v_max dt`` (the configuration is not read)."""
        del configuration
        if self.G.shape[0] == 0:
            return mink.Constraint()
        self._h.fill(self.max_velocity * dt)
        return mink.Constraint(G=self.G, h=self._h)
