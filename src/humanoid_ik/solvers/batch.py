"""Many targets of one chain at once: :func:`solve_batch`, on one core or several.

Every target is solved on its own from the same start, exactly as :func:`~.one_call.solve`
solves it: the answers are the single calls' bit for bit, whatever ``workers`` is.

Where every target is ``lm``'s (the solver ``lm``, or ``auto`` choosing ``lm`` for the
targets' tasks; no elbow pole), the targets go to ``lm``'s compiled loop in one call
(:meth:`LM.solve_many <humanoid_ik.solvers.jacobian.lm.LM.solve_many>`), on ``workers``
threads with a kernel each (the loop releases the GIL); a target no start reached is
solved again by the one call, which measures it (``auto``'s retry of a missed pose
target runs in the compiled loop too). Where every target is a pose for ``subproblem``
(the solver, or ``auto``'s choice on a 6-hinge arm of its families), the C solve and
``lm``'s kernel's measure run over all of them on ``workers`` threads
(:meth:`Subproblem.solve_many
<humanoid_ik.solvers.analytic.subproblem.solver.Subproblem.solve_many>`).

Otherwise, with ``workers`` above 1 the targets go in contiguous chunks to that many
processes, each holding its own copy of the robot (the model as it is now, and its
current joints); a process costs about a second to start (it imports MuJoCo and reads
the model), so this pays from tens of thousands of targets (``benchmarks/batch.py``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from types import MappingProxyType
from typing import Any, cast

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.core.types import BatchResults, IKResult, Status, Target, target_rows
from humanoid_ik.errors import SolverError, TargetError
from humanoid_ik.solvers.analytic.subproblem import Subproblem
from humanoid_ik.solvers.auto import Auto
from humanoid_ik.solvers.base import Solver, check_start
from humanoid_ik.solvers.jacobian.lm import LM
from humanoid_ik.solvers.one_call import solve, solver_for

__all__ = ["solve_batch"]

CHUNKS_PER_WORKER = 4
"""Chunks each process gets (a few, so that a slow chunk does not hold the others up)."""

_WORKER: dict[str, Any] = {}
"""A worker process's chain, start and solver (set once by :func:`_start_worker`)."""


class _Targets:
    """A batch's targets, checked: as arrays for the compiled paths (:meth:`poses`,
    :attr:`packed`) and one by one as :class:`Target` objects (:meth:`target`)."""

    def __init__(self, targets: Sequence[Target] | ArrayLike, quats: ArrayLike | None):
        """Target objects, or positions ``(N, 3)`` with orientations ``(N, 4)`` wxyz or
        ``None``, checked as arrays (:func:`~humanoid_ik.core.types.target_rows`: a bad
        row raises the error its ``Target`` gives; the quaternions normalised as
        ``Target`` normalises one)."""
        self._objects: list[Target] | None = None
        self._packed: Packed | None = None
        self._unit: NDArray[np.float64] | None = None
        if isinstance(targets, list | tuple) and all(isinstance(t, Target) for t in targets):
            if quats is not None:
                raise TargetError("quats go with positions (N, 3), not with Target objects")
            self._objects = list(targets)
            self.count = len(self._objects)
            return
        self._positions, self._quats, self._unit = target_rows(cast(ArrayLike, targets), quats)
        self.count = len(self._positions)

    @property
    def packed(self) -> Packed:
        """Positions ``(N, 3)``, orientations ``(N, 4)``, their rotations ``(N, 3, 3)``
        (``quat_to_mat``, row by row the bits of ``Target``'s) and poles ``(N, 3)``,
        NaN rows where a target has none (read-only)."""
        if self._packed is None:
            if self._objects is not None:
                self._packed = _packed(self._objects)
            else:
                p, n = self._positions, self.count
                nan = np.full((n, 3), np.nan)
                if self._unit is None:
                    self._packed = (p, np.full((n, 4), np.nan), np.full((n, 3, 3), np.nan), nan)
                else:
                    self._packed = (p, self._unit, quat_to_mat(self._unit), nan)
                for a in self._packed:
                    a.setflags(write=False)
        return self._packed

    def poses(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The positions ``(N, 3)`` and unit quaternions ``(N, 4)`` (no rotations made)."""
        if self._objects is None and self._unit is not None:
            return self._positions, self._unit
        positions, quats, _, _ = self.packed
        return positions, quats

    def target(self, i: int) -> Target:
        """Target ``i``, as given or as ``Target(position, quat)`` of its rows."""
        if self._objects is not None:
            return self._objects[i]
        return Target(self._positions[i], None if self._quats is None else self._quats[i])

    def posed(self) -> NDArray[np.bool_]:
        """Which targets have an orientation ``(N,)``."""
        if self._objects is not None:
            return np.array([t.quat is not None for t in self._objects], dtype=bool)
        return np.full(self.count, self._unit is not None)

    def any_pole(self) -> bool:
        """Whether some target has an elbow pole (arrays have none)."""
        return self._objects is not None and any(t.pole is not None for t in self._objects)


def _start_worker(
    model_file: str,
    qpos: NDArray[np.float64],
    ee: tuple[str, str],
    joints: list[str],
    q0: NDArray[np.float64],
    solver: str | Solver,
    options: dict[str, Any],
) -> None:
    """A worker's copy of the caller's chain: the same model (read from the binary file
    the caller saved it to), joints and robot pose."""
    robot = Robot(mujoco.MjModel.from_binary_path(model_file))
    robot.data.qpos[:] = qpos
    mujoco.mj_kinematics(robot.model, robot.data)
    kind, name = ee
    chain = Chain(robot, joints=joints, **{kind: name})
    _WORKER.update(chain=chain, q0=q0, solver=solver, options=options)


Packed = tuple[NDArray[np.float64], ...]
"""Targets as arrays (:func:`_packed`): positions, orientations, rotations, poles."""


def _solve_chunk(chunk: Packed) -> tuple[NDArray[np.float64], list[tuple[Any, ...]]]:
    """A worker's answers to a chunk of targets (both ways as arrays where they can be:
    they cross the pipe far cheaper than objects): the joints ``(k, n)`` and, per
    target, the other arguments of its :class:`IKResult` (rebuilt in the caller)."""
    w = _WORKER
    positions, quats, rotations, poles = chunk
    q = np.empty((len(positions), w["chain"].n))
    rest = []
    for i in range(len(positions)):
        posed = not np.isnan(quats[i, 0])
        target = Target.unchecked(
            positions[i],
            quats[i] if posed else None,
            rotations[i] if posed else None,
            None if np.isnan(poles[i, 0]) else poles[i],
        )
        result = solve(w["chain"], target, w["solver"], q0=w["q0"], **w["options"])
        fields = result.__reduce__()[1]
        q[i] = fields[0]
        rest.append(fields[1:])
    return q, rest


def _compiled_lm(chain: Chain, solver: Solver, targets: _Targets) -> LM | None:
    """The ``lm`` that solves every target when it is ``solver`` itself or ``auto``'s
    choice for each target's task, and no target has a pole (``lm`` honours one in
    Python); else ``None``."""
    if targets.any_pole():
        return None
    if type(solver) is LM:
        return solver
    if type(solver) is not Auto:
        return None
    tasks = set(targets.posed().tolist())
    chosen = {solver.choice(chain, pose) for pose in tasks}
    if len(chosen) != 1:
        return None
    (lm,) = chosen
    return lm if type(lm) is LM else None


def _solve_compiled(
    chain: Chain,
    solver: Solver,
    lm: LM,
    targets: _Targets,
    start: NDArray[np.float64],
    threads: int,
) -> BatchResults:
    """``solve(chain, target, solver, q0=start)`` for each target, the compiled loop
    solving them all (:meth:`LM.solve_many`, on ``threads`` threads): each converged
    answer is wrapped as ``lm`` (and ``auto``) wrap it, when read. For ``auto``, the pose
    targets ``lm`` missed go to its retry (:attr:`Auto.retry`) in the compiled loop as
    well; a target still missed is solved again by the one call, which measures it (the
    same starts give the same pose: only the result is made anew)."""
    auto = type(solver) is Auto
    positions, quats, rotations, _ = targets.packed
    posed = ~np.isnan(quats[:, 0])
    chain.claim()
    try:
        chain.sync()
        q0 = chain.clip(check_start(chain, start))
        q, info = lm.solve_many(chain, positions, quats, rotations, q0, threads)
        again = np.flatnonzero((info[:, 0] != 1.0) & posed) if auto else np.empty(0, int)
        if again.size:
            assert isinstance(solver, Auto)
            parts = (positions[again], quats[again], rotations[again])
            q2, info2 = solver.retry.solve_many(chain, *parts, q0, threads)
    finally:
        chain.release()
    retried: set[int] = set()
    if again.size:  # the retry's converged answers replace the first pass's
        ok = info2[:, 0] == 1.0
        q[again[ok]], info[again[ok]] = q2[ok], info2[ok]
        retried = set(again[ok].tolist())
    made = {  # solved again by the one call
        i: solve(chain, targets.target(i), solver, q0=start)
        for i in np.flatnonzero(info[:, 0] != 1.0).tolist()
    }
    for i, r in made.items():
        q[i] = r.q
        er_i = np.nan if r.orientation_error is None else r.orientation_error
        info[i] = (r.converged, r.iterations, r.position_error, er_i)
    q.setflags(write=False)  # its rows are the results' joints
    er = np.where(posed, info[:, 3], np.nan)
    one = MappingProxyType({"auto": ("lm",)} if auto else {})
    both = MappingProxyType({"auto": ("lm", "lm")})
    template = {"converged": True, "status": Status.CONVERGED, "solver": lm.name, "message": ""}

    def row(i: int) -> IKResult:
        if i in made:
            return made[i]
        r = object.__new__(IKResult)
        _ok, its, ep, e_r = info[i].tolist()
        r.__dict__.update(
            template, q=q[i], iterations=int(its), position_error=ep,
            orientation_error=e_r if posed[i] else None,
            details=both if i in retried else one,
        )  # fmt: skip
        return r

    if info[-1, 0] == 1.0:
        chain.set_q(q[-1])  # the scratch data at the last answer, as after the one calls
    return BatchResults(targets.count, row, (q, info[:, 0] == 1.0, info[:, 2].copy(), er))


def _compiled_subproblem(chain: Chain, solver: Solver, targets: _Targets) -> Subproblem | None:
    """The ``subproblem`` that solves every target when it is ``solver`` itself or
    ``auto``'s choice for pose targets, every target is a pose and none has a pole;
    else ``None``."""
    if targets.any_pole() or not targets.posed().all():
        return None
    if type(solver) is Subproblem:
        return solver
    if type(solver) is Auto:
        chosen = solver.choice(chain, True)
        return chosen if type(chosen) is Subproblem else None
    return None


def _solve_exact(
    chain: Chain,
    solver: Solver,
    exact: Subproblem,
    targets: _Targets,
    start: NDArray[np.float64],
    threads: int,
) -> BatchResults:
    """``solve(chain, target, solver, q0=start)`` for each pose target, ``subproblem``
    solving them all in C (:meth:`Subproblem.solve_many`, on ``threads`` threads), each
    result made as the one call makes it (and wrapped as ``auto`` wraps it) when read:
    targets given as arrays stay arrays."""
    positions, quats = targets.poses()
    chain.claim()
    try:
        chain.sync()
        reason = exact.applicable(chain, True)
        if reason is not None:
            raise SolverError(reason)
        q0 = chain.clip(check_start(chain, start))
        q, counts, info = exact.solve_many(chain, positions, quats, q0, threads)
    finally:
        chain.release()
    q.setflags(write=False)  # its rows are the results' joints
    extra = {"auto": (exact.name,)} if type(solver) is Auto else None
    chain.set_q(q[-1])  # the scratch data at the last answer, as after the one calls
    return exact.batch(chain.n, q, counts, info, extra)


def _packed(targets: list[Target]) -> Packed:
    """Targets as arrays: positions ``(N, 3)``, orientations ``(N, 4)``, their rotations
    ``(N, 3, 3)`` and poles ``(N, 3)``, with NaN rows where a target has none."""

    def stack(
        values: list[NDArray[np.float64] | None], shape: tuple[int, ...]
    ) -> NDArray[np.float64]:
        if all(v is not None for v in values):  # one copy (a third of the loop's time)
            return np.array(values, dtype=np.float64).reshape(len(values), *shape)
        out = np.full((len(values), *shape), np.nan)
        for i, v in enumerate(values):
            if v is not None:
                out[i] = v
        return out

    arrays = (
        stack([t.position for t in targets], (3,)),
        stack([t.quat for t in targets], (4,)),
        stack([t.rotation for t in targets], (3, 3)),
        stack([t.pole for t in targets], (3,)),
    )
    for a in arrays:
        a.setflags(write=False)
    return arrays


def solve_batch(
    chain: Chain,
    targets: Sequence[Target] | ArrayLike,
    solver: str | Solver = "auto",
    *,
    quats: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    workers: int = 1,
    **options: Any,
) -> BatchResults:
    """Solve IK for ``chain`` toward each of ``targets``, each from the same start.

    Args:
        chain: the kinematic chain (its robot's other joints keep their current values).
        targets: :class:`Target` objects, or positions ``(N, 3)`` [m].
        solver: a solver name (default ``auto``) or a solver object, as for ``solve``.
        quats: orientations ``(N, 4)`` wxyz for positions given as an array.
        q0: the start ``(n,)`` of every solve [rad]; default the chain's current joints.
        workers: threads (``lm``'s compiled loop, ``subproblem``) or processes (the other
            solvers) to solve on (1: this thread; ``0``: one per core).
        **options: solver options, when ``solver`` is a name.

    Returns:
        The :class:`~humanoid_ik.core.types.BatchResults`: one :class:`IKResult` per
        target, in order, equal to ``solve(chain, target, solver, q0=q0, **options)``
        for each, and the same answers as arrays (``.q``, ``.converged``, ...).

    Raises:
        HumanoidIKError: a bad target, solver, option or ``workers``; nothing is solved.
    """
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 0:
        raise SolverError(f"workers must be an integer >= 0 (0: one per core), got {workers!r}")
    given = _Targets(targets, quats)
    start = chain.q if q0 is None else np.asarray(q0, dtype=np.float64)
    if not given.count:
        return BatchResults.of([])
    n_workers = min(int(workers) or (os.cpu_count() or 1), given.count)
    qpos = chain.data.qpos.copy()  # the robot's pose the workers copy, before any solve
    # checks solver and start
    first = solve(chain, given.target(0), solver, q0=start, **options)
    s = solver_for(solver, options) if isinstance(solver, str) else solver
    exact = _compiled_subproblem(chain, s, given)
    if exact is not None:
        return _solve_exact(chain, s, exact, given, start, n_workers)
    compiled = _compiled_lm(chain, s, given)
    if compiled is not None:
        return _solve_compiled(chain, s, compiled, given, start, n_workers)
    if n_workers <= 1:
        rest = [
            solve(chain, given.target(i), solver, q0=start, **options)
            for i in range(1, given.count)
        ]
        return BatchResults.of([first, *rest])
    # imported here: a solve without workers (every import humanoid_ik) needs neither
    import multiprocessing as mp
    import tempfile
    from concurrent.futures import ProcessPoolExecutor

    packed = tuple(a[1:] for a in given.packed)
    size = -(-len(packed[0]) // (n_workers * CHUNKS_PER_WORKER))
    chunks = [tuple(a[i : i + size] for a in packed) for i in range(0, len(packed[0]), size)]
    methods = mp.get_all_start_methods()
    ctx = mp.get_context("forkserver" if "forkserver" in methods else "spawn")
    ee = (chain.ee_kind, chain.ee_name)
    # the model goes to the workers as one binary file, not pickled once per worker (a
    # robot's meshes make it tens of MB: 0.4 s a worker through the pipe on G1)
    with tempfile.TemporaryDirectory(prefix="humanoid-ik-batch-") as folder:
        model_file = os.path.join(folder, "model.mjb")
        mujoco.mj_saveModel(chain.model, model_file, None)
        args = (model_file, qpos, ee, list(chain.joint_names), start, solver, options)
        with ProcessPoolExecutor(
            n_workers, mp_context=ctx, initializer=_start_worker, initargs=args
        ) as pool:
            results = [first]
            for q, fields in pool.map(_solve_chunk, chunks):
                results.extend(IKResult(qi, *f) for qi, f in zip(q, fields, strict=True))
    return BatchResults.of(results)
