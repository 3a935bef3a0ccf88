"""Value types: the IK target and the result every solver returns."""

from __future__ import annotations

import gc
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, NamedTuple, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.checks import float_array
from humanoid_ik.errors import TargetError

if TYPE_CHECKING:
    from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import UNIT_TOL, normalize_quat, quat_norms, quat_to_mat

__all__ = [
    "BatchResults",
    "EffectorGoal",
    "IKResult",
    "STATUSES",
    "Status",
    "TARGET_KINDS",
    "Target",
    "collector_held",
    "target_rows",
]


class Status(StrEnum):
    """How a solve ended (a string enum: ``Status.CONVERGED == "converged"``)."""

    CONVERGED = "converged"
    """Within the solver's tolerances."""
    MAX_ITERATIONS = "max_iterations"
    """Stopped by the iteration cap or a stall, from every start."""
    UNREACHABLE = "unreachable"
    """The target lies outside what the chain can reach (analytic solvers say so)."""


STATUSES = tuple(s.value for s in Status)
TARGET_KINDS = ("position", "pose")
"""What a target fixes: a position, or a pose (position and orientation)."""
MAX_COORDINATE = 1e6  # [m]: farther targets are input mistakes (and overflow squares)
_FLOAT64 = np.dtype(np.float64)


@dataclass(frozen=True)
class Target:
    """A position target ``(3,)`` in [m], optionally with a wxyz orientation ``(4,)``
    and an elbow *pole* ``(3,)`` [m]: the world point the elbow should point towards
    (Maya's pole vector, Unreal's two-bone IK joint target). The elbow then lies in the
    plane through the shoulder, the wrist and the pole, on the pole's side, where the
    arm's ranges allow (``docs/solvers.md`` lists the solvers that honour it).

    Raises:
        TargetError: wrong shape, NaN/inf, a coordinate beyond 1e6 m, or a zero /
            non-unit quaternion.
    """

    position: NDArray[np.float64]
    quat: NDArray[np.float64] | None = None
    pole: NDArray[np.float64] | None = None
    rotation: NDArray[np.float64] | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        p = float_array("target position", self.position)
        if p.shape != (3,):
            raise TargetError(f"target position must have 3 values (x, y, z), got shape {p.shape}")
        x, y, z = p.tolist()  # one comparison per coordinate: NaN fails it too
        if not (abs(x) <= MAX_COORDINATE and abs(y) <= MAX_COORDINATE and abs(z) <= MAX_COORDINATE):
            if not np.all(np.isfinite(p)):
                raise TargetError(f"target position {p.tolist()} is not finite")
            raise TargetError(
                f"target position {p.tolist()} lies beyond {MAX_COORDINATE:g} m; "
                "expected coordinates in metres"
            )
        p.setflags(write=False)
        object.__setattr__(self, "position", p)
        if self.pole is not None:
            object.__setattr__(self, "pole", _point("elbow pole", self.pole))
        if self.quat is None:
            object.__setattr__(self, "rotation", None)
            return
        q = normalize_quat(float_array("quaternion", self.quat))
        q.setflags(write=False)
        R = quat_to_mat(q)
        R.setflags(write=False)
        object.__setattr__(self, "quat", q)
        object.__setattr__(self, "rotation", R)

    @classmethod
    def unchecked(
        cls,
        position: NDArray[np.float64],
        quat: NDArray[np.float64] | None = None,
        rotation: NDArray[np.float64] | None = None,
        pole: NDArray[np.float64] | None = None,
    ) -> Target:
        """A target from the fields of one already made (and so checked), taken as they
        are: what :func:`~humanoid_ik.solvers.batch.solve_batch` rebuilds from the
        arrays it sends to its worker processes (15 us a target saved there)."""
        new = object.__new__(cls)
        new.__dict__.update(position=position, quat=quat, pole=pole, rotation=rotation)
        return new

    @classmethod
    def of(cls, target: Target | ArrayLike, quat: ArrayLike | None = None) -> Target:
        """A ``Target`` from a ``Target`` or a position (and an optional quaternion; a
        ``Target``'s pole is kept)."""
        q = None if quat is None else float_array("quaternion", quat)
        if isinstance(target, Target):
            return target if q is None else cls(target.position, q, target.pole)
        return cls(float_array("target position", target), q)

    @classmethod
    def from_motion(
        cls,
        position: NDArray[np.float64],
        quat: NDArray[np.float64] | None = None,
        pole: NDArray[np.float64] | None = None,
    ) -> Target:
        """The target a motion gives at one instant, without the checks of user input.

        ``position`` is what :meth:`Motion.position <humanoid_ik.motion.base.Motion.position>`
        returns, a new float64 ``(3,)`` array from checked parameters: it is taken as is
        (not copied; made read-only) and only its coordinates are bounded, with the
        constructor's error. Anything else, and a pose target's quaternion (which the
        constructor normalises), goes through the constructor. The frame loop builds
        every frame's targets this way, and a ``pole`` (an effector's elbow pole, itself
        a motion's output) alike.
        """
        if quat is not None or not _motion_point(position):
            return cls(position, quat, pole)
        if pole is not None and not _motion_point(pole):
            return cls(position, None, pole)
        position.setflags(write=False)
        if pole is not None:
            pole.setflags(write=False)
        new = object.__new__(cls)
        new.__dict__.update(position=position, quat=None, pole=pole, rotation=None)
        return new

    @property
    def is_pose(self) -> bool:
        """True when the target includes an orientation."""
        return self.quat is not None


def _motion_point(p: Any) -> bool:
    """``p`` is a float64 ``(3,)`` array inside :data:`MAX_COORDINATE` (a motion's
    output, which :meth:`Target.from_motion` takes as is); anything else, NaN included,
    goes through the constructor's checks."""
    if type(p) is not np.ndarray or p.dtype is not _FLOAT64 or p.shape != (3,):
        return False
    x, y, z = p.tolist()
    return abs(x) <= MAX_COORDINATE and abs(y) <= MAX_COORDINATE and abs(z) <= MAX_COORDINATE


def _point(what: str, value: ArrayLike) -> NDArray[np.float64]:
    """``value`` as a read-only ``(3,)`` point [m] within :data:`MAX_COORDINATE`.

    Raises:
        TargetError: not 3 finite numbers, or beyond 1e6 m (the message starts with ``what``).
    """
    p = float_array(what, value)
    if p.shape != (3,):
        raise TargetError(f"{what} must have 3 values (x, y, z), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise TargetError(f"{what} {p.tolist()} is not finite")
    if np.any(np.abs(p) > MAX_COORDINATE):
        raise TargetError(f"{what} {p.tolist()} lies beyond {MAX_COORDINATE:g} m; expected metres")
    p.setflags(write=False)
    return p


_NO_DETAILS: Mapping[str, Any] = MappingProxyType({})


def target_rows(
    positions: ArrayLike, quats: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None]:
    """Many targets as arrays: positions ``(N, 3)`` [m] and wxyz quaternions ``(N, 4)``
    (or ``None``), checked row by row as :class:`Target` checks one (a bad row raises
    the error its ``Target`` gives, naming its value). Returns new arrays: the positions,
    the quaternions as given and normalised as ``Target`` normalises one (the same bits:
    :func:`~humanoid_ik.core.rotations.quat_norms`), ``None`` twice without them.

    Raises:
        TargetError: wrong shapes, a value that is not a number, or a bad row.
    """
    p = float_array("target positions", positions)
    if p.ndim != 2 or p.shape[1] != 3:
        raise TargetError(f"positions must have shape (N, 3) [m], got {p.shape}")
    bad = ~(np.abs(p) <= MAX_COORDINATE).all(axis=1)  # NaN fails it too
    if bad.any():
        Target(p[np.flatnonzero(bad)[0]])  # raises the row's error
    if quats is None:
        return p, None, None
    qt = float_array("quaternions", quats)
    if qt.shape != (len(p), 4):
        raise TargetError(
            f"quats must have shape ({len(p)}, 4) wxyz to go with the positions, got {qt.shape}"
        )
    norms = quat_norms(qt)
    bad = ~(np.abs(norms - 1.0) <= UNIT_TOL)  # NaN, inf and zero fail it too
    if bad.any():
        i = np.flatnonzero(bad)[0]
        Target(p[i], qt[i])  # raises the row's error
    return p, qt, qt / norms[:, None]


@contextmanager
def collector_held() -> Iterator[None]:
    """Python's cyclic collector held off for the block (then as it was): while many
    results pile up. They make no reference cycles, but the collector, run again and
    again over them, cost 1.5 us a result more at 100,000 (G1's batch)."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


@dataclass(frozen=True, eq=False)
class IKResult:
    """What a solver did.

    Attributes:
        q: joint values ``(n,)`` [rad], in the chain's joint order.
        converged: error below the solver's tolerances.
        iterations: iterations (sweeps for CCD) over all restarts.
        position_error: distance from the end effector to the target [m] (for look-at,
            the distance from the target to the gaze ray).
        orientation_error: angle between achieved and target orientation [rad] (for
            look-at, between the forward axis and the target direction); ``None`` when
            the task had no orientation.
        status: ``converged``, ``max_iterations`` or ``unreachable``.
        solver: the solver's name.
        message: why it did not converge, or ``""``.
        details: the solver's intermediate values by name, a read-only mapping (a
            ``dict`` given is copied behind ``MappingProxyType``; empty for a solver that
            reports none). ``two_link`` gives the elbow's interior angle
            ``phi``, ``theta2 = +-(phi - pi)``, the branch, and per shoulder kind the
            worksheet's angles (see ``docs/two_link.md``). Values are floats, strings,
            tuples and named tuples; not part of equality.
    """

    q: NDArray[np.float64]
    converged: bool
    iterations: int
    position_error: float
    orientation_error: float | None
    status: Status
    solver: str = ""
    message: str = ""
    details: Mapping[str, Any] = field(default_factory=lambda: _NO_DETAILS, compare=False)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status '{self.status}' unknown; statuses: {', '.join(STATUSES)}")
        object.__setattr__(self, "status", Status(self.status))
        q = np.array(self.q, dtype=np.float64)
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        if isinstance(self.details, dict):
            object.__setattr__(self, "details", MappingProxyType(self.details.copy()))

    def __eq__(self, other: object) -> bool:
        """Equal when every field but ``details`` is (``q`` element by element)."""
        if not isinstance(other, IKResult):
            return NotImplemented
        mine, theirs = self.__reduce__()[1][:-1], other.__reduce__()[1][:-1]
        return bool(np.array_equal(mine[0], theirs[0])) and mine[1:] == theirs[1:]

    __hash__ = None  # type: ignore[assignment]  # as a dataclass with eq: not hashable

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled with ``details`` as a plain dict (a ``MappingProxyType`` does not
        pickle), so results come back from worker processes (``solve_batch``)."""
        fields = (self.q, self.converged, self.iterations, self.position_error)
        rest = (self.orientation_error, self.status.value, self.solver, self.message)
        return (IKResult, (*fields, *rest, dict(self.details)))

    @classmethod
    def unchecked(
        cls,
        q: NDArray[np.float64],
        converged: bool,
        iterations: int,
        position_error: float,
        orientation_error: float | None,
        status: Status,
        solver: str,
        message: str = "",
        details: Mapping[str, Any] = _NO_DETAILS,
    ) -> IKResult:
        """A result from values a solver already made right (``q`` a read-only float64
        ``(n,)`` array, which may view a larger read-only one; ``status`` a
        :class:`Status`; ``details`` read-only),
        taken as they are: what :func:`~humanoid_ik.solvers.batch.solve_batch` builds for
        each of many answers of the compiled ``lm`` loop (about 2 us a result saved)."""
        new = object.__new__(cls)
        new.__dict__.update(
            q=q, converged=converged, iterations=iterations, position_error=position_error,
            orientation_error=orientation_error, status=status, solver=solver,
            message=message, details=details,
        )  # fmt: skip
        return new

    def with_details(self, **extra: Any) -> IKResult:
        """This result with ``extra`` added to its ``details`` (the other fields shared:
        they are immutable, ``q`` read-only), without re-checking them."""
        new = object.__new__(IKResult)
        new.__dict__.update(self.__dict__)
        # extra is this call's own dict: taken as it is where there is nothing to merge
        details = {**self.details, **extra} if self.details else extra
        new.__dict__["details"] = MappingProxyType(details)
        return new

    def to_dict(self, joint_names: list[str] | None = None) -> dict[str, Any]:
        """A JSON-ready dict (joint values by name when ``joint_names`` is given; the
        ``details`` key only when the solver reported some)."""
        q = [float(v) for v in self.q]
        return {
            "solver": self.solver,
            "status": self.status.value,
            "converged": self.converged,
            "iterations": self.iterations,
            "position_error_m": self.position_error,
            "orientation_error_rad": self.orientation_error,
            "q": dict(zip(joint_names, q, strict=True)) if joint_names else q,
            "message": self.message,
            **({"details": _plain(self.details)} if self.details else {}),
        }


BatchArrays = tuple[
    NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]
]
"""A batch's ``q``, ``converged``, ``position_error`` and ``orientation_error``."""


class BatchResults(Sequence[IKResult]):
    """The answers of :func:`~humanoid_ik.solvers.batch.solve_batch`: one
    :class:`IKResult` per target, in order, and the same answers as arrays.

    A sequence (``len``, indexing, slices, iteration; equal to a list or tuple of equal
    results): each :class:`IKResult` is made when first read, so a batch that is read as
    arrays never makes one (a result costs about 0.5 us of Python; a UR5 pose solve in C
    about 1). The arrays are read-only:

    - ``q`` ``(N, n)``: the joints [rad] (row ``i`` is ``self[i].q``);
    - ``converged`` ``(N,)``: bool;
    - ``position_error`` ``(N,)`` [m] and ``orientation_error`` ``(N,)`` [rad], NaN
      where a target had no orientation (``self[i].orientation_error`` is ``None``).
    """

    def __init__(
        self,
        count: int,
        row: Callable[[int], IKResult],
        arrays: BatchArrays | None = None,
    ):
        """``count`` results, result ``i`` made by ``row(i)``; ``arrays`` (``q``,
        ``converged``, ``position_error``, ``orientation_error``, as the class says) when
        the caller has them, else gathered from the results when first read."""
        self._count, self._row = count, row
        self._made: list[IKResult | None] = [None] * count
        self._arrays = arrays
        if arrays is not None:
            for a in arrays:
                a.setflags(write=False)

    @classmethod
    def of(cls, results: Sequence[IKResult]) -> BatchResults:
        """Results already made, as a batch."""
        batch = cls(len(results), results.__getitem__)
        batch._made = list(results)
        return batch

    def __len__(self) -> int:
        return self._count

    @overload
    def __getitem__(self, index: int) -> IKResult: ...
    @overload
    def __getitem__(self, index: slice) -> list[IKResult]: ...
    def __getitem__(self, index: int | slice) -> IKResult | list[IKResult]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._count))]
        i = index.__index__()
        if i < 0:
            i += self._count
        if not 0 <= i < self._count:
            raise IndexError(f"result {index} of a batch of {self._count}")
        made = self._made[i]
        if made is None:
            made = self._made[i] = self._row(i)
        return made

    def __iter__(self) -> Iterator[IKResult]:
        with collector_held():  # the results pile up: no collector pass per few hundred
            made = [self[i] for i in range(self._count)]
        return iter(made)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, (BatchResults, list, tuple)):
            return NotImplemented
        return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))

    __hash__ = None  # type: ignore[assignment]  # a sequence that compares by value

    def __repr__(self) -> str:
        return f"BatchResults({self._count} results)"

    def _gathered(self) -> BatchArrays:
        if self._arrays is None:
            results = list(self)
            n = len(results[0].q) if results else 0
            q = np.array([r.q for r in results], dtype=np.float64).reshape(len(results), n)
            ok = np.array([r.converged for r in results], dtype=bool)
            ep = np.array([r.position_error for r in results], dtype=np.float64)
            er = np.array(
                [np.nan if r.orientation_error is None else r.orientation_error for r in results],
                dtype=np.float64,
            )
            self._arrays = (q, ok, ep, er)
            for a in self._arrays:
                a.setflags(write=False)
        return self._arrays

    @property
    def q(self) -> NDArray[np.float64]:
        """The joints ``(N, n)`` [rad]."""
        return self._gathered()[0]

    @property
    def converged(self) -> NDArray[np.bool_]:
        """Which targets converged ``(N,)``."""
        return self._gathered()[1]

    @property
    def position_error(self) -> NDArray[np.float64]:
        """The position errors ``(N,)`` [m]."""
        return self._gathered()[2]

    @property
    def orientation_error(self) -> NDArray[np.float64]:
        """The orientation errors ``(N,)`` [rad], NaN for a position target."""
        return self._gathered()[3]


def _plain(value: Any) -> Any:
    """``value`` as JSON-ready data: mappings and named tuples to dicts, other tuples and
    arrays to lists, numpy numbers to Python ones."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, tuple) and hasattr(value, "_asdict"):  # a NamedTuple
        return {k: _plain(v) for k, v in value._asdict().items()}
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


class EffectorGoal(NamedTuple):
    """One effector's task, as handed to a solver that moves several effectors at once."""

    chain: Chain
    """The effector's chain (all goals share one ``MjModel``)."""
    target: Target
    """Where the site must go (``reach``) or what it must look at (``look_at``)."""
    q0: NDArray[np.float64]
    """Warm start ``(n,)`` [rad]: the chain's joints at the previous frame."""
    task: str
    """``reach`` or ``look_at`` (aim the site's x axis at the target)."""
