"""The one module that uses mink beyond its top-level API.

Every other module of :mod:`humanoid_ik.solvers.mink` uses only names that ``mink``
itself exports (``mink.Task``, ``mink.Limit``, ``mink.Configuration``,
``mink.build_ik``, ``mink.FrameTask``, ...) and the public methods and attributes of
those classes. The two names below are not part of that API, so a mink release may
change them without notice:

- ``mink.Task._weighted_residual(error, jacobian)`` (private; in mink 1.2.0 and
  1.3.0, absent before 1.2.0). It returns ``(W J, W e', mu)`` with ``W = diag(cost)``,
  ``e' = -gain e`` and ``mu = lm_damping |W e'|^2``: the task's rows of the stacked
  least-squares objective that ``mink.build_ik`` assembles (``H = sum_i J_i' W_i^2 J_i
  + (damping + sum_i mu_i) I``, ``c = -sum_i (W_i e'_i)' W_i J_i``). Why: our tasks
  (:mod:`~humanoid_ik.solvers.mink.tasks`) compute their error and Jacobian in one pass
  into preallocated buffers and hand them to the QP through mink's public hook
  ``Task.compute_qp_residual`` (mink >= 1.2.0). mink's default implementation of that
  hook calls ``compute_error`` and ``compute_jacobian`` separately, which would run the
  kinematics twice and copy both arrays; calling mink's own weighting keeps one
  definition of how cost, gain and damping enter the QP (mink's) for our tasks and for
  mink's.
- ``mink.limits.collision_avoidance_limit.compute_contact_normal_jacobian`` (public
  name in a submodule, not exported by ``mink`` nor ``mink.limits``; this signature and
  body in 1.1.0 to 1.3.0, before 1.1.0 it took a ``Contact``). It returns the row
  ``n' (J_2 - J_1)`` ``(nv,)`` of one geom pair at the witness points of
  ``mj_geomDistance``, as mink's ``CollisionAvoidanceLimit`` builds it. Why: our
  :class:`~humanoid_ik.solvers.mink.limits.CollisionLimit` uses mink's rows with a
  different bound.

``pyproject.toml`` pins mink to the releases in which these were checked (1.2.0 to
1.3.0, see ``docs/mink.md``), and ``tests/test_mink_ik.py`` compares a whole QP step of
:class:`~humanoid_ik.solvers.mink.UpperBodyIK` with mink's public ``mink.solve_ik``, so
a release that changes either name's meaning fails a test.

This module imports mink (about 0.2 s with qpsolvers and SciPy); it is imported only
when a mink solver is built.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np
from mink.limits import collision_avoidance_limit as _collision_module
from numpy.typing import NDArray

__all__ = ["contact_normal_jacobian", "weighted_residual"]


def weighted_residual(
    task: mink.Task, error: NDArray[np.float64], jacobian: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The task's weighted least-squares rows from its error and Jacobian.

    With ``W = diag(task.cost)``, ``alpha = task.gain`` and ``lambda = task.lm_damping``::

        W J                       # (k, nv) weighted Jacobian
        W (-alpha e)              # (k,)    weighted error
        mu = lambda |W alpha e|^2 # scalar Levenberg-Marquardt term (added to H's diagonal)

    Args:
        task: a ``mink.Task`` (its ``cost``, ``gain`` and ``lm_damping`` are read).
        error: the task error ``e`` ``(k,)``.
        jacobian: its Jacobian ``J = de/dq`` ``(k, nv)``.

    Returns:
        ``(W J, -alpha W e, mu)``, new arrays (the buffers passed in are not kept).
    """
    return task._weighted_residual(error, jacobian)


def contact_normal_jacobian(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    geom1: int,
    geom2: int,
    fromto: NDArray[np.float64],
    scratch: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
) -> NDArray[np.float64]:
    """The change of a geom pair's separation per unit joint displacement.

    With ``p_1``, ``p_2`` the witness points ``fromto`` of ``mj_geomDistance`` (on geom 1
    and geom 2), ``n = (p_2 - p_1) / |p_2 - p_1|`` and ``J_1``, ``J_2`` the world-frame
    translational Jacobians ``(3, nv)`` of those points on their bodies::

        row = n' (J_2 - J_1)      # (nv,) [m/rad]

    Args:
        model: the MuJoCo model.
        data: data with the kinematics at the current pose.
        geom1: id of the first geom.
        geom2: id of the second geom.
        fromto: ``(6,)`` witness points from ``mj_geomDistance`` [m].
        scratch: ``(normal (3,), jac1 (3, nv), jac2 (3, nv))`` buffers, overwritten.

    Returns:
        The row ``(nv,)`` (a new array).
    """
    normal, jac1, jac2 = scratch
    row: NDArray[np.float64] = _collision_module.compute_contact_normal_jacobian(
        model, data, geom1, geom2, fromto, normal, jac1, jac2
    )
    return row
