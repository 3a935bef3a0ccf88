"""Cyclic coordinate descent with a nudge factor (lecture notes, IK method 2).

One joint's update is :func:`step`, the lecture's rotation of one hinge toward the
target; the solver :class:`CCD` sweeps the same update (:func:`_turn`) over the chain
from the tip to the root, with pattern moves between sweeps and seeded restarts.
``docs/ccd.md`` follows the lecture's worked example through :func:`step`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple, Self

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.rotations import hinge_angle_between
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers.base import Solver, error_buffers
from humanoid_ik.solvers.iterate import Best, Stall, pose_cost
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["CCD", "CCDOptions", "CCDStep", "into_range", "step"]

_TAU = 2.0 * math.pi
_MAX_STRIDE = 1024.0  # largest pattern-move multiple of a sweep's joint step


def _check_nudge(nudge: float) -> None:
    """Raises SolverError unless ``0 < nudge <= 1``."""
    if not 0.0 < nudge <= 1.0:
        raise SolverError(f"option 'nudge' of solver 'ccd' must be in (0, 1], got {nudge}")


@dataclass(frozen=True)
class CCDOptions(SolverOptions):
    """Options of ``ccd``.

    Attributes:
        nudge: fraction ``c`` of each joint's best angle applied per update, in (0, 1].
        max_iterations: sweeps per start.
        restarts: further starts (seeded random in-range poses) after a stall. When
            ``max_iterations`` is given and ``restarts`` is not, ``restarts`` is 0: a
            caller who counts sweeps gets the sweeps of the one start ``q0``, never a pose
            from a random restart (see :meth:`parse`).
        stall_window: sweeps without a 1 % gain that count as a stall.
        seed: seed of the random restarts.
        pattern_moves: with a unit ``nudge``, after each sweep but the last, try moving
            on along the sweep's joint step (a Hooke-Jeeves pattern move, kept only when
            it brings the end effector closer). ``False`` runs the lecture's plain sweeps;
            so does a ``nudge`` below 1, which asks for damped turns that a pattern move
            would multiply away.
    """

    nudge: float = 1.0
    max_iterations: int = 300
    restarts: int = 10
    stall_window: int = 15
    seed: int = 0
    pattern_moves: bool = True
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "max_iterations": (0, 100_000),
        "restarts": (0, 1_000),
        "stall_window": (0, 100_000),
    }
    """Sweeps, restarts and the stall window bound a solve's time (``nudge`` is checked
    to lie in (0, 1] when the options are made)."""

    def __post_init__(self) -> None:
        _check_nudge(self.nudge)

    @classmethod
    def parse(cls, solver: str, given: Mapping[str, Any]) -> Self:
        """The options from keyword values, with the restarts rule: ``max_iterations``
        given without ``restarts`` means ``restarts = 0``.

        Raises:
            SolverError: an unknown name or a bad value (see :class:`SolverOptions`).
        """
        if "max_iterations" in given and "restarts" not in given:
            given = {**given, "restarts": 0}
        return super().parse(solver, given)


class CCDStep(NamedTuple):
    """What one joint's CCD update did (:func:`step`)."""

    joint: int
    """Index of the joint in the chain (``0`` is the root)."""
    phi: float
    """The lecture's angle toward the target about the hinge, before the nudge and the
    range [rad]: ``atan2(u . (r_p x w_p), r_p . w_p)``."""
    angle: float
    """The change of the joint's value [rad]: ``nudge * phi`` unless the range stopped
    it (or took the same pose ``2 pi`` away)."""
    axis: NDArray[np.float64]
    """The hinge's unit axis ``(3,)`` in the world frame, before the turn."""
    q: NDArray[np.float64]
    """The chain's joint values after the turn ``(n,)`` [rad]."""
    position: NDArray[np.float64]
    """The end effector after the turn ``(3,)`` [m], from MuJoCo FK."""


def into_range(x: float, lo: float, hi: float) -> float:
    """The joint value in ``[lo, hi]`` whose hinge pose is nearest to the pose at ``x``.

    Hinge values ``2 pi`` apart are one pose, so ``x`` itself when it lies in the range,
    else ``x + 2 pi k`` when one lies in it (the nearest such), else the range end
    nearest to ``x`` on the circle: ``argmin_{b in {lo, hi}} |wrap(x - b)|`` with
    ``wrap`` into ``[-pi, pi]``. For a unit nudge this is the exact minimiser of the
    distance to the target over the joint's range (that distance, ``A - B cos(t - t*)``
    in the joint value ``t``, is unimodal on the circle), where plain clipping can stop
    the joint at the far end: clipping never does better.

    Args:
        x: the wanted joint value [rad].
        lo: lower end of the range [rad] (``-inf`` when unlimited).
        hi: upper end of the range [rad] (``inf`` when unlimited).
    """
    if lo <= x <= hi:
        return x
    if x < lo:
        y = x + _TAU * math.ceil((lo - x) / _TAU)
        if y <= hi:
            return y
    else:
        y = x - _TAU * math.ceil((x - hi) / _TAU)
        if y >= lo:
            return y
    d_lo = abs(math.remainder(x - lo, _TAU))
    d_hi = abs(math.remainder(x - hi, _TAU))
    return lo if d_lo <= d_hi else hi


def _turn(chain: Chain, pd: NDArray[np.float64], i: int, c: float, q: NDArray) -> float:
    """Turn joint ``i`` toward ``pd`` (one CCD update; the kinematics must be current).

    ``q`` ``(n,)`` is the chain's joint vector, updated in place with the scratch
    ``qpos``; MuJoCo's kinematics are re-run. Returns the lecture's angle ``phi`` [rad].
    """
    m, d = chain.model, chain.data
    j = chain.joint_ids[i]
    anchor = d.xanchor[j]
    phi = hinge_angle_between(d.xaxis[j], chain.position - anchor, pd - anchor)
    q[i] = into_range(q[i] + c * phi, chain.lower[i], chain.upper[i])
    d.qpos[chain.qpos_adr[i]] = q[i]
    mujoco.mj_kinematics(m, d)
    return phi


def _joint_index(chain: Chain, joint: int | str) -> int:
    """The chain index of ``joint`` (an index or a joint name).

    Raises:
        SolverError: no such joint in the chain (the valid ones are listed).
    """
    if isinstance(joint, str):
        if joint in chain.joint_names:
            return chain.joint_names.index(joint)
        raise SolverError(f"joint '{joint}' not in the chain; joints: {choices(chain.joint_names)}")
    if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool):
        if 0 <= joint < chain.n:
            return int(joint)
    raise SolverError(
        f"joint {joint!r} not in the chain; indices 0 to {chain.n - 1} "
        f"({', '.join(chain.joint_names)}) or a name"
    )


def step(chain: Chain, target: Target | ArrayLike, joint: int | str, nudge: float = 1.0) -> CCDStep:
    """One joint's CCD update, as the lecture does it, on the chain's scratch data.

    With ``p`` the end effector, ``a`` the joint's anchor, ``u`` its unit axis and
    ``p_d`` the target: ``r = p - a``, ``e = p_d - p``; the lecture's angle from ``r`` to
    ``r + e`` is ``phi = atan2(|r x e|, r.r + r.e)``. A hinge turns about ``u`` only, so
    ``r`` and ``w = r + e`` are first projected on the plane normal to ``u``
    (``r_p = r - (r.u) u``) and ``phi = atan2(u . (r_p x w_p), r_p . w_p)``, signed
    about ``u`` (the lecture's value when ``u`` is parallel to ``r x e``). The joint
    goes to ``q_i + nudge * phi``, brought into its range by :func:`into_range` (the
    same pose when that value lies in the range). The solver's sweeps run this update.

    Args:
        chain: the chain; its scratch data's current joint values are the start.
        target: the target position ``(3,)`` [m] (a :class:`Target` without orientation).
        joint: the joint's index in the chain (``0`` is the root) or its name.
        nudge: the fraction ``c`` of ``phi`` applied, in ``(0, 1]``.

    Returns:
        The angles, the new joint values and the new end-effector position.

    Raises:
        SolverError: an unknown joint, a pose target or a nudge outside ``(0, 1]``.
        TargetError: a bad target position.
    """
    tgt = Target.of(target)
    if tgt.is_pose:
        raise SolverError("ccd solves position targets only")
    _check_nudge(nudge)
    i = _joint_index(chain, joint)
    q = chain.q
    chain.set_q(q)
    before = float(q[i])
    axis = chain.data.xaxis[chain.joint_ids[i]].copy()
    phi = _turn(chain, tgt.position, i, nudge, q)
    return CCDStep(i, phi, float(q[i]) - before, axis, q, chain.position.copy())


class CCD(Solver):
    """Visit each joint from the end effector to the root and turn it toward the target.

    A sweep applies :func:`step`'s update to joints ``n-1, ..., 0``, FK re-read from
    MuJoCo after every joint. Between sweeps, with ``pattern_moves`` and a unit
    ``nudge``, the solver tries to go on along the sweep's joint step ``dq``
    (``q_new - q_old``): the candidate ``clip(q + s dq)`` is kept when it brings the end
    effector closer, and the stride ``s`` doubles after a kept move (up to 1024) and
    halves after a refused one (down to 1). Plain CCD is slow near a stretched arm, where
    each sweep unbends the elbow by a sliver (about ``b (b^2 - b*^2) / 8`` per sweep for
    an elbow at ``b`` that must reach ``b*``, two unit links; near ``b*`` the error
    shrinks by ``1 - b*^2 / 4`` per sweep): the pattern move takes those slivers in
    strides.

    Sweeps repeat until ``|p_d - p| < tol`` or ``max_iterations`` sweeps. A run that
    makes less than 1 % progress in ``stall_window`` sweeps restarts from a seeded random
    in-range pose, up to ``restarts`` times; the best pose seen is returned, and its
    ``message`` says so when it came from a restart rather than ``q0``.
    """

    name: ClassVar[str] = "ccd"
    summary: ClassVar[str] = "cyclic coordinate descent with a nudge factor"
    Options: ClassVar[type[SolverOptions]] = CCDOptions
    options: CCDOptions

    def _solve(self, chain: Chain, target: Target, q0: np.ndarray) -> IKResult:
        best = Best(q0)
        first_err = math.inf
        sweeps = 0
        for k, q in enumerate(self.starts(chain, q0, target)):
            done, err, n = self._run(chain, target.position, q)
            sweeps += n
            if k == 0:
                first_err = err
            best.offer(q, pose_cost(err), k)
            if done:
                break
        note = "" if best.start == 0 else self._restart_note(best.start, first_err)
        if best.cost < self.options.tol:
            return self._result(chain, target, best.q, sweeps, message=note)
        message = self.gave_up() + (f"; {note}" if note else "")
        return self._result(chain, target, best.q, sweeps, message=message)

    def _restart_note(self, k: int, first_err: float) -> str:
        """The message of a result whose pose came from restart ``k``."""
        o = self.options
        return (
            f"NOTE: this pose comes from restart {k} of {o.restarts} (a seeded random "
            f"in-range pose, seed {o.seed}), not from q0, whose run ended "
            f"{first_err:.3g} m from the target"
        )

    def _run(self, chain: Chain, pd: np.ndarray, q: np.ndarray) -> tuple[bool, float, int]:
        """Sweeps from ``q`` (updated in place): ``(converged, error [m], sweeps)``."""
        chain.set_q(q)
        c, tol = self.options.nudge, self.options.tol
        last = self.options.max_iterations
        stalled = Stall(self.options.stall_window)
        err = math.inf
        before = q.copy()
        stride = 1.0
        pattern = self.options.pattern_moves and c == 1.0
        for sweep in range(1, last + 1):
            before[:] = q
            for i in range(chain.n - 1, -1, -1):
                _turn(chain, pd, i, c, q)
            err = self._error(chain, pd)
            if err < tol:
                return True, err, sweep
            if pattern and sweep < last:
                err, stride = self._pattern_move(chain, pd, q, q - before, err, stride)
                if err < tol:
                    return True, err, sweep
            if stalled(sweep - 1, err):  # the sweeps count from 1
                return False, err, sweep
        return False, err, last

    def _error(self, chain: Chain, pd: np.ndarray) -> float:
        """The position error [m] at the current kinematics (:func:`pose_error`)."""
        return pose_error(chain.position, chain.rotation, pd, None, *error_buffers(chain))[0]

    def _pattern_move(
        self, chain: Chain, pd: np.ndarray, q: np.ndarray, dq: np.ndarray, err: float, stride: float
    ) -> tuple[float, float]:
        """Try ``clip(q + stride dq)``; keep it in ``q`` when it is closer than ``err``.

        Returns the error [m] at ``q`` afterwards and the next stride.
        """
        trial = chain.clip(q + stride * dq)
        chain.set_q(trial)
        e = self._error(chain, pd)
        if e < err:
            q[:] = trial
            return e, min(2.0 * stride, _MAX_STRIDE)
        chain.set_q(q)
        return err, max(0.5 * stride, 1.0)
