"""FABRIK, forward and backward reaching inverse kinematics (Aristidou and Lasenby 2011),
on any chain of hinges, for position targets, with the joint ranges applied after
every iteration.

FABRIK works on points, not angles: the chain is the polyline of its joint positions
``p_0 .. p_m`` (the distinct hinge anchors, hinges about one point counted once, then
the end effector) with fixed segment lengths ``d_i = |p_{i+1} - p_i|`` (hinges keep
them). One iteration is two passes (:func:`passes`): *backward*, the end effector put on
the target and each point moved back along the line to its successor to keep ``d_i``;
*forward*, the base put back and each point moved along the line from its predecessor.
A target out of reach straightens the chain toward it.

A MuJoCo chain is hinges, so after every iteration the points are taken back to joint
angles (:func:`fit_angles`), as the paper's constrained version applies each joint's
constraint after a pass: from the root to the tip, each hinge turns by the angle that
best aligns the chain below it with the points (the least-squares turn about its axis
of the vectors from its anchor to every later point, ``atan2(sum u . (v_p x w_p),
sum v_p . w_p)``, the CCD rule of ``solvers/ccd.py`` over several points), brought into
its range by :func:`~humanoid_ik.solvers.ccd.into_range` (the in-range pose nearest on
the circle), then MuJoCo's forward kinematics run; the end of the hinge's child
segment weighs most, each later point a tenth of the one before. The next iteration starts from the
points of that feasible pose. ``docs/fabrik.md`` explains why and what it costs.

The iterate, stall and restart rule is ``solvers/iterate.py``'s: iterations until the
error is below ``tol``, less than 1 % progress in ``stall_window`` iterations ends a
start, ``restarts`` seeded random in-range starts, the best pose returned.
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
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.solvers.base import Solver, error_buffers
from humanoid_ik.solvers.ccd import into_range
from humanoid_ik.solvers.iterate import Best, Stall, pose_cost
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["FABRIK", "FABRIKOptions", "fit_angles", "groups", "passes"]

_SAME_POINT = 1e-9
"""Anchors closer than this [m] are one point of the polyline."""
_WEIGHTS = 0.1 ** np.arange(64)
"""The weights of the points after a hinge in its fit: its child segment's end first,
each later point ten times less (they settle what the nearer ones leave free, such as
the turn of a hinge along its child segment)."""
_MAX_STRIDE = 1024.0
"""Largest pattern-move multiple of an iteration's joint step (as ``ccd``'s)."""


@dataclass(frozen=True)
class FABRIKOptions(SolverOptions):
    """Options of ``fabrik``.

    Attributes:
        max_iterations: iterations (a backward and a forward pass, then the angles) per
            start.
        restarts: further starts (seeded random in-range poses) after a stall.
        stall_window: iterations without a 1 % gain that count as a stall.
        seed: seed of the random restarts.
        pattern_moves: after each iteration but the last, try moving on along the
            iteration's joint step (a Hooke-Jeeves pattern move, as ``ccd`` does, kept
            only when it brings the end effector closer). FABRIK, like CCD, crawls
            toward a target near the chain's full reach; ``False`` runs plain iterations.
    """

    max_iterations: int = 200
    restarts: int = 10
    stall_window: int = 10
    seed: int = 0
    pattern_moves: bool = True
    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "max_iterations": (0, 100_000),
        "restarts": (0, 1_000),
        "stall_window": (0, 100_000),
    }
    """Iterations, restarts and the stall window bound a solve's time."""


def groups(chain: Chain) -> NDArray[np.int64]:
    """``(n,)`` the point of the polyline each joint turns about, at the current
    kinematics: joints whose anchors coincide (a spherical shoulder) share a point;
    point ``k`` is the anchor of the first joint of group ``k``, the end effector comes
    after the last group. Hinges keep this grouping in every pose."""
    anchors = chain.data.xanchor[chain.joint_ids]
    out = np.zeros(chain.n, dtype=np.int64)
    for i in range(1, chain.n):
        same = float(np.linalg.norm(anchors[i] - anchors[i - 1])) <= _SAME_POINT
        out[i] = out[i - 1] + (0 if same else 1)
    return out


def _points(chain: Chain, first: NDArray[np.int64]) -> NDArray[np.float64]:
    """``(m + 1, 3)`` the polyline at the current kinematics: the anchors of the joints
    ``first`` (one per group), then the end effector."""
    return np.vstack([chain.data.xanchor[chain.joint_ids[first]], chain.position])


def passes(
    points: NDArray[np.float64], target: NDArray[np.float64], lengths: NDArray[np.float64]
) -> NDArray[np.float64]:
    """One FABRIK iteration on ``points`` ``(m + 1, 3)`` toward ``target``: a backward
    and a forward pass, or the chain straightened toward a target beyond its reach.
    ``lengths`` ``(m,)`` are the segments' lengths. Returns new points (the base kept)."""
    p = points.copy()
    base = p[0].copy()
    m = len(lengths)

    def along(a: NDArray[np.float64], b: NDArray[np.float64], d: float) -> NDArray[np.float64]:
        """The point at distance ``d`` from ``a`` toward ``b`` (``b`` itself when they meet)."""
        r = float(np.linalg.norm(b - a))
        return b.copy() if r < 1e-12 else a + (d / r) * (b - a)

    if float(np.linalg.norm(target - base)) >= float(lengths.sum()):
        for i in range(m):
            p[i + 1] = along(p[i], target, float(lengths[i]))
        return p
    p[m] = target
    for i in range(m - 1, -1, -1):  # backward: from the end effector on the target
        p[i] = along(p[i + 1], p[i], float(lengths[i]))
    p[0] = base
    for i in range(m):  # forward: from the base back in place
        p[i + 1] = along(p[i], p[i + 1], float(lengths[i]))
    return p


def fit_angles(
    chain: Chain, goal: NDArray[np.float64], group: NDArray[np.int64], q: NDArray[np.float64]
) -> None:
    """Turn the chain's hinges, root to tip, so that its polyline follows ``goal``
    ``(m + 1, 3)`` as closely as each hinge can, inside the ranges; ``q`` (the chain's
    joint values, current in the scratch data) is updated in place and the kinematics
    are current afterwards.

    Hinge ``i`` (anchor ``a``, unit axis ``u``) turns by the weighted least-squares
    angle that takes the vectors ``v_k = p_k - a`` from it to the later points of the
    polyline toward ``w_k = goal_k - a``: with ``_p`` the part normal to ``u`` and
    weights ``c_k = 0.1^k`` (``k = 0`` its child segment's end),
    ``t = atan2(sum_k c_k u . (v_kp x w_kp), sum_k c_k v_kp . w_kp)``, then into its
    range.
    """
    m, d = chain.model, chain.data
    lo, hi = chain.lower, chain.upper
    first = np.flatnonzero(np.r_[True, np.diff(group) > 0])
    for i in range(chain.n):
        j = chain.joint_ids[i]
        a, u = d.xanchor[j], d.xaxis[j]
        later = slice(int(group[i]) + 1, None)
        v = _points(chain, first)[later] - a
        w = goal[later] - a
        v -= np.outer(v @ u, u)
        w -= np.outer(w @ u, u)
        weight = _WEIGHTS[: len(v)]
        s = float(weight @ (np.cross(v, w) @ u))
        c = float(weight @ np.sum(v * w, axis=1))
        if abs(s) + abs(c) <= 1e-18:
            continue
        q[i] = into_range(float(q[i]) + math.atan2(s, c), float(lo[i]), float(hi[i]))
        d.qpos[chain.qpos_adr[i]] = q[i]
        mujoco.mj_kinematics(m, d)


class FABRIK(Solver):
    """Forward and backward reaching IK on the chain's joint positions, taken back to
    in-range hinge angles after every iteration (see the module docstring).

    Iterates until ``|p_d - p| < tol`` or ``max_iterations``; a start that makes less
    than 1 % progress in ``stall_window`` iterations ends, and the next of ``restarts``
    seeded random in-range poses starts; the best pose seen is returned.
    """

    name: ClassVar[str] = "fabrik"
    summary: ClassVar[str] = "forward and backward reaching IK on the joint positions"
    Options: ClassVar[type[SolverOptions]] = FABRIKOptions
    options: FABRIKOptions

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        best = Best(q0)
        chain.set_q(q0)
        group = groups(chain)
        first = np.flatnonzero(np.r_[True, np.diff(group) > 0])
        lengths = np.linalg.norm(np.diff(_points(chain, first), axis=0), axis=1)
        iterations = 0
        first_err = math.inf
        for k, q in enumerate(self.starts(chain, q0, target)):
            done, err, n = self._run(chain, target.position, q, group, first, lengths)
            iterations += n
            if k == 0:
                first_err = err
            best.offer(q, pose_cost(err), k)
            if done:
                break
        note = ""
        if best.start:
            o = self.options
            note = (
                f"NOTE: this pose comes from restart {best.start} of {o.restarts} (a seeded "
                f"random in-range pose, seed {o.seed}), not from q0, whose run ended "
                f"{first_err:.3g} m from the target"
            )
        if best.cost < self.options.tol:
            return self._result(chain, target, best.q, iterations, message=note)
        message = self.gave_up() + (f"; {note}" if note else "")
        return self._result(chain, target, best.q, iterations, message=message)

    def _run(
        self,
        chain: Chain,
        pd: NDArray[np.float64],
        q: NDArray[np.float64],
        group: NDArray[np.int64],
        first: NDArray[np.int64],
        lengths: NDArray[np.float64],
    ) -> tuple[bool, float, int]:
        """Iterations from ``q`` (updated in place): ``(converged, error [m], iterations)``."""
        chain.set_q(q)
        tol, last = self.options.tol, self.options.max_iterations
        stalled = Stall(self.options.stall_window)
        err = self._error(chain, pd)
        if err < tol or last == 0:
            return err < tol, err, 0
        before = q.copy()
        stride = 1.0
        for it in range(1, last + 1):
            before[:] = q
            goal = passes(_points(chain, first), pd, lengths)
            fit_angles(chain, goal, group, q)
            err = self._error(chain, pd)
            if self.options.pattern_moves and err >= tol and it < last:
                err, stride = self._pattern_move(chain, pd, q, q - before, err, stride)
            if err < tol:
                return True, err, it
            if stalled(it - 1, err):
                return False, err, it
        return False, err, last

    def _pattern_move(
        self,
        chain: Chain,
        pd: NDArray[np.float64],
        q: NDArray[np.float64],
        dq: NDArray[np.float64],
        err: float,
        stride: float,
    ) -> tuple[float, float]:
        """Try ``clip(q + stride dq)``; keep it in ``q`` when it is closer than ``err``.
        The stride doubles after a kept move (up to :data:`_MAX_STRIDE`), halves after a
        refused one (down to 1). Returns the error [m] at ``q`` afterwards and the next
        stride."""
        trial = chain.clip(q + stride * dq)
        chain.set_q(trial)
        e = self._error(chain, pd)
        if e < err:
            q[:] = trial
            return e, min(2.0 * stride, _MAX_STRIDE)
        chain.set_q(q)
        return err, max(0.5 * stride, 1.0)

    def _error(self, chain: Chain, pd: NDArray[np.float64]) -> float:
        """The position error [m] at the current kinematics (:func:`pose_error`)."""
        return pose_error(chain.position, chain.rotation, pd, None, *error_buffers(chain))[0]
