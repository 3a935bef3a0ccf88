"""The QP of one set of active effectors, and one step of it.

With ``S`` the dofs of the active chains (those of the effectors that have a target)
and ``F`` every other dof, one step of duration ``dt`` [s] finds the displacement ``dq``
``(nv,)`` [rad] solving::

    min  sum_tasks |W_i (J_i dq + alpha_i e_i)|^2 + (damping + sum_i mu_i) |dq|^2
    s.t. range_gain (q_min - q) <= dq_S <= range_gain (q_max - q)  (JointRangeLimit)
         |dq_S| <= v_max dt                                          (JointVelocityLimit)
         -n' (J_2 - J_1) dq <= gain_c (d - d_min)    pairs nearer than d_detect (CollisionLimit)
         dq_F = 0                                    (frozen)

The objective and the inequality rows are assembled by ``mink.build_ik`` (mink's one
definition of how tasks and limits enter the QP); ``dq_F = 0`` is then substituted
instead of being handed to the solver as equality rows (what ``mink.DofFreezingTask``
would add): the QP solved has the ``|S|`` active dofs only, ``H_SS``, ``c_S``,
``G[:, S]``, the same minimiser (``tests/test_mink_ik.py`` compares the step with
``mink.solve_ik`` and a ``DofFreezingTask``). daqp (the default) is called directly,
other qpsolvers backends through ``qpsolvers.solve_qp``. Only the joints in ``S`` are
integrated, so the frozen ones keep their values bit for bit. ``dq = 0`` satisfies
every constraint once the active joints are inside their ranges
(:meth:`QPStep.__call__` moves them there first; frozen joints have no range row;
velocity and collision bounds are >= 0), so the QP is never infeasible.

Where the time of a step goes (bundled right arm, pose target, about 100 us in all
before this reduction): ``mink.build_ik`` about 45 %, qpsolvers' conversion and daqp on
the full ``nv``-dof problem with the frozen dofs as equality rows about 25 %, the rest
clipping and kinematics. ``benchmarks/mink_step.py`` measures the step against a plain
``mink.solve_ik`` loop with the same tasks and limits.

This module imports mink; :class:`~humanoid_ik.solvers.mink.UpperBodyIK` imports it on
first use.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import daqp
import mink
import mujoco
import numpy as np
import qpsolvers
from numpy.typing import NDArray

from humanoid_ik.solvers.mink.limits import CollisionLimit, JointRangeLimit
from humanoid_ik.solvers.mink.options import MinkOptions

__all__ = ["HALVINGS", "ActiveKey", "Problem", "QPStep", "build_problem"]

ActiveKey = tuple[tuple[str, bool], ...]
"""``(effector name, pose target?)`` per effector with a target, in effector order."""
HALVINGS = 6
"""How many times a step that brings a collision pair too close is halved before it is
dropped."""


@dataclass(frozen=True)
class Problem:
    """Tasks, limits and frozen dofs of one set of active effectors (built once per key).

    Attributes:
        key: the active effectors.
        tasks: their tasks, then the posture task.
        limits: the range limit of the active joints, then the shared velocity and
            collision limits.
        qpos_adr: ``qpos`` addresses of the active joints ``(k,)``.
        dof_adr: their dof addresses ``(k,)``.
        lower: their lower range ends ``(k,)`` [rad] (``-inf`` when unlimited).
        upper: their upper range ends ``(k,)`` [rad] (``+inf`` when unlimited).
    """

    key: ActiveKey
    tasks: list[mink.Task]
    limits: list[mink.Limit]
    qpos_adr: NDArray[np.int64]
    dof_adr: NDArray[np.int64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]


def build_problem(
    model: mujoco.MjModel,
    key: ActiveKey,
    joint_ids: Sequence[int],
    tasks: Sequence[mink.Task],
    shared_limits: Sequence[mink.Limit],
    range_gain: float,
) -> Problem:
    """The problem of the effectors in ``key``.

    Args:
        model: the MuJoCo model.
        key: the active effectors.
        joint_ids: the active chains' joint ids (hinge or slide), sorted.
        tasks: the tasks, in QP order.
        shared_limits: limits used by every problem (velocity, collision).
        range_gain: the range limit's gain in (0, 1].
    """
    jids = np.asarray(joint_ids, dtype=np.int64)
    dof = model.jnt_dofadr[jids].astype(np.int64)
    limited = model.jnt_limited[jids].astype(bool)
    return Problem(
        key=key,
        tasks=list(tasks),
        limits=[JointRangeLimit(model, list(joint_ids), range_gain), *shared_limits],
        qpos_adr=model.jnt_qposadr[jids].astype(np.int64),
        dof_adr=dof,
        lower=np.where(limited, model.jnt_range[jids, 0], -np.inf),
        upper=np.where(limited, model.jnt_range[jids, 1], np.inf),
    )


class QPStep:
    """One QP step of a :class:`Problem` on a ``mink.Configuration``.

    Args:
        configuration: the configuration stepped (its ``qpos`` is changed in place).
        options: the solver's options; ``damping``, ``qp_solver``, ``max_velocity``
            [rad/s] and ``min_distance`` [m] are read at every step.
        collision: the collision limit checked after each step, or ``None``.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        options: MinkOptions,
        collision: CollisionLimit | None,
    ):
        self.configuration = configuration
        self.options = options
        self.collision = collision
        self.dq = np.zeros(configuration.model.nv)
        """The displacement ``(nv,)`` [rad] the last QP returned (zeros if none)."""
        self._dist = np.empty(0 if collision is None else len(collision.geom_id_pairs))

    def __call__(self, prob: Problem, dt: float) -> bool:
        """Step ``dt`` [s]: solve the QP, integrate the active joints. False if the QP
        solver found no solution (nothing moves then).

        The QP meets its bounds to the solver's tolerance (about 1e-6 for daqp), so the
        step is clipped to the velocity limit and the ranges, which then hold exactly.
        With collision pairs, a step after which some pair is closer than
        ``min(its distance before, min_distance / 2)`` (the linearised row missed a
        second-order loss) is halved, up to :data:`HALVINGS` times, then dropped.
        """
        cfg, o = self.configuration, self.options
        qpos = cfg.data.qpos
        q_act = qpos[prob.qpos_adr]
        if ((q_act < prob.lower) | (q_act > prob.upper)).any():
            np.clip(q_act, prob.lower, prob.upper, out=q_act)
            qpos[prob.qpos_adr] = q_act
            cfg.update()
        x = self._solve_active(prob, dt)
        self.dq[:] = 0.0
        if x is None:
            return False
        self.dq[prob.dof_adr] = x
        vmax = o.max_velocity * dt
        step = np.clip(x, -vmax, vmax)
        q_new = q_act + step
        np.clip(q_new, prob.lower, prob.upper, out=q_new)
        qpos[prob.qpos_adr] = q_new
        cfg.update()
        if self.collision is not None:
            self._back_off(prob, q_act, step, q_new)
        return True

    def _solve_active(self, prob: Problem, dt: float) -> NDArray[np.float64] | None:
        """The QP's minimiser over the active dofs ``(k,)`` with the frozen ones at 0, or
        ``None`` when the solver finds none."""
        o, dofs = self.options, prob.dof_adr
        qp = mink.build_ik(self.configuration, prob.tasks, dt, o.damping, prob.limits)
        H = qp.P[np.ix_(dofs, dofs)]
        c = qp.q[dofs]
        if qp.G is None or qp.h is None:
            G, h = np.zeros((0, dofs.size)), np.zeros(0)
        else:
            G, h = qp.G[:, dofs], qp.h
        if o.qp_solver != "daqp":
            rows = h.size > 0
            x = qpsolvers.solve_qp(
                H, c, G if rows else None, h if rows else None, solver=o.qp_solver
            )
            return None if x is None else np.asarray(x, dtype=np.float64)
        x, _, exitflag, _ = daqp.solve(
            H, c, G, h, np.full(h.size, -1e30), np.zeros(h.size, np.intc)
        )
        return np.asarray(x, dtype=np.float64) if exitflag > 0 else None

    def _back_off(
        self,
        prob: Problem,
        q_act: NDArray[np.float64],
        step: NDArray[np.float64],
        q_new: NDArray[np.float64],
    ) -> None:
        """Halve the step (in place) while a collision pair ends too close; drop it
        after :data:`HALVINGS` halvings."""
        coll, cfg = self.collision, self.configuration
        assert coll is not None
        qpos, dist = cfg.data.qpos, self._dist
        floor = np.minimum(coll.last_distances, 0.5 * self.options.min_distance)
        floor -= 1e-9
        for _ in range(HALVINGS):
            if np.all(coll.distances(cfg.data, dist) >= floor):
                return
            step *= 0.5
            np.add(q_act, step, out=q_new)
            np.clip(q_new, prob.lower, prob.upper, out=q_new)
            qpos[prob.qpos_adr] = q_new
            cfg.update()
        if np.all(coll.distances(cfg.data, dist) >= floor):
            return
        qpos[prob.qpos_adr] = q_act
        cfg.update()
