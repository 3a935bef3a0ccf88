"""The swivel of a ``closed_form`` arm planned over the whole clip (the clip is known in
advance), for joint motion the speed limits allow.

Frame by frame, the human elbow's swivel is the natural choice, but a straight arm has
none, and near the shoulder's gimbal lock (the arm raised sideways, where the first and
third shoulder axes line up) the exact pose at one swivel may need a shoulder joint to
turn far faster than its limit while another swivel, which bends the upper arm away from
the locked direction, needs little. So the swivel is planned: at every frame the exact
answers at :data:`GRID` swivels (``closed_form``'s batch path, each warm-started from
the same swivel's answer at the planned frame before, so that each follows one branch), then the
path through them of least cost (dynamic programming, Viterbi): per frame the angle to
the human elbow's swivel times the elbow's weight (0 for a straight human arm: the
elbow is free there), plus per step the joint motion over the speed limits, squared
(:data:`MOTION_WEIGHT`: the smallest motion, so the swivel only moves where it must), and
a large price for a step over a limit (:data:`OVER_PRICE`) or a swivel the ranges do not
allow. The elbow's cost is that of the swivel each answer is *at*: where the ranges
forbid the grid's swivel, ``closed_form`` takes the feasible one nearest it (on the
branch of its start), and the plan must not count it as the one asked for. The steps
may use :data:`SPEED_SHARE` of the limits (the frames between planned ones do not move
evenly). The frame loop then solves each frame at its planned swivel, exactly, starting
``closed_form`` from the plan's own joints (:attr:`Plan.seeds`: its shoulder and wrist
branches; from the previous frame it would keep that frame's branch, and the swivel
nearest the planned one there can be far from it: ``models/robot``'s elbow was 68
degrees off on the reach across the body). What the plan could not do is kept for the
metrics: the frames whose pose no swivel reaches inside the ranges, and the plan's
largest speed over the limits (:attr:`Plan.in_ranges`, :attr:`Plan.speed_need`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.experiments.retarget.elbow import swivel_axes, swivel_for, swivels_of
from humanoid_ik.experiments.retarget.robot import RobotArm
from humanoid_ik.experiments.retarget.targets import STRAIGHT, ArmTargets
from humanoid_ik.solvers.analytic.closed_form import solve_batch

__all__ = ["ELBOW_WEIGHT", "GRID", "KEY", "MOTION_WEIGHT", "OVER_PRICE", "Plan", "plan_swivels"]

GRID = 48
"""Swivels tried per planned frame (every 7.5 degrees)."""
PASSES = 3
"""Batch passes that carry each swivel's branch from a planned frame to the next."""
KEY = 6
"""The plan's frames: every ``KEY``-th (20 per second at 120 Hz)."""
ELBOW_WEIGHT = 1.0
"""Cost of one radian between the planned swivel and the human elbow's (bent arm)."""
MOTION_WEIGHT = 0.05
"""Cost of a step's joint motion: the squared largest speed over its limit."""
OVER_PRICE = 100.0
"""Cost of a step over a speed limit, per unit of speed over the limit, plus one."""
SPEED_SHARE = 0.75
"""The share of the speed limits a step between planned frames may use: the frames
between, at interpolated swivels, do not move evenly, and the frame loop must keep up."""
INFEASIBLE = 1e4
"""Cost of a swivel at which the pose is out of reach or out of the ranges."""


class Plan(NamedTuple):
    """One arm's plan over the clip, per frame."""

    swivel: NDArray[np.float64]
    """``(F,)`` the planned swivel [rad]."""
    seeds: NDArray[np.float64]
    """``(F, n)`` the plan's joints (the planned frames' answers, interpolated between):
    ``closed_form``'s start, so that it lands on the plan's shoulder and wrist branches
    (from the previous frame it would keep that frame's branch and take the feasible
    swivel nearest the planned one there, which may be far from it)."""
    speed_need: NDArray[np.float64]
    """``(F,)`` the plan's largest joint speed over its limit, between its planned
    frames: above 1, the clip asks for more than the limits allow at any swivel of the
    grid (the frame loop then solves position first inside the speed box)."""
    in_ranges: NDArray[np.bool_]
    """``(F,)`` some swivel of the grid reaches the pose exactly inside the joint ranges
    (at the nearest planned frame)."""


def elbow_weight(bend: NDArray[np.float64]) -> NDArray[np.float64]:
    """How much the human elbow counts: 0 for a straight arm (bend below
    :data:`~.targets.STRAIGHT`), rising to 1 at twice it."""
    return np.clip((bend - STRAIGHT) / STRAIGHT, 0.0, 1.0)


def plan_swivels(
    arm: RobotArm,
    targets: ArmTargets,
    dt: float,
    q_start: NDArray[np.float64],
) -> Plan:
    """The planned swivel of every frame (see the module) and what goes with it
    (:class:`Plan`); ``q_start`` is the first frame's starting posture. The plan is made
    on every :data:`KEY`-th frame (a grid step is more than a frame's motion allows) and
    interpolated between."""
    c = arm.chain
    F = len(targets.position)
    keys = np.unique(np.append(np.arange(0, F, KEY), F - 1))
    grid = np.linspace(-math.pi, math.pi, GRID, endpoint=False)
    want = np.empty(len(keys))
    quats = np.empty((len(keys), 4))
    axes = np.empty((2, len(keys), 1, 3))  # each planned frame's swivel frame (r, k)
    for i, f in enumerate(keys.tolist()):
        R = targets.rotation(f) if arm.pose else None
        axes[0, i, 0], axes[1, i, 0] = swivel_axes(c, targets.position[f], R)
        want[i] = math.atan2(
            float(targets.elbow[f] @ axes[1, i, 0]), float(targets.elbow[f] @ axes[0, i, 0])
        )
        quats[i] = mat_to_quat(R) if R is not None else (1.0, 0.0, 0.0, 0.0)
    w = ELBOW_WEIGHT * elbow_weight(targets.bend[keys])
    K = len(keys)
    # every planned frame at every swivel in one batch, warm-started from the same
    # swivel's answer at the planned frame before (of the pass before: PASSES passes)
    pos = np.repeat(targets.position[keys], GRID, axis=0)
    qt = np.repeat(quats, GRID, axis=0) if arm.pose else None
    sw = np.tile(grid, K)
    q_all = np.broadcast_to(q_start, (K, GRID, c.n))
    for _ in range(PASSES):
        q0 = np.concatenate([np.broadcast_to(q_start, (1, GRID, c.n)), q_all[:-1]])
        q_flat, ok_flat = solve_batch(c, pos, qt, q0.reshape(-1, c.n), sw)
        q_all = q_flat.reshape(K, GRID, c.n)
    ok_all = ok_flat.reshape(K, GRID)
    # the swivel each answer is at: where the ranges forbid the one asked for,
    # closed_form takes the nearest feasible one (on the branch of its start)
    got = swivels_of(c, q_all, axes[0], axes[1])
    cost = np.zeros(GRID)
    back = np.zeros((K, GRID), dtype=np.int64)
    q_prev = np.broadcast_to(q_start, (GRID, c.n))
    for i, f in enumerate(keys.tolist()):
        q, ok = q_all[i], ok_all[i]
        node = w[i] * np.abs(np.remainder(got[i] - want[i] + math.pi, 2 * math.pi) - math.pi)
        node = node + np.where(ok, 0.0, INFEASIBLE)
        step = SPEED_SHARE * arm.speed * dt * max(1, f - (keys[i - 1] if i else 0))
        if i == 0:
            ratio = np.max(np.abs(q - q_start) / step, axis=1)
            cost = node + MOTION_WEIGHT * ratio**2
        else:
            # ratio[j, k]: the largest joint speed over its limit from swivel j to k
            ratio = np.max(np.abs(q[None, :, :] - q_prev[:, None, :]) / step, axis=2)
            trans = MOTION_WEIGHT * ratio**2 + np.where(ratio > 1.0, OVER_PRICE * ratio, 0.0)
            total = cost[:, None] + trans
            back[i] = np.argmin(total, axis=0)
            cost = total[back[i], np.arange(GRID)] + node
        q_prev = q
    path = np.empty(len(keys), dtype=np.int64)
    path[-1] = int(np.argmin(cost))
    for i in range(len(keys) - 1, 0, -1):
        path[i - 1] = back[i, path[i]]
    frames = np.arange(F)
    psi = np.interp(frames, keys, np.unwrap(got[np.arange(K), path]))
    q_path = q_all[np.arange(K), path]
    seeds = np.stack([np.interp(frames, keys, q_path[:, j]) for j in range(c.n)], axis=1)
    # within a grid step of the human elbow, the elbow's own swivel (the grid's rounding)
    near = np.empty(F)
    for f in range(F):
        R = targets.rotation(f) if arm.pose else None
        near[f] = swivel_for(c, targets.position[f], R, targets.elbow[f]) - psi[f]
    near = np.remainder(near + math.pi, 2 * math.pi) - math.pi
    half = math.pi / GRID * 2
    psi = psi + elbow_weight(targets.bend[:F]) * np.clip(near, -half, half)
    # what the plan needs: each planned step's largest joint speed over its limit
    gaps = np.maximum(np.diff(keys), 1) * dt
    need = np.max(np.abs(np.diff(q_path, axis=0)) / (arm.speed * gaps[:, None]), axis=1)
    return Plan(
        np.asarray(np.remainder(psi + math.pi, 2 * math.pi) - math.pi),
        seeds,
        np.interp(frames, keys, np.append(need[:1], need) if K > 1 else np.zeros(K)),
        np.interp(frames, keys, ok_all.any(axis=1).astype(np.float64)) > 0.5,
    )
