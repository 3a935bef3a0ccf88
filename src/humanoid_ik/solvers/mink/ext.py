"""mink extensions used by the ``mink`` solver: position and gaze tasks, range and velocity
limits on chosen joints, and a collision limit in displacement form.

This module imports mink (and through it qpsolvers and SciPy, about 0.2 s), so
:mod:`humanoid_ik.solvers.mink.solver` imports it only when a mink solver is built.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mink
import mujoco
import numpy as np
from mink.limits.collision_avoidance_limit import (
    compute_contact_normal_jacobian as _contact_normal_jacobian,
)
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.measures import GazeError, axis_vector, gaze_error
from humanoid_ik.errors import TargetError

__all__ = ["PositionTask", "GazeTask", "JointRangeLimit", "JointVelocityLimit", "CollisionLimit"]


class _BufferedTask(mink.Task):
    """A task whose ``_update(configuration)`` fills the buffers ``_e`` ``(k,)`` and ``_J``
    ``(k, nv)`` at the configuration's kinematics; the mink interface reads them."""

    _e: NDArray[np.float64]
    _J: NDArray[np.float64]

    def _update(self, configuration: mink.Configuration) -> None:
        raise NotImplementedError

    def compute_error(self, configuration: mink.Configuration) -> NDArray[np.float64]:
        """The task error ``e`` ``(k,)`` (a copy)."""
        self._update(configuration)
        return self._e.copy()

    def compute_jacobian(self, configuration: mink.Configuration) -> NDArray[np.float64]:
        """The task Jacobian ``J = de/dq`` ``(k, nv)`` (a copy)."""
        self._update(configuration)
        return self._J.copy()

    def compute_qp_residual(
        self, configuration: mink.Configuration
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        self._update(configuration)
        return self._weighted_residual(self._e, self._J)

    def compute_qp_objective(self, configuration: mink.Configuration) -> mink.Objective:
        self._update(configuration)
        return self._assemble_qp(self._e, self._J, configuration._eye_nv)


class PositionTask(_BufferedTask):
    """Move a site or body origin onto a point, in the world frame::

        e(q) = p - p*          # (3,) [m]
        J(q) = J_v             # (3, nv), mj_jacSite / mj_jacBody

    A position-only ``mink.FrameTask`` measures its error with the SE(3) logarithm,
    whose translation part depends on the frame's rotation relative to the target's,
    so even with the orientation cost at zero the wrist takes part in reducing it. This
    task is the plain Cartesian error: only the site's position counts.

    Args:
        model: the MuJoCo model.
        name: site or body name.
        kind: ``"site"`` or ``"body"``.
        cost: weight [1/m], a scalar.
        gain: task gain in [0, 1].
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
        self._jacp = np.zeros((3, model.nv))  # (3, nv)
        self._J = self._jacp  # the task Jacobian is J_v itself
        self._e = np.empty(3)

    def set_target(self, point: ArrayLike) -> None:
        """Reach ``point`` ``(3,)`` [m] in the world frame.

        Raises:
            TargetError: not 3 finite numbers.
        """
        p = np.asarray(point, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise TargetError(
                f"position target must be 3 finite numbers, got {np.asarray(point)!r}"
            )
        self.target = p.copy()

    def _update(self, configuration: mink.Configuration) -> None:
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        m, d = configuration.model, configuration.data
        if self.kind == "site":
            np.subtract(d.site_xpos[self.obj_id], self.target, out=self._e)
            mujoco.mj_jacSite(m, d, self._jacp, None, self.obj_id)
        else:
            np.subtract(d.xpos[self.obj_id], self.target, out=self._e)
            mujoco.mj_jacBody(m, d, self._jacp, None, self.obj_id)


class GazeTask(_BufferedTask):
    r"""Point a site's forward axis at a point in the world.

    With ``R`` and ``p`` the site's rotation and position, ``a`` the unit forward axis in
    the site frame and ``p*`` the target point::

        f = R a,  r = p* - p,  n = |r|,  d = r / n
        e(q) = f - d                                    # (3,), |e| = 2 sin(theta / 2)
        J(q) = -[f]x J_w + (I - d d') J_v / n           # (3, nv)

    where ``theta`` is the angle between the axis and the direction to the target and
    ``J_v``, ``J_w`` are the world-frame linear and angular Jacobians of the site
    (``mj_jacSite``). ``df = w x f`` gives the first term; ``dd = (I - d d') dr / n``
    with ``dr = -J_v dq`` the second. The error is mink's ``LookAtTask`` error
    ``a - R' d`` rotated into the world frame: the same norm, hence the same gradient
    ``J' e`` of the QP objective (the Gauss-Newton Hessians differ away from alignment);
    this task reads the site Jacobian once and builds no Lie-group objects.
    ``e`` vanishes only when the axis points at the target (not when it points away,
    unlike ``f x d``), and has rank two: roll about the gaze line is left free.

    Args:
        model: the MuJoCo model.
        site: name of the gaze site.
        axis: forward axis ``(3,)`` in the site frame (normalised here).
        cost: weight of the task [1/unit of e], a scalar.
        gain: task gain in [0, 1].
        lm_damping: Levenberg-Marquardt damping (see ``mink.Task``).

    Raises:
        TargetError: a zero ``axis``, a bad target.
        KeyError: ``site`` not in the model (callers check names first).
    """

    k: int = 3

    def __init__(
        self,
        model: mujoco.MjModel,
        site: str,
        axis: ArrayLike = (1.0, 0.0, 0.0),
        cost: float = 1.0,
        gain: float = 1.0,
        lm_damping: float = 0.0,
    ):
        super().__init__(cost=np.full(3, float(cost)), gain=gain, lm_damping=lm_damping)
        self.site = site
        self.site_id = int(model.site(site).id)
        self.axis = axis_vector(axis)
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
        p = np.asarray(point, dtype=np.float64)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise TargetError(f"gaze target must be 3 finite numbers, got {np.asarray(point)!r}")
        self.target = p.copy()

    def _forward_and_offset(
        self, d: mujoco.MjData
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """The site's forward axis ``f`` in the world and the offset ``target - site`` [m],
        as scalars (the 3-vectors are cheaper in plain floats than in numpy)."""
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        sid = self.site_id
        R = d.site_xmat[sid]
        a0, a1, a2 = self.axis
        f = (
            R[0] * a0 + R[1] * a1 + R[2] * a2,
            R[3] * a0 + R[4] * a1 + R[5] * a2,
            R[6] * a0 + R[7] * a1 + R[8] * a2,
        )
        p, t = d.site_xpos[sid], self.target
        return f, (t[0] - p[0], t[1] - p[1], t[2] - p[2])

    def _update(self, configuration: mink.Configuration) -> None:
        """Fill ``_e`` and ``_J`` at the configuration's kinematics (scalar arithmetic for
        the 3-vectors, one ``(3, 6) @ (6, nv)`` product for the Jacobian)."""
        m, d = configuration.model, configuration.data
        sid = self.site_id
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
        mujoco.mj_jacSite(m, d, jac[:3], jac[3:], sid)
        np.matmul(M, jac, out=self._J)

    def error(self, configuration: mink.Configuration) -> GazeError:
        """The gaze error (:func:`humanoid_ik.core.measures.gaze_error`) at the
        configuration's kinematics."""
        if self.target is None:
            raise mink.TargetNotSet(self.__class__.__name__)
        d = configuration.data
        return gaze_error(
            d.site_xpos[self.site_id], d.site_xmat[self.site_id], self.axis, self.target
        )


class JointRangeLimit(mink.Limit):
    """Box limits on chosen hinge or slide joints only::

        gain (q_min - q) <= dq <= gain (q_max - q)      for the chosen joints

    Joints left out (those the solver freezes) get no row, so a frozen joint outside
    its range cannot make the QP infeasible. Unlimited joints get no row either.
    ``G`` is built once; ``h`` is refilled in place.

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
        del dt  # a position limit
        if self.G.shape[0] == 0:
            return mink.Constraint()
        k = self.G.shape[0] // 2
        q = configuration.data.qpos[self.qpos_adr]
        h = self._h
        np.subtract(self.upper, q, out=h[:k])
        np.subtract(q, self.lower, out=h[k:])
        h *= self.gain
        return mink.Constraint(G=self.G, h=h)


class CollisionLimit(mink.CollisionAvoidanceLimit):
    """mink's collision avoidance limit with its bound in displacement form.

    Each pair closer than ``collision_detection_distance`` adds the row::

        -n' (J_2 - J_1) dq <= gain (d - d_min)      (0 when d <= d_min)

    the distance ``d`` along the contact normal ``n`` (from ``mj_geomDistance``) may
    shrink by at most ``gain`` times its margin over ``d_min`` in one step. mink 1.3
    divides that bound by ``dt`` although ``dq`` is a displacement, which lets geoms
    close ``1 / dt`` times faster at small steps; here the bound holds whatever the
    frame rate. Pairs are chosen as in mink (same body, parent and child, and
    contype/conaffinity filtered out); the rows use mink's contact normal Jacobian.

    The row is the distance's first-order change; a step that slides a geom along a
    curved surface loses distance at second order. :meth:`distances` measures every
    pair after a step so the caller can shorten it (see ``UpperBodyIK``).
    """

    def __init__(self, model: mujoco.MjModel, geom_pairs, **kwargs):
        super().__init__(model, geom_pairs, **kwargs)
        n = len(self.geom_id_pairs)
        self._pairs = np.array(self.geom_id_pairs, dtype=np.int64).reshape(n, 2)
        self._G = np.zeros((n, model.nv))  # (pairs, nv)
        self._h = np.empty(n)
        self.last_distances = np.full(n, np.inf)
        """Distance [m] of every pair (capped at the detection distance) at the last
        :meth:`compute_qp_inequalities`."""

    def distances(self, data: mujoco.MjData, out: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fill ``out`` ``(pairs,)`` with each pair's distance [m], capped at the detection
        distance (negative when the geoms overlap)."""
        m, ft, cap = self.model, self._fromto, self.collision_detection_distance
        for i, (g1, g2) in enumerate(self.geom_id_pairs):
            out[i] = mujoco.mj_geomDistance(m, data, g1, g2, cap, ft)
        return out

    def compute_qp_inequalities(
        self, configuration: mink.Configuration, dt: float
    ) -> mink.Constraint:
        del dt  # the bound is a displacement
        m, data = self.model, configuration.data
        G, h, dist_out = self._G, self._h, self.last_distances
        G.fill(0.0)
        h.fill(np.inf)
        cap, dmin, gain = (
            self.collision_detection_distance,
            self.minimum_distance_from_collisions,
            self.gain,
        )
        ft, normal, jac1, jac2 = self._fromto, self._normal, self._jac1, self._jac2
        for i, (g1, g2) in enumerate(self.geom_id_pairs):
            dist = mujoco.mj_geomDistance(m, data, g1, g2, cap, ft)
            dist_out[i] = dist
            if abs(dist - cap) < 1e-12:
                continue
            row = _contact_normal_jacobian(m, data, g1, g2, ft, normal, jac1, jac2)
            h[i] = (gain * (dist - dmin) if dist > dmin else 0.0) + self.bound_relaxation
            G[i] = -row if dist >= 0 else row
        return mink.Constraint(G=G, h=h)


class JointVelocityLimit(mink.Limit):
    """Box limits on the displacement of chosen hinge or slide joints in one step::

        -v_max dt <= dq <= v_max dt      for the chosen joints

    ``G`` is built once; ``h`` is refilled in place.

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
        del configuration
        if self.G.shape[0] == 0:
            return mink.Constraint()
        self._h.fill(self.max_velocity * dt)
        return mink.Constraint(G=self.G, h=self._h)
