"""Aim a site's (or a body's) forward axis at a point in the world."""

from __future__ import annotations

import math

import mink
import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.measures import GazeError, axis_vector, gaze_error
from humanoid_ik.solvers.mink.tasks.buffered import BufferedTask, check_point

__all__ = ["GazeTask"]


class GazeTask(BufferedTask):
    r"""Point a site's (or a body's) forward axis at a point in the world.

    With ``R`` and ``p`` the site's rotation and position, ``a`` the unit forward axis in
    the site frame and ``p*`` the target point::

        f = R a,  r = p* - p,  n = |r|,  d = r / n
        e(q) = f - d                                    # (3,), |e| = 2 sin(theta / 2)
        J(q) = -[f]x J_w + (I - d d') J_v / n           # (3, nv)

    where ``theta`` is the angle between the axis and the direction to the target and
    ``J_v``, ``J_w`` are the world-frame linear and angular Jacobians of the site
    (``mj_jacSite``; a body's origin: ``mj_jacBody``, for a head limb whose gaze frame
    is its head link, ``core/limbs.py``). ``df = w x f`` gives the first term;
    ``dd = (I - d d') dr / n`` with ``dr = -J_v dq`` the second. The error is mink's
    ``LookAtTask`` error ``a - R' d`` rotated into the world frame: the same norm, hence
    the same gradient ``J' e`` of the QP objective (the Gauss-Newton Hessians differ away
    from alignment); this task reads the site Jacobian once and builds no Lie-group
    objects.
    ``e`` vanishes only when the axis points at the target (not when it points away,
    unlike ``f x d``), and has rank two: roll about the gaze line is left free.

    How far off the gaze is, in the package's one measure, is :meth:`error`
    (:func:`humanoid_ik.core.measures.gaze_error`), not ``|e|``.

    Args:
        model: the MuJoCo model.
        site: name of the gaze site (of the body with ``kind="body"``).
        axis: forward axis in the site frame: ``"x"``, ``"y"``, ``"z"`` or ``(3,)``
            (normalised here).
        cost: weight of the task [1/unit of e], a scalar.
        gain: task gain ``alpha`` in [0, 1].
        lm_damping: Levenberg-Marquardt damping (see ``mink.Task``).
        kind: ``"site"`` or ``"body"``: what ``site`` names.

    Raises:
        TargetError: a zero ``axis``, a bad target.
        KeyError: ``site`` not in the model (callers check names first).
    """

    k: int = 3

    def __init__(
        self,
        model: mujoco.MjModel,
        site: str,
        axis: str | ArrayLike = (1.0, 0.0, 0.0),
        cost: float = 1.0,
        gain: float = 1.0,
        lm_damping: float = 0.0,
        kind: str = "site",
    ):
        super().__init__(cost=np.full(3, float(cost)), gain=gain, lm_damping=lm_damping)
        self.site = site
        self.kind = kind
        self._body = kind == "body"
        self.site_id = int(model.body(site).id if self._body else model.site(site).id)
        self.axis = axis_vector(axis)
        """The unit forward axis ``a`` ``(3,)`` in the site frame."""
        self.target: NDArray[np.float64] | None = None
        self._jac = np.zeros((6, model.nv))  # (6, nv): J_v over J_w
        self._M = np.empty((3, 6))  # [(I - d d') / n, -[f]x]
        self._e = np.empty(3)
        self._J = np.empty((3, model.nv))  # (3, nv)

    def set_target(self, point: ArrayLike) -> None:
        """Look at ``point`` ``(3,)`` [m] in the world frame.

        Raises:
            TargetError: not 3 finite numbers.
        """
        self.target = check_point(point, "gaze target")

    def _forward_and_offset(
        self, d: mujoco.MjData
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The site's forward axis ``f`` in the world and the offset ``target - site`` [m],
        as scalars (the 3-vectors are cheaper in plain floats than in numpy)."""
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        sid = self.site_id
        R = (d.xmat if self._body else d.site_xmat)[sid]
        a0, a1, a2 = self.axis
        f = (
            R[0] * a0 + R[1] * a1 + R[2] * a2,
            R[3] * a0 + R[4] * a1 + R[5] * a2,
            R[6] * a0 + R[7] * a1 + R[8] * a2,
        )
        p, t = (d.xpos if self._body else d.site_xpos)[sid], self.target
        return f, (t[0] - p[0], t[1] - p[1], t[2] - p[2])

    def fill(self, configuration: mink.Configuration) -> None:
        """Fill ``_e`` and ``_J`` at the configuration's kinematics (scalar arithmetic for
        the 3-vectors, one ``(3, 6) @ (6, nv)`` product for the Jacobian)."""
        m, d = configuration.model, configuration.data
        (f0, f1, f2), (r0, r1, r2) = self._forward_and_offset(d)
        n = max(math.sqrt(r0 * r0 + r1 * r1 + r2 * r2), 1e-12)
        d0, d1, d2 = r0 / n, r1 / n, r2 / n
        e = self._e
        e[0], e[1], e[2] = f0 - d0, f1 - d1, f2 - d2
        M = self._M
        M[:, :3] = (
            ((1.0 - d0 * d0) / n, -d0 * d1 / n, -d0 * d2 / n),
            (-d1 * d0 / n, (1.0 - d1 * d1) / n, -d1 * d2 / n),
            (-d2 * d0 / n, -d2 * d1 / n, (1.0 - d2 * d2) / n),
        )
        M[:, 3:] = ((0.0, f2, -f1), (-f2, 0.0, f0), (f1, -f0, 0.0))  # -[f]x
        jac = self._jac
        if self._body:
            mujoco.mj_jacBody(m, d, jac[:3], jac[3:], self.site_id)
        else:
            mujoco.mj_jacSite(m, d, jac[:3], jac[3:], self.site_id)
        np.matmul(M, jac, out=self._J)

    def error(self, configuration: mink.Configuration) -> GazeError:
        """The gaze error (miss [m], angle [rad]) at the configuration's kinematics.

        Raises:
            mink.TargetNotSet: no target yet.
        """
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        d, sid = configuration.data, self.site_id
        if self._body:
            return gaze_error(d.xpos[sid], d.xmat[sid], self.axis, self.target)
        return gaze_error(d.site_xpos[sid], d.site_xmat[sid], self.axis, self.target)
