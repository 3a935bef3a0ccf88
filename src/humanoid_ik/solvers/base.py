"""The solver protocol: typed options, applicability, the gaze axis, result measuring,
and the case of several effectors solved at once."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import axis_vector, pose_error
from humanoid_ik.core.types import EffectorGoal, IKResult, Status, Target
from humanoid_ik.errors import SolverError, TargetError, show_value
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["Solver", "check_start", "error_buffers", "on_threads"]

_KINDS = {
    "b": "true/false values",
    "c": "complex numbers",
    "U": "text",
    "S": "text",
    "O": "objects that are not real numbers",
}
"""What a start's NumPy dtype kind says it holds, when that is not real numbers."""
_FLOAT64 = np.dtype(np.float64)


def check_start(chain: Chain, q0: ArrayLike) -> NDArray[np.float64]:
    """``q0`` as a start for ``chain``: ``n`` finite real numbers, a new float64 array.

    Text, true/false values, complex numbers and objects that are not real numbers are
    refused, though NumPy would convert them (``"0"`` and ``True`` to 0.0 and 1.0, a
    complex number to its real part with only a warning).

    Raises:
        TargetError: not real numbers, the wrong length, or NaN/inf (one line).
    """
    if (
        type(q0) is np.ndarray
        and q0.dtype is _FLOAT64
        and q0.shape == (chain.n,)
        and math.isfinite(sum(q0.tolist()))  # not finite: the checks below say which
    ):
        return q0.copy()  # the common start, without the conversions (2 us a solve)
    try:
        arr = np.asarray(q0)
    except (TypeError, ValueError):  # ragged: the chain's check says it
        return chain.check_q(q0)
    kind = arr.dtype.kind
    if kind == "O":  # a list of objects: each must be a real number
        kinds = {np.asarray(v).dtype.kind for v in arr.ravel().tolist()}
        kind = "f" if kinds <= {"i", "u", "f"} else "O"
    if kind not in "iuf":
        shown = show_value(q0)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        got = _KINDS.get(kind, str(arr.dtype))
        raise TargetError(f"joint vector must be {chain.n} real numbers (rad), got {got}: {shown}")
    return chain.check_q(arr)


def on_threads(count: int, threads: int, run: Callable[[int, int, int], None]) -> None:
    """``run(k, lo, hi)`` for each of ``threads`` contiguous parts ``[lo, hi)`` of
    ``count`` items: part 0 in this thread, the others each on a thread of its own
    (``run`` releases the GIL in compiled code to gain from them); the first exception
    of any part is raised here, after every part ended."""
    import threading

    failed: list[BaseException] = []

    def part(k: int, lo: int, hi: int) -> None:
        try:
            run(k, lo, hi)
        except BaseException as exc:  # raised in the caller, not lost in a thread
            failed.append(exc)

    bounds = np.linspace(0, count, threads + 1).astype(int).tolist()
    workers = [
        threading.Thread(target=part, args=(k, bounds[k], bounds[k + 1])) for k in range(1, threads)
    ]
    for w in workers:
        w.start()
    try:
        part(0, bounds[0], bounds[1])
    finally:
        for w in workers:
            w.join()
    if failed:
        raise failed[0]


def error_buffers(chain: Chain) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The error vector ``(6,)`` and quaternion scratch ``(2, 4)`` that
    :func:`~humanoid_ik.core.measures.pose_error` writes, from the chain's robot state."""
    r = chain.robot
    return r.buffer("pose_error", (6,)), r.buffer("pose_error_quats", (2, 4))


class Solver(ABC):
    """An IK method. Subclasses set ``name``, ``summary``, ``Options`` and implement
    ``_solve``.

    Options are keyword arguments parsed into the solver's ``Options`` dataclass
    (:class:`~humanoid_ik.solvers.options.SolverOptions`: every solver takes ``tol``
    [m] and ``rot_tol`` [rad]); the solver reads them as ``self.options``.

    Several effectors at once: a solver that moves several chains in one problem sets
    ``solves_effectors`` and overrides :meth:`solve_effectors`; the scene runner then
    hands it every effector that uses it, in one call per frame. Any other solver is
    called once per effector through :meth:`solve`.

    No state: a solver object holds its options and nothing a solve changes, so one
    object may serve several threads that each have their own robot state. What a
    solver derives from a chain alone (seed poses, manipulability at home, closed-form
    geometry) and the buffers a solve writes are kept in the robot's workspace
    (:meth:`Chain.derived`, :meth:`Robot.buffer <humanoid_ik.core.robot.Robot.buffer>`),
    built by :meth:`prepare`, which timing loops call before they start the clock.
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    supports_orientation: ClassVar[bool] = False
    reaches: ClassVar[bool] = True
    """True for solvers that move the site onto the target (the bench's reaching tasks)."""
    honours_pole: ClassVar[bool] = False
    """True for solvers that turn the elbow toward a target's pole (``Target.pole``);
    the others solve without it and say so: ``details["pole"] == "ignored"``."""
    solves_effectors: ClassVar[bool] = False
    """True for solvers that solve several effectors jointly (:meth:`solve_effectors`)."""
    Options: ClassVar[type[SolverOptions]] = SolverOptions
    options: SolverOptions

    def __init__(self, **options: Any):
        self.options = self.Options.parse(self.name, options)

    def prepare(self, chain: Chain) -> None:
        """Build what the solver derives from ``chain`` alone, so a later timed solve
        does not pay for it (a no-op for solvers that derive nothing)."""
        return None

    def prepare_effectors(self, goals: Sequence[EffectorGoal]) -> None:
        """:meth:`prepare` for the effectors a later :meth:`solve_effectors` call gets
        (by default, each goal's chain)."""
        for g in goals:
            self.prepare(g.chain)

    def solve_effectors(self, goals: Sequence[EffectorGoal]) -> list[IKResult]:
        """Solve several effectors jointly (only where ``solves_effectors`` is set).

        Args:
            goals: one goal per effector, all chains on one model.

        Returns:
            One result per goal, in order.

        Raises:
            SolverError: this solver solves one effector at a time.
        """
        raise SolverError(f"solver '{self.name}' solves one effector at a time")

    def starts(
        self, chain: Chain, q0: NDArray[np.float64], target: Target | None = None
    ) -> Iterator[NDArray[np.float64]]:
        """``q0``, then ``restarts`` seeded random in-range poses (``seed`` option) for
        solvers with those options.

        Solvers with a better restart rule use ``target`` (see the Jacobian family)."""
        yield q0.copy()
        rng = np.random.default_rng(getattr(self.options, "seed", 0))
        for _ in range(getattr(self.options, "restarts", 0)):
            yield chain.random_q(rng)

    def gave_up(self) -> str:
        """The message of a result that did not converge from any start."""
        starts = getattr(self.options, "restarts", 0) + 1
        return (
            f"no start of {starts} converged; the closest pose is returned "
            "(the target may be out of reach within the joint ranges)"
        )

    def gaze_axis(self) -> NDArray[np.float64]:
        """The unit axis ``(3,)`` of the site frame this solver aims at a ``look_at``
        target (``x`` unless an option chooses another)."""
        return axis_vector(getattr(self.options, "forward_axis", "x"))

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        """``None`` when the solver can solve this chain and task, else the reason it cannot."""
        if pose and not self.supports_orientation:
            return f"{self.name} solves position targets only"
        return None

    def solve(
        self,
        chain: Chain,
        target: Target | ArrayLike,
        q0: ArrayLike | None = None,
        *,
        data: mujoco.MjData | None = None,
    ) -> IKResult:
        """Solve from ``q0`` (default: the chain's current joint values, moved inside ranges).

        Works on the chain's robot state; leaves it at the returned pose. Follows changes
        to the live model first (:meth:`Chain.sync`).

        Args:
            chain, target, q0: the chain, its target and the start.
            data: the caller's ``MjData``, copied into the robot state once the robot is
                claimed (only read).

        Raises:
            TargetError: a bad target or ``q0``.
            SolverError: the solver does not apply to this chain or task.
            ChainError: another thread is solving on the same robot, or ``data``
                belongs to another model.
        """
        tgt = Target.of(target)
        chain.claim()
        try:
            if data is not None:
                chain.load(data)
            chain.sync()
            reason = self.applicable(chain, tgt.is_pose)
            if reason is not None:
                raise SolverError(reason)
            start = chain.q if q0 is None else check_start(chain, q0)
            res = self._solve(chain, tgt, chain.clip(start, out=start))
            if tgt.pole is not None and "pole" not in res.details:
                res = res.with_details(pole="ignored")
            return res
        finally:
            chain.release()

    @abstractmethod
    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        """Solve from ``q0`` (inside ranges) on the chain's scratch data."""

    def _result(
        self,
        chain: Chain,
        target: Target,
        q: NDArray[np.float64],
        iterations: int,
        status: Status | None = None,
        message: str = "",
    ) -> IKResult:
        """Measure ``q`` with MuJoCo FK and wrap it; status from the tolerances unless given."""
        chain.set_q(q)
        ep, er = pose_error(
            chain.position, chain.rotation, target.position, target.quat, *error_buffers(chain)
        )
        o = self.options
        ok = ep < o.tol and (target.quat is None or er < o.rot_tol)
        if status is None:
            status = Status.CONVERGED if ok else Status.MAX_ITERATIONS
        return IKResult(
            q=q.copy(),
            converged=status is Status.CONVERGED,
            iterations=iterations,
            position_error=ep,
            orientation_error=None if target.quat is None else er,
            status=status,
            solver=self.name,
            message=message,
        )
