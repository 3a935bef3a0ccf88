"""Levenberg-Marquardt with error-adaptive damping and joint ranges as box constraints.

Each iteration minimises the damped, weighted linearised error over the joint step
``dq`` inside the joint ranges::

    min  1/2 dq' (J' W J + lambda I) dq - (J' W e)' dq
    s.t. lower - q <= dq <= upper - q

with ``e`` the task error (:func:`~humanoid_ik.core.measures.pose_error`: 3 rows for a
position target, 6 for a pose), ``W = diag(1, 1, 1, w, w, w)`` and ``w`` the square of
``orientation_weight`` [m/rad] (one radian weighs as that many metres), and the damping
``lambda = error_damping * E + min_damping`` with ``E = e' W e / 2`` (Sugihara 2011;
Chan and Lawrence's error-damped rule is ``min_damping = 0``). Far from the target the
damping makes the step a short gradient step; near it the step is the Gauss-Newton
step and convergence is quadratic; no step cap is needed (on the bundled arm and the
``models/robot`` arm a cap of 0.8 rad per joint never bound).

The box is solved by MuJoCo's ``mju_boxQP`` (a projected Newton method on the
``n x n`` system), written for ``x = q + dq`` between the fixed ``lower`` and ``upper``
and warm-started at ``q``, in place in ``qpos`` where the chain's joints follow each
other there. A joint at a range end leaves the step and the others are re-solved
without it: the step never stalls against a limit it could slide along, and every
iterate is inside the ranges by construction.

Per iteration the path is one ``mj_kinematics``, the error from the site's position and
its body's quaternion and rotation (the target orientation is moved into the body's
frame once per solve), one ``mj_comPos`` + ``mj_jacSite`` (``mj_jacBody`` for a body
end effector), ``J' W J`` and ``J' W e`` by MuJoCo's ``mju_sqrMatTD`` /
``mju_mulMatTVec`` on preallocated buffers, and the box QP: no Python loop over joints.
The Jacobian from MuJoCo is cheaper than the chain's own columns ``axis x (p - anchor)``
in numpy (see ``docs/lm.md`` for the figures).

That loop runs in C where it is built (:mod:`.lm_loop`, ``_lm_loop.c``: one call from
Python per start, the same MuJoCo calls in the same order, the same answers bit for
bit); ``LM._descend`` is the same loop in Python, the reference and the fallback
(:attr:`LM.compiled`). From Python an iteration costs 3.2-5 times MuJoCo's FK +
Jacobian call, in C 0.4-0.7 times it (``benchmarks/floor.py``).

A start that stalls (less than 1 % progress of ``E`` in ``stall_window`` iterations) or
reaches ``max_iterations`` is followed by the next start, up to ``restarts``: the seed
library's poses nearest the target alternating with seeded random in-range poses
(:func:`~humanoid_ik.solvers.jacobian.seeds.restart_poses`). The first start is ``q0``,
the chain's current joints unless given: tracking a moving target warm-starts from
the previous answer.

Caches: the solver keeps its work buffers for the last chain and task size (rows 3 or
6) it solved, rebuilt when another chain object (identity) or task size comes; the
buffers hold views of the chain's scratch data and no value from one solve to the next
(the ranges from the chain and the site's placement on its body from the last
kinematics pass are read on every solve, so a model changed in place is followed as
:meth:`Chain.sync` follows it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.jacobian import lm_loop
from humanoid_ik.solvers.jacobian.loop import OPTION_BOUNDS
from humanoid_ik.solvers.jacobian.seeds import restart_poses, seed_library
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["LM", "LMOptions"]


@dataclass(frozen=True)
class LMOptions(SolverOptions):
    """Options of ``lm``.

    Attributes:
        max_iterations: iterations per start.
        restarts: further starts after a stall (seed-library poses, random poses).
        stall_window: iterations without a 1 % gain that count as a stall.
        seed: seed of the random restarts.
        library_seeds: seed-library poses nearest the target among the restarts.
        orientation_weight: length [m] that one radian of orientation error weighs as.
        error_damping: ``c`` in ``lambda = c E + min_damping``, ``E = e' W e / 2``
            [m^2] (``c`` has no unit: ``J' W J`` is in [m^2] per rad^2).
        min_damping: ``lambda`` at zero error [m^2]. The defaults (0.1, 1e-6 and an
            ``orientation_weight`` of 0.5 m/rad) were the fastest at full success in
            ``benchmarks/lm_damping.py`` (see ``docs/lm.md``).
    """

    max_iterations: int = 50
    restarts: int = 20
    stall_window: int = 4
    seed: int = 0
    library_seeds: int = 8
    orientation_weight: float = 0.5
    error_damping: float = 0.1
    min_damping: float = 1e-6
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        **{k: OPTION_BOUNDS[k] for k in ("max_iterations", "restarts", "library_seeds")},
        "stall_window": (2, 100_000),
        "orientation_weight": (0.0, 100.0),
        "error_damping": (0.0, 1e6),
        "min_damping": (1e-12, 1.0),
    }
    """A ``min_damping`` above 0 keeps the system positive definite; the upper bounds
    keep a solve finite in time."""


class _Work:
    """Buffers of one (chain, task size): what an iteration writes, allocated once."""

    def __init__(self, chain: Chain, rows: int, weight: float):
        m, d, n = chain.model, chain.data, chain.n
        self.chain, self.rows = chain, rows
        self.wr = weight * weight
        self.w = np.ones(rows)
        self.w[3:] = self.wr
        site = chain.ee_kind == "site"
        body = int(m.site_bodyid[chain.ee_id]) if site else chain.ee_id
        self.xpos = d.site_xpos[chain.ee_id] if site else d.xpos[chain.ee_id]
        # the orientation is read from the body's quaternion and rotation, with the
        # target moved into the body's frame once per solve (no mju_mat2Quat per step)
        self.body_quat, self.body_mat = d.xquat[body], d.xmat[body]
        self.site_mat = d.site_xmat[chain.ee_id] if site else None
        self.quats = np.empty((2, 4))  # scratch of the per-solve target conversion
        self.target_body = np.empty(4)  # the body's orientation that puts the site on target
        self.jac_fn = mujoco.mj_jacSite if site else mujoco.mj_jacBody
        e = self.e = np.zeros(rows)  # minus the weighted error, -W e
        self.e_p, self.e_r = e[:3], e[3:]
        self.q_err = np.empty(3)
        self.jac = chain._jac[:rows]  # (rows, nv): C-contiguous rows of the chain's buffer
        sl = chain._dof_slice
        whole = sl is not None and sl.start == 0 and sl.stop == m.nv
        self.J = self.jac if whole else np.empty((rows, n))  # (rows, n), C-contiguous
        self.jac_cols = None if whole or sl is None else self.jac[:, sl]
        self.H = np.empty((n, n))
        self.H_flat = self.H.reshape(-1)
        self.eye = np.eye(n).reshape(-1)
        self.g = np.empty(n)
        self.Hx = np.empty(n)
        self.R = np.empty((n, n + 7))
        adr = chain.qpos_adr
        contiguous = bool(np.all(np.diff(adr) == 1))
        self.qpos_view = d.qpos[int(adr[0]) : int(adr[-1]) + 1] if contiguous else None
        self.native: lm_loop.Problem | None = None

    def compile(self, options: LMOptions) -> None:
        """Set up the compiled loop on these buffers (:mod:`.lm_loop`)."""
        chain, n, d = self.chain, self.chain.n, self.chain.data
        self.target_pos = np.empty(3)
        self.ranges = (chain.lower, chain.upper)
        J = self.J if self.J.flags.c_contiguous else np.empty((self.rows, n))
        arrays = {
            "qadr": chain.qpos_adr, "dof": chain.dof_adr, "qpos": d.qpos, "xpos": self.xpos,
            "body_quat": self.body_quat, "body_mat": self.body_mat,
            "target_pos": self.target_pos, "target_body": self.target_body, "jac": chain._jac,
            "J": J, "w": self.w, "H": self.H, "eye": self.eye, "g": self.g, "Hx": self.Hx,
            "R": self.R, "e": self.e, "q_err": self.q_err, "x": np.empty(n),
            "best_q": np.empty(n), "history": np.empty(options.stall_window),
            "lower": chain.lower, "upper": chain.upper,
        }  # fmt: skip
        ints = {
            "n": n, "rows": self.rows, "nv": chain.model.nv, "ee_id": chain.ee_id,
            "max_iterations": options.max_iterations, "window": options.stall_window,
        }  # fmt: skip
        floats = {
            "tol": options.tol, "rot_tol": options.rot_tol, "wr": self.wr,
            "damp_e": options.error_damping * 0.5, "damp_0": options.min_damping,
        }  # fmt: skip
        site = chain.ee_kind == "site"
        self.native = lm_loop.Problem(chain.model, d, arrays, ints, floats, site)

    def descend_native(
        self, target: Target, q: NDArray[np.float64]
    ) -> tuple[bool, int, float, float, float]:
        """One start in the compiled loop (the same steps as ``LM._descend``)."""
        native = self.native
        assert native is not None
        chain = self.chain
        if self.ranges[0] is not chain.lower or self.ranges[1] is not chain.upper:
            self.ranges = (chain.lower, chain.upper)  # re-read by Chain.sync
            native.set_array("lower", chain.lower)
            native.set_array("upper", chain.upper)
        self.target_pos[:] = target.position
        return native.descend(q)


def _body_target(work: _Work, quat: NDArray[np.float64]) -> None:
    """``work.target_body = quat * s^-1 * b``: the body orientation ``b'`` with
    ``b' * (b^-1 s) = quat``, from the site ``s`` and body ``b`` orientations of the last
    kinematics pass (the site's placement on its body as MuJoCo computes it)."""
    if work.site_mat is None:
        work.target_body[:] = quat
        return
    site, rel = work.quats
    mujoco.mju_mat2Quat(site, work.site_mat)
    mujoco.mju_negQuat(rel, site)
    mujoco.mju_mulQuat(site, quat, rel)
    mujoco.mju_mulQuat(work.target_body, site, work.body_quat)


class LM(Solver):
    """Levenberg-Marquardt: error-adaptive damping, ranges as box constraints, restarts
    from the seed library (see the module docstring for the step and the damping)."""

    name: ClassVar[str] = "lm"
    summary: ClassVar[str] = "Levenberg-Marquardt, error-adaptive damping, ranges as a box QP"
    supports_orientation: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = LMOptions
    options: LMOptions

    _work: _Work | None = None
    compiled: bool = lm_loop.AVAILABLE
    """Whether solves run the compiled iteration loop (:mod:`.lm_loop`; the answers
    are the same bit for bit). False where it is not built or
    ``HUMANOID_IK_LM_LOOP=python``; set it False on a solver to run the Python loop."""

    def prepare(self, chain: Chain) -> None:
        """Build the chain's seed library (used by the restarts) before any timed solve."""
        if self.options.restarts and self.options.library_seeds:
            seed_library(chain)

    def starts(self, chain: Chain, q0: NDArray[np.float64], target: Target | None = None):
        """``q0``, then library poses nearest ``target`` alternating with seeded random ones."""
        o = self.options
        return restart_poses(chain, q0, target, o.restarts, o.library_seeds, o.seed)

    def _buffers_for(self, chain: Chain, rows: int) -> _Work:
        work = self._work
        if work is None or work.chain is not chain or work.rows != rows:
            work = self._work = _Work(chain, rows, self.options.orientation_weight)
        if self.compiled and work.native is None:
            work.compile(self.options)
        return work

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        work = self._buffers_for(chain, 6 if target.quat is not None else 3)
        best_q, best_cost = q0.copy(), math.inf
        iterations = 0
        native = self.compiled and work.native is not None
        if target.quat is not None:
            _body_target(work, target.quat)
        for q in self.starts(chain, q0, target):
            if native:
                ok, its, cost, ep, er = work.descend_native(target, q)
            else:
                ok, its, cost, ep, er = self._descend(work, target, q)
            iterations += its
            if ok:
                rot = er if target.quat is not None else None
                return IKResult(q, True, iterations, ep, rot, Status.CONVERGED, self.name)
            if cost < best_cost:
                best_cost, best_q = cost, q
        return self._result(chain, target, best_q, iterations, message=self.gave_up())

    def _descend(
        self, work: _Work, target: Target, q: NDArray[np.float64]
    ) -> tuple[bool, int, float, float, float]:
        """Iterate from ``q``, which ends at the converged pose (inside the ranges) or
        at the best pose of this start. ``_lm_loop.c`` is this loop statement by
        statement: change both.

        Returns:
            ``(converged, iterations, cost, position error, orientation error)``: the
            cost ``e' W e`` and the errors of that pose (the errors when converged).
        """
        chain = work.chain
        m, d = chain.model, chain.data
        kinematics, com_pos, jac_fn = mujoco.mj_kinematics, mujoco.mj_comPos, work.jac_fn
        sub3, norm3, scl3 = mujoco.mju_sub3, mujoco.mju_norm3, mujoco.mju_scl3
        subquat, mulmatvec3 = mujoco.mju_subQuat, mujoco.mju_mulMatVec3
        sqr_td, mul_t, add_scl, box_qp = (
            mujoco.mju_sqrMatTD, mujoco.mju_mulMatTVec, mujoco.mju_addToScl, mujoco.mju_boxQP,
        )  # fmt: skip
        o = self.options
        tol, rot_tol, window, wr = o.tol, o.rot_tol, o.stall_window, work.wr
        damp_e, damp_0 = o.error_damping * 0.5, o.min_damping
        tp, tq = target.position, work.target_body
        pose = target.quat is not None
        xpos, jacp, jacr, eid = work.xpos, chain._jacp, chain._jacr, chain.ee_id
        body_quat, body_mat = work.body_quat, work.body_mat
        e, e_p, e_r, J, jac_cols, w = work.e, work.e_p, work.e_r, work.J, work.jac_cols, work.w
        q_err, H, H_flat, eye_flat = work.q_err, work.H, work.H_flat, work.eye
        g, Hx, R, lo, hi = work.g, work.Hx, work.R, chain.lower, chain.upper
        mul_v = mujoco.mju_mulMatVec
        qv = work.qpos_view
        qadr = chain.qpos_adr
        x = q if qv is None else qv  # the joints being solved: qpos itself where it can
        x[:] = q
        history = [math.inf] * window
        best_q, best = q.copy(), math.inf
        er = 0.0
        for it in range(o.max_iterations + 1):
            if qv is None:
                d.qpos[qadr] = x
            kinematics(m, d)
            sub3(e_p, xpos, tp)  # -e: g = J' W (-e) needs no negation
            ep = norm3(e_p)
            if pose:
                # -w: log(t^-1 b) in the body's frame b, t the target's body frame; to
                # the world by the body's rotation (= R_site log(target^-1 site))
                subquat(q_err, body_quat, tq)
                mulmatvec3(e_r, body_mat, q_err)
                er = norm3(e_r)
                scl3(e_r, e_r, wr)
            cost = ep * ep + wr * er * er
            if cost < best:
                best = cost
                best_q[:] = x
            if ep < tol and er < rot_tol:
                q[:] = x
                return True, it, cost, ep, er
            slot = it % window
            if it == o.max_iterations or (it >= window and cost > 0.99 * history[slot]):
                break
            history[slot] = cost
            com_pos(m, d)
            jac_fn(m, d, jacp, jacr, eid)
            if jac_cols is not None:
                np.copyto(J, jac_cols)
            elif J is not work.jac:
                np.take(work.jac, chain.dof_adr, axis=1, out=J)
            sqr_td(H, J, w)  # H = J' W J
            add_scl(H_flat, eye_flat, damp_e * cost + damp_0)  # + lambda I
            mul_t(g, J, e)  # g = -J' W e: the step's linear term
            mul_v(Hx, H, x)
            add_scl(g, Hx, -1.0)  # the same problem in x = q + dq: linear term g - H q
            if box_qp(x, R, None, H, g, lo, hi) < 0:  # warm-started at x = q
                break  # not positive definite (an overflow): this start ends like a stall
        q[:] = best_q
        return False, it, best, math.nan, math.nan
