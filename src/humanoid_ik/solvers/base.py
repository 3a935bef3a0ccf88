"""The solver protocol: options, applicability, and the error measure all solvers share."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError, choices

__all__ = ["Solver", "pose_error"]


def pose_error(chain: Chain, target: Target, out: NDArray[np.float64]) -> tuple[float, float]:
    """Fill ``out`` with the task error at the chain's current kinematics.

    ``out[:3] = p_target - p_site`` [m]; for a pose target ``out[3:6]`` is the world-frame
    rotation vector ``w`` with ``R_target = exp([w]x) R_site`` [rad], from ``mju_subQuat``.

    Returns:
        ``(position error [m], orientation error [rad] or nan)``.
    """
    np.subtract(target.position, chain.position, out=out[:3])
    ep = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2])
    if target.quat is None:
        return ep, math.nan
    buf = chain._quat_buf
    mujoco.mju_mat2Quat(buf[0], chain.rotation.reshape(9))
    mujoco.mju_subQuat(buf[1, :3], target.quat, buf[0])  # site frame
    np.dot(chain.rotation, buf[1, :3], out=out[3:6])
    er = math.sqrt(out[3] * out[3] + out[4] * out[4] + out[5] * out[5])
    return ep, er


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
        err = np.empty(6)
        ep, er = pose_error(chain, target, err)
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
