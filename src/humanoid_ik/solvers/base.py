"""The solver protocol: options, applicability, the gaze axis, and result measuring."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import axis_vector, pose_error
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError, choices

__all__ = ["Solver"]


class Solver(ABC):
    """An IK method. Subclasses set ``name``, ``defaults`` and implement ``_solve``.

    Options are keyword arguments checked against ``defaults``; every solver takes
    ``tol`` (position tolerance [m]) and ``rot_tol`` (orientation tolerance [rad]).
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    supports_orientation: ClassVar[bool] = False
    reaches: ClassVar[bool] = True
    """True for solvers that move the site onto the target (the bench's reaching tasks)."""
    defaults: ClassVar[dict[str, Any]] = {}
    _common: ClassVar[dict[str, Any]] = {"tol": 1e-4, "rot_tol": 1e-3}

    def __init__(self, **options: Any):
        valid = {**self._common, **self.defaults}
        for key, value in options.items():
            if key not in valid:
                raise SolverError(
                    f"option '{key}' unknown for solver '{self.name}'; options: {choices(valid)}"
                )
            valid[key] = self._check_option(key, value, valid[key])
        self.options = valid
        for key, value in valid.items():
            setattr(self, key, value)
        self._buffers = (np.empty(6), np.empty((2, 4)))  # error vector, quaternion scratch

    def _check_option(self, key: str, value: Any, default: Any) -> Any:
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise SolverError(
                    f"option '{key}' of solver '{self.name}' must be true or false, got {value!r}"
                )
            return value
        if isinstance(default, (int, float)):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SolverError(
                    f"option '{key}' of solver '{self.name}' must be a number, got {value!r}"
                )
            if not math.isfinite(value) or value < 0:
                raise SolverError(
                    f"option '{key}' of solver '{self.name}' must be a finite "
                    f"number >= 0, got {value!r}"
                )
            if isinstance(default, int):
                if value != int(value):
                    raise SolverError(
                        f"option '{key}' of solver '{self.name}' must be an integer, got {value!r}"
                    )
                return int(value)
            return float(value)
        if isinstance(default, str):
            allowed = getattr(self, f"{key}_choices", None)
            if not isinstance(value, str) or (allowed and value not in allowed):
                raise SolverError(
                    f"option '{key}' of solver '{self.name}' is {value!r}; "
                    f"choices: {choices(allowed or [])}"
                )
            return value
        return value

    def starts(self, chain: Chain, q0: NDArray[np.float64], target: Target | None = None):
        """``q0``, then ``restarts`` seeded random in-range poses (``seed`` option).

        Solvers with a better restart rule use ``target`` (see the Jacobian family)."""
        yield q0.copy()
        rng = np.random.default_rng(self.options.get("seed", 0))
        for _ in range(int(self.options.get("restarts", 0))):
            yield chain.random_q(rng)

    def gave_up(self) -> str:
        """The message of a result that did not converge from any start."""
        starts = int(self.options.get("restarts", 0)) + 1
        return (
            f"no start of {starts} converged; the closest pose is returned "
            "(the target may be out of reach within the joint ranges)"
        )

    def gaze_axis(self) -> NDArray[np.float64]:
        """The unit axis ``(3,)`` of the site frame this solver aims at a ``look_at``
        target (``x`` unless an option chooses another)."""
        return axis_vector(self.options.get("forward_axis", "x"))

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        """``None`` when the solver can solve this chain and task, else the reason it cannot."""
        if pose and not self.supports_orientation:
            return f"{self.name} solves position targets only"
        return None

    def solve(
        self, chain: Chain, target: Target | ArrayLike, q0: ArrayLike | None = None
    ) -> IKResult:
        """Solve from ``q0`` (default: the chain's current joint values, moved inside ranges).

        Works on the chain's scratch data; leaves it at the returned pose.

        Raises:
            TargetError: a bad target or ``q0``.
            SolverError: the solver does not apply to this chain or task.
        """
        tgt = Target.of(target)
        reason = self.applicable(chain, tgt.is_pose)
        if reason is not None:
            raise SolverError(reason)
        start = chain.q if q0 is None else chain.check_q(q0)
        result = self._solve(chain, tgt, chain.clip(start))
        return result

    @abstractmethod
    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        """Solve from ``q0`` (inside ranges) on the chain's scratch data."""

    def _result(
        self,
        chain: Chain,
        target: Target,
        q: NDArray[np.float64],
        iterations: int,
        status: str | None = None,
        message: str = "",
    ) -> IKResult:
        """Measure ``q`` with MuJoCo FK and wrap it; status from the tolerances unless given."""
        chain.set_q(q)
        ep, er = pose_error(
            chain.position, chain.rotation, target.position, target.quat, *self._buffers
        )
        ok = ep < self.tol and (target.quat is None or er < self.rot_tol)
        if status is None:
            status = "converged" if ok else "max_iterations"
        return IKResult(
            q=q.copy(),
            converged=status == "converged",
            iterations=iterations,
            position_error=ep,
            orientation_error=None if target.quat is None else er,
            status=status,
            solver=self.name,
            message=message,
        )
