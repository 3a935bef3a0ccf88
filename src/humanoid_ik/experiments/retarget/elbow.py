"""The human elbow's direction on a robot arm, in the solvers' terms.

The arm's shoulder, elbow and wrist points and "the elbow points at a pole" are the
solvers' (:mod:`humanoid_ik.solvers.analytic.elbow`: :func:`arm_points`,
:func:`pole_angle`); a wanted elbow *direction* ``d`` (a unit offset from the
shoulder-wrist line, :mod:`.targets`) is the pole ``S + d`` (:func:`pole_for`). What a
retarget adds:

- :func:`elbow_error`: the pole's angle to the elbow's plane and how bent the arm is
  (below :data:`~.targets.BENT` the direction is not measured);
- :func:`swivel_for`: ``closed_form``'s swivel (its own frame, ``swivel_frame``) that
  points the elbow along a direction: the swivel plan (:mod:`.plan`) and the partial
  pull of a frame need the angle itself, not only the pole;
- :func:`elbow_steps`: the partial pull of an ``lm`` arm, before its solve: one
  weighted null-space step, where ``lm``'s own :func:`~humanoid_ik.solvers.jacobian.lm.pole_steps`
  would turn the elbow all the way after it (a frame's pull is halved within the speed
  limits, and the first frame's is the full one: there ``Target.pole`` is used).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import rotation_log
from humanoid_ik.solvers.analytic.closed_form.geometry import arm_context
from humanoid_ik.solvers.analytic.closed_form.numeric import FLOATS
from humanoid_ik.solvers.analytic.closed_form.swivel import start_elbow, swivel_frame, wrist_target
from humanoid_ik.solvers.analytic.elbow import arm_points, elbow_frame, pole_angle

__all__ = ["elbow_error", "elbow_steps", "pole_for", "swivel_axes", "swivel_for", "swivels_of"]


def pole_for(chain: Chain, want: NDArray[np.float64]) -> NDArray[np.float64]:
    """The pole ``(3,)`` [m] that asks for the elbow direction ``want``: the shoulder
    point plus it."""
    return np.asarray(arm_points(chain).shoulder + want)


def elbow_error(chain: Chain, want: NDArray[np.float64]) -> tuple[float, float]:
    """(the angle [rad] between the elbow's half-plane now and that of ``want`` about the
    shoulder-wrist line, :func:`pole_angle`; the elbow's distance from that line over the
    upper arm's length); the angle is NaN for a straight arm."""
    pts = arm_points(chain)
    S, E, W = pts
    up = E - S
    line = W - S
    u = line / max(float(np.linalg.norm(line)), 1e-12)
    bend = float(np.linalg.norm(up - float(up @ u) * u) / max(float(np.linalg.norm(up)), 1e-12))
    return pole_angle(pts, S + want), bend


def swivel_for(
    chain: Chain, position: NDArray, rotation: NDArray | None, want: NDArray[np.float64]
) -> float:
    """The ``closed_form`` swivel [rad] that points the elbow along ``want`` for a hand at
    ``position`` (``rotation``: a pose target, whose wrist point the swivel turns about),
    in ``closed_form``'s own frame (:func:`swivel_frame`: 0 on the side of the line
    facing gravity), as its pole search starts from a pole."""
    r, k = swivel_axes(chain, position, rotation)
    return math.atan2(float(want @ k), float(want @ r))


def swivel_axes(
    chain: Chain, position: NDArray, rotation: NDArray | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(r, k)``: the unit axes of ``closed_form``'s swivel frame for that hand target
    (:func:`swivel_frame`): an elbow offset ``e`` has the swivel ``atan2(e . k, e . r)``."""
    ctx = arm_context(chain)
    S = ctx.S
    if rotation is not None:
        t = wrist_target(ctx, position.tolist(), rotation.tolist())
    else:
        t = (float(position[0]) - S[0], float(position[1]) - S[1], float(position[2]) - S[2])
    _, r, k = swivel_frame(FLOATS, ctx, t, ctx.rest)
    return np.array(r, dtype=np.float64), np.array(k, dtype=np.float64)


def swivels_of(chain: Chain, q: NDArray[np.float64], r: NDArray, k: NDArray) -> NDArray:
    """The swivels [rad] ``closed_form``'s answers ``q (..., n)`` are at, in the frames
    ``r, k (..., 3)`` (:func:`swivel_axes`): the shoulder's turn of the rest elbow offset,
    vectorised (what the answer's elbow shows, where ``closed_form`` took the feasible
    swivel nearest the one asked for)."""
    ctx = arm_context(chain)
    a = np.moveaxis(q[..., :3], -1, 0)
    e = np.stack(start_elbow(ctx, tuple(np.cos(a)), tuple(np.sin(a))), axis=-1)
    return np.arctan2(np.sum(e * k, axis=-1), np.sum(e * r, axis=-1))


def _normal(v: NDArray[np.float64], n: NDArray[np.float64]) -> NDArray[np.float64] | None:
    p = v - float(v @ n) * n
    r = float(np.linalg.norm(p))
    return None if r < 1e-9 else p / r


def _damped_pinv(J: NDArray[np.float64], lam: float) -> NDArray[np.float64]:
    return np.asarray(J.T @ np.linalg.solve(J @ J.T + lam * np.eye(J.shape[0]), np.eye(J.shape[0])))


def elbow_steps(
    chain: Chain,
    q: NDArray[np.float64],
    position: NDArray[np.float64],
    rotation: NDArray[np.float64] | None,
    want: NDArray[np.float64],
    steps: int,
    weight: float = 1.0,
    free: int | None = None,
) -> NDArray[np.float64]:
    """``steps`` Gauss-Newton steps from ``q`` towards the hand target (the primary task)
    with the elbow turned about the shoulder-wrist line towards ``want``'s half-plane in
    the hand task's null space (the secondary one, as ``pole_steps``); each elbow step
    turns it by at most 0.3 rad, times ``weight`` (0: the hand alone). Only the first
    ``free`` joints move (default all; the first frame's start holds the wrist), the
    elbow is the whole arm's.
    Returns the joint values (inside the ranges); the chain is left at them."""
    c = chain
    frame = elbow_frame(c)
    k = frame.elbow
    n = c.n if free is None else free
    q = q.copy()
    for _ in range(steps):
        c.set_q(q)
        J = c.current_jacobian()[:, :n]
        e = np.empty(6)
        e[:3] = position - c.position
        if rotation is not None:
            e[3:] = rotation_log(rotation @ c.rotation.T)
            Jh = J
        else:
            e, Jh = e[:3], J[:3]
        Jp = _damped_pinv(Jh, 1e-8)
        dq = Jp @ e
        S, E, W = frame.points(c)
        u = (W - S) / max(float(np.linalg.norm(W - S)), 1e-12)
        up = E - S
        a, b = _normal(up, u), _normal(want, u)
        if a is not None and b is not None and k > 0 and weight > 0:
            # the elbow turned about u from a towards b: E - S = (along) u + r a, and
            # the turn by t moves r a to r (a cos t + (u x a) sin t)
            ua = np.array(
                [u[1] * a[2] - u[2] * a[1], u[2] * a[0] - u[0] * a[2], u[0] * a[1] - u[1] * a[0]]
            )
            err = math.atan2(float(ua @ b), float(a @ b))
            turn = weight * math.copysign(min(abs(err), 0.3), err)
            r = float(up @ a)  # a: the unit normal part of up
            dE = r * ((math.cos(turn) - 1.0) * a + math.sin(turn) * ua)
            anchors, axes = c.joint_axes()
            JE = np.zeros((3, n))
            JE[:, :k] = np.cross(axes[:k], E - anchors[:k]).T
            N = np.eye(n) - Jp @ Jh
            dq = dq + N @ (_damped_pinv(JE @ N, 1e-6) @ (dE - JE @ dq))
        q[:n] += dq
        q = c.clip(q)
    c.set_q(q)
    return q
