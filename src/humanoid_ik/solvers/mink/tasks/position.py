"""A plain Cartesian position task for a site or a body origin."""

from __future__ import annotations

import mink
import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.solvers.mink.tasks.buffered import BufferedTask, check_point

__all__ = ["PositionTask"]


class PositionTask(BufferedTask):
    """Move a site or body origin onto a point, in the world frame::

        e(q) = p(q) - p*       # (3,) [m]
        J(q) = J_v(q)          # (3, nv) [m/rad], mj_jacSite / mj_jacBody

    A position-only ``mink.FrameTask`` measures its error with the SE(3) logarithm,
    whose translation part depends on the frame's rotation relative to the target's,
    so even with the orientation cost at zero the wrist takes part in reducing it. This
    task is the plain Cartesian error: only the site's position counts.

    Args:
        model: the MuJoCo model.
        name: site or body name.
        kind: ``"site"`` or ``"body"``.
        cost: weight [1/m], a scalar.
        gain: task gain ``alpha`` in [0, 1].
        lm_damping: Levenberg-Marquardt damping (see ``mink.Task``).
    """

    k: int = 3

    def __init__(
        self,
        model: mujoco.MjModel,
        name: str,
        kind: str = "site",
        cost: float = 1.0,
        gain: float = 1.0,
        lm_damping: float = 0.0,
    ):
        super().__init__(cost=np.full(3, float(cost)), gain=gain, lm_damping=lm_damping)
        self.kind = kind
        self.obj_id = int(model.site(name).id if kind == "site" else model.body(name).id)
        self.target: NDArray[np.float64] | None = None
        self._J = np.zeros((3, model.nv))  # J_v itself, filled by mj_jacSite / mj_jacBody
        self._e = np.empty(3)

    def set_target(self, point: ArrayLike) -> None:
        """Reach ``point`` ``(3,)`` [m] in the world frame.

        Raises:
            TargetError: not 3 finite numbers.
        """
        self.target = check_point(point, "position target")

    def fill(self, configuration: mink.Configuration) -> None:
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        m, d = configuration.model, configuration.data
        if self.kind == "site":
            np.subtract(d.site_xpos[self.obj_id], self.target, out=self._e)
            mujoco.mj_jacSite(m, d, self._J, None, self.obj_id)
        else:
            np.subtract(d.xpos[self.obj_id], self.target, out=self._e)
            mujoco.mj_jacBody(m, d, self._J, None, self.obj_id)
