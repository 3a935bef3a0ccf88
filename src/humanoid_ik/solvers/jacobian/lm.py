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
and warm-started at ``q``. A joint at a range end leaves the step and the others are re-solved
without it: the step never stalls against a limit it could slide along, and every
iterate is inside the ranges by construction.

One start, the iteration loop, runs in C: the extension module
``humanoid_ik.solvers.jacobian._lm_kernel`` (``_lm_kernel.c``, built by ``setup.py``
against the headers and the ``libmujoco`` of the ``mujoco`` wheel; there is no other
implementation and no fallback). Per iteration it computes the frames of the bodies
from the world to the end effector only (after the first pass, only those the chain's
joints move), with ``mj_kinematics``'s operations in its order (the same bits), the error
from the end effector's position and its body's quaternion and rotation (the target
orientation is moved into the body's frame at the start's first pass), the chain's
Jacobian columns from the joint axes and anchors just computed, ``J' W J``
and ``J' W e`` by ``mju_sqrMatTD`` / ``mju_mulMatTVec`` and the box QP, with no call
back into Python. Those columns, ``axis x (p - anchor)`` per hinge (the axis alone
per slide), are MuJoCo's Jacobian's (``mj_jacSite``, to rounding), built in C without
``mj_comPos`` and the other dofs' columns (in numpy they would cost ten times MuJoCo's;
see ``docs/lm.md`` for the figures).

The kernel owns a copy of the model (made from the bytes of ``mujoco.mj_saveModel``;
there is no public way to reach the ``mjModel`` behind a ``mujoco.MjModel``) and an
``MjData`` of its own. Each start copies the robot's scratch ``qpos`` into it (so the
joints off the chain, a torso or a floating base, are where the robot has them) and
takes its buffers from that ``MjData``'s stack, freed on return. The kernel is built
once per robot state and kept in its workspace (:meth:`Robot.workspace
<humanoid_ik.core.robot.Robot.workspace>`, key :data:`KERNEL_KEY`), so it is rebuilt
from the changed model when the live model changes (:meth:`Robot.sync
<humanoid_ik.core.robot.Robot.sync>`). A kernel serves one thread at a time, as its
robot state does (a solve claims the robot); the loop runs without the GIL.

A start that stalls (less than 1 % progress of ``E`` in ``stall_window`` iterations, the
rule of :mod:`humanoid_ik.solvers.iterate`, applied in C) or reaches ``max_iterations``
is followed by the next start, up to ``restarts``: the seed
library's poses nearest the target alternating with seeded random in-range poses
(:func:`~humanoid_ik.solvers.jacobian.seeds.restart_poses`). The first start is ``q0``,
the chain's current joints unless given: tracking a moving target warm-starts from
the previous answer. The restarts and the best pose over them (the lowest
:func:`~humanoid_ik.solvers.iterate.pose_cost`, as every solver ranks them) run in C
too (``Kernel.restart`` after the first start, ``Kernel.solve`` for a batch: one
loop, the same answers); the answer is written into the robot's scratch data
(:meth:`Chain.set_q`), so the scratch data is at the returned pose.

An elbow pole (``Target.pole``) is honoured after convergence, without touching the
kernel's iteration: :func:`pole_steps` turns the elbow toward the pole's plane in the
null space of the end-effector task (Gauss-Newton steps that keep the end on target),
where the arm is redundant; a pose it cannot keep within the tolerances is dropped and
the converged one returned.

State: the solver object holds its options only (and their tuple for the kernel); one
object may serve several threads that each have their own robot state.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.rotations import axis_angle_matrix
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.analytic.elbow import POLE_TOL, elbow_frame, pole_angle
from humanoid_ik.solvers.base import Solver, error_buffers, on_threads
from humanoid_ik.solvers.iterate import pose_cost
from humanoid_ik.solvers.jacobian import _lm_kernel
from humanoid_ik.solvers.jacobian.loop import OPTION_BOUNDS
from humanoid_ik.solvers.jacobian.seeds import random_starts, restart_poses, seed_library
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["KERNEL_KEY", "LM", "LMOptions", "kernel", "pole_steps"]


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


KERNEL_KEY = ("lm_kernel",)
"""The key of the kernel in a robot state's workspace."""


def _build_kernel(model: mujoco.MjModel) -> _lm_kernel.Kernel:
    buf = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return _lm_kernel.Kernel(buf)


def kernel(chain: Chain, index: int = 0) -> _lm_kernel.Kernel:
    """The compiled loop of ``chain``'s robot state: built from a copy of the model on
    first use, kept in the robot's workspace (dropped when the model changes). ``index``
    1, 2, ...: another kernel of the same robot state, for another thread of a batch
    (:func:`~humanoid_ik.solvers.batch.solve_batch`; a kernel serves one thread).

    A model with mocap bodies gets the robot state's mocap poses copied into the kernel
    on every call (a chain below a moved mocap body: its FK moves with it; the kernel's
    calls copy ``qpos`` only)."""
    key = KERNEL_KEY if index == 0 else (*KERNEL_KEY, index)
    k = chain.robot.workspace(key, lambda: _build_kernel(chain.model))
    if chain.model.nmocap:
        k.set_mocap(chain.data.mocap_pos.reshape(-1), chain.data.mocap_quat.reshape(-1))
    return k


class LM(Solver):
    """Levenberg-Marquardt: error-adaptive damping, ranges as box constraints, restarts
    from the seed library (see the module docstring for the step and the damping)."""

    name: ClassVar[str] = "lm"
    honours_pole: ClassVar[bool] = True
    summary: ClassVar[str] = "Levenberg-Marquardt, error-adaptive damping, ranges as a box QP"
    supports_orientation: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = LMOptions
    options: LMOptions

    def prepare(self, chain: Chain) -> None:
        """Build the robot's kernel and the chain's seed library (used by the restarts)
        before any timed solve."""
        kernel(chain)
        if self.options.restarts and self.options.library_seeds:
            seed_library(chain)

    def starts(self, chain: Chain, q0: NDArray[np.float64], target: Target | None = None):
        """``q0``, then library poses nearest ``target`` alternating with seeded random
        ones: the order the compiled restarts follow (``Kernel.restart``)."""
        o = self.options
        return restart_poses(chain, q0, target, o.restarts, o.library_seeds, o.seed)

    def __init__(self, **options: Any):
        super().__init__(**options)
        o = self.options
        self._kernel_options = (
            o.tol, o.rot_tol, o.orientation_weight**2, o.error_damping, o.min_damping,
            o.max_iterations, o.stall_window,
        )  # fmt: skip

    def kernel_options(self) -> tuple[float, float, float, float, float, int, int]:
        """The options as the kernel takes them (``_lm_kernel.Kernel.descend``): made
        once from the (immutable) options."""
        return self._kernel_options

    def solve_many(
        self,
        chain: Chain,
        positions: NDArray[np.float64],
        quats: NDArray[np.float64],
        rotations: NDArray[np.float64],
        q0: NDArray[np.float64],
        threads: int = 1,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Many targets from the start ``q0`` (inside the ranges) in one call of the
        compiled loop per thread (``_lm_kernel.Kernel.solve``): each answer is the one
        :meth:`solve` gives that target from ``q0``, bit for bit, with the GIL released.

        Args:
            positions, quats, rotations: the targets ``(N, 3)``, ``(N, 4)`` and their
                rotation matrices ``(N, 3, 3)``, NaN rows for a position target.
            threads: kernels of the robot state (:func:`kernel`) working at once, each on
                a contiguous part of the targets.

        Returns:
            The answers ``(N, n)`` and per target ``(converged, iterations, position
            error, orientation error)``. A target that did not converge has its best
            pose; its result is the one :meth:`solve` makes (it measures the pose again).

        The caller holds the robot (:meth:`Chain.claim`) and has synced it.
        """
        o = self.options
        count = len(positions)
        kernels = [kernel(chain, k) for k in range(threads)]  # built here, not in threads
        library = seed_library(chain).packed if o.restarts and o.library_seeds else None
        randoms = random_starts(chain, o.seed, o.restarts).reshape(-1)
        q, info = np.empty((count, chain.n)), np.empty((count, 4))
        fixed = (
            chain.data.qpos.copy(), chain.qpos_adr, chain.dof_adr, chain.ee_kind == "site",
            chain.ee_id, chain.lower, chain.upper,
        )  # fmt: skip
        flat = [np.ascontiguousarray(a).reshape(count, -1) for a in (positions, quats, rotations)]

        options = self.kernel_options()

        def run(k: int, lo: int, hi: int) -> None:
            p, qt, rot = (a[lo:hi].reshape(-1) for a in flat)
            kernels[k].solve(
                *fixed, p, qt, options, q0.copy(), rot, library, o.library_seeds,
                randoms, o.restarts, q[lo:hi].reshape(-1), info[lo:hi].reshape(-1),
            )  # fmt: skip

        on_threads(count, threads, run)
        return q, info

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        k = kernel(chain)
        o, options = self.options, self.kernel_options()
        site = chain.ee_kind == "site"
        problem = (
            chain.data.qpos, chain.qpos_adr, chain.dof_adr, site, chain.ee_id, chain.lower,
            chain.upper, target.position, target.quat, options,
        )  # fmt: skip
        # q: the start, overwritten with the converged pose or the start's best pose
        q = q0.copy()
        ok, iterations, _cost, ep, er = k.descend(*problem, q)
        if not ok and o.restarts:
            # the restarts in the compiled loop, as a batch runs them (seeds.restart_poses'
            # order), from the first start's best pose and cost (solve_one in C)
            best = pose_cost(ep, er)  # er is 0 for a position target
            if not best < math.inf:  # a start that overflowed: the best pose is q0
                q[:], best = q0, math.inf
            library = seed_library(chain).packed if o.library_seeds else None
            rot = None if target.rotation is None else target.rotation.reshape(9)
            randoms = random_starts(chain, o.seed, o.restarts).reshape(-1)
            ok, more, _cost, ep, er = k.restart(
                *problem, q, rot, library, o.library_seeds, randoms, o.restarts, best
            )
            iterations += more
        if ok:
            chain.set_q(q)  # the scratch data at the returned pose
            rot_error = er if target.quat is not None else None
            q.setflags(write=False)  # q is this solve's own array: the result's
            res = IKResult.unchecked(
                q, True, iterations, ep, rot_error, Status.CONVERGED, self.name
            )
            return res if target.pole is None else pole_steps(self, chain, target, res)
        return self._result(chain, target, q, iterations, message=self.gave_up())


def _unit_normal(v: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64] | None:
    p = v - float(v @ u) * u
    r = float(np.linalg.norm(p))
    return None if r < 1e-9 else p / r


def _damped_pinv(J: NDArray[np.float64], lam: float) -> NDArray[np.float64]:
    return np.asarray(J.T @ np.linalg.inv(J @ J.T + lam * np.eye(J.shape[0])))


def pole_steps(
    solver: Solver, chain: Chain, target: Target, res: IKResult, steps: int = 40
) -> IKResult:
    """``res`` (a converged answer) with its elbow turned toward ``target.pole`` in the
    null space of the end-effector task: the secondary objective of the Jacobian
    solvers (``lm``, ``dls``).

    Per step: the Gauss-Newton step ``dq = J+ e`` of the end task (3 or 6 rows: it
    keeps the end on target), plus, in its null space ``N = I - J+ J``, the step that
    turns the elbow point about the shoulder-wrist line toward the pole's half-plane
    (at most ``turn`` rad): ``N (J_E N)+ (dE - J_E dq)``, with ``J_E`` the elbow
    point's Jacobian (the hinges before the elbow); ``q`` is clipped to the ranges. A
    step that does not bring the elbow nearer halves ``turn`` (from 0.3 rad; at most 4
    times in a row). Then end-task steps alone bring the end back within the solver's
    tolerances; a pose they cannot bring back is dropped and ``res`` returned as it was.

    Returns:
        The answer, its ``details`` with ``pole`` (``honoured``, ``improved``, or why
        not), ``pole_error`` [rad] and ``pole_error_start`` [rad].
    """
    pole = target.pole
    assert pole is not None
    frame = elbow_frame(chain)
    k = frame.elbow
    rows = 3 if target.quat is None else 6
    q = res.q.copy()
    chain.set_q(q)
    start = err = pole_angle(frame.points(chain), pole)
    turn, misses = 0.3, 0
    eye = np.eye(chain.n)
    for _ in range(steps):
        if not err > POLE_TOL or k == 0 or misses > 4:  # NaN: a straight arm
            break
        S, E, W = frame.points(chain)
        J, Jp, dq = _end_step(chain, target, rows)
        u = (W - S) / max(float(np.linalg.norm(W - S)), 1e-12)
        a, b = _unit_normal(E - S, u), _unit_normal(pole - S, u)
        if a is None or b is None:
            break
        angle = math.copysign(min(err, turn), float(u @ np.cross(a, b)))
        dE = axis_angle_matrix(u, angle) @ (E - S) - (E - S)
        anchors, axes = chain.joint_axes()
        JE = np.zeros((3, chain.n))
        JE[:, :k] = np.cross(axes[:k], E - anchors[:k]).T
        N = eye - Jp @ J
        dq += N @ (_damped_pinv(JE @ N, 1e-8) @ (dE - JE @ dq))
        q_new = chain.clip(q + dq)
        chain.set_q(q_new)
        now = pole_angle(frame.points(chain), pole)
        if now < err - 1e-12:
            q, err, misses = q_new, now, 0
        else:
            chain.set_q(q)
            turn, misses = 0.5 * turn, misses + 1
    ok = _back_on_target(solver, chain, target, q, rows)
    if ok is not None:
        q = ok
        err = pole_angle(frame.points(chain), pole)
    if ok is None or not err < start:
        chain.set_q(res.q)
        why = "honoured" if start <= POLE_TOL else "not honoured: no redundancy to turn the elbow"
        if math.isnan(start):
            why = "undefined: a straight arm or a pole on the shoulder-wrist line"
        return res.with_details(pole=why, pole_error=start, pole_error_start=start)
    e, qb = error_buffers(chain)
    ep, er = pose_error(chain.position, chain.rotation, target.position, target.quat, e, qb)
    rot = None if target.quat is None else er
    out = IKResult(q, True, res.iterations, ep, rot, Status.CONVERGED, res.solver)
    why = "honoured" if err <= POLE_TOL else "improved (joint ranges or no redundancy)"
    return out.with_details(pole=why, pole_error=err, pole_error_start=start)


def _end_step(
    chain: Chain, target: Target, rows: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(J, J+, J+ e)`` of the end task at the chain's current pose."""
    e, qb = error_buffers(chain)
    pose_error(chain.position, chain.rotation, target.position, target.quat, e, qb)
    J = chain.current_jacobian()[:rows]
    Jp = _damped_pinv(J, 1e-10)
    return J, Jp, Jp @ e[:rows]


def _back_on_target(
    solver: Solver, chain: Chain, target: Target, q: NDArray[np.float64], rows: int
) -> NDArray[np.float64] | None:
    """``q`` brought within the solver's tolerances by end-task steps (at most 10), or
    ``None`` (the chain is left at the last pose)."""
    o = solver.options
    e, qb = error_buffers(chain)
    for _ in range(11):
        chain.set_q(q)
        ep, er = pose_error(chain.position, chain.rotation, target.position, target.quat, e, qb)
        if ep < o.tol and (target.quat is None or er < o.rot_tol):
            return q
        q = chain.clip(q + _end_step(chain, target, rows)[2])
    return None
