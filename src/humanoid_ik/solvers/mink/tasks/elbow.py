"""A low-weight task turning an arm's elbow toward its pole's plane (``Target.pole``)."""

from __future__ import annotations

import mink
import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.solvers.analytic.elbow import elbow_frame
from humanoid_ik.solvers.mink.tasks.buffered import BufferedTask, check_point

__all__ = ["ElbowTask"]


class ElbowTask(BufferedTask):
    """Move the elbow point (the arm's elbow hinge anchor,
    :mod:`~humanoid_ik.solvers.analytic.elbow`) into the half-plane of the pole about
    the shoulder-wrist line, at its distance from the line::

        e(q) = E(q) - (S + ((E - S) . u) u + |E - S|_perp b)   # (3,) [m]
        J(q) = J_E(q)                                          # (3, nv), mj_jac at E

    with ``u`` the unit shoulder-wrist line and ``b`` the unit part of ``pole - S``
    normal to it: the goal is the elbow turned about the line onto the pole's side,
    read again at every step (the line moves with the arm). Zero where the arm is
    straight or the pole lies on the line. A secondary task: its cost is low
    (``MinkOptions.pole_cost``), so the hand tasks win where both cannot be met.

    Args:
        model: the MuJoCo model.
        chain: the arm's chain (on ``model``).
        cost: weight [1/m], a scalar.
    """

    k: int = 3

    def __init__(self, model: mujoco.MjModel, chain: Chain, cost: float = 0.1):
        super().__init__(cost=np.full(3, float(cost)), gain=1.0, lm_damping=0.0)
        self.chain = chain
        self.frame = elbow_frame(chain)
        self.body = int(model.jnt_bodyid[int(chain.joint_ids[self.frame.elbow])])
        self.pole: NDArray[np.float64] | None = None
        self._J = np.zeros((3, model.nv))
        self._e = np.zeros(3)

    def set_pole(self, pole: ArrayLike) -> None:
        """Point the elbow toward ``pole`` ``(3,)`` [m] (world).

        Raises:
            TargetError: not 3 finite numbers.
        """
        self.pole = check_point(pole, "elbow pole")

    def fill(self, configuration: mink.Configuration) -> None:
        if self.pole is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        m, d = configuration.model, configuration.data
        S, E, W = self.frame.points(self.chain, d)
        line = W - S
        u = line / max(float(np.linalg.norm(line)), 1e-12)
        up = E - S
        perp = up - float(up @ u) * u
        p = self.pole - S
        p = p - float(p @ u) * u
        r, rp = float(np.linalg.norm(perp)), float(np.linalg.norm(p))
        if r < 1e-9 or rp < 1e-9:
            self._e[:] = 0.0
            self._J[:] = 0.0
            return
        np.subtract(perp, r / rp * p, out=self._e)
        mujoco.mj_jac(m, d, self._J, None, E, self.body)
