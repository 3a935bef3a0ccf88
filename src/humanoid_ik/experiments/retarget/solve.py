"""Every frame of a retarget solved: both hands, both elbows and the gaze, warm-started
from the previous frame, within the joint speed limits and free of self-collision.

Per arm, with ``solver="auto"`` (the exact solvers where ``auto`` would take them):

- a pose target (an arm of 6 joints or more) on a chain ``closed_form`` solves (a
  spherical shoulder and wrist: the bundled humanoid): ``closed_form`` at the swivel
  planned over the clip (:func:`~.plan.plan_swivels`: the human elbow's where it is
  bent, the least joint motion within the speed limits), from the plan's joints (its
  branches), exact; where that is faster than the limits, the hand position first
  inside the speed box from that answer alone (:func:`~.speed.bounded_solve`), so the
  arm stays on the plan's branches;
- a position target (an arm of fewer than 6 joints) on a chain ``two_link`` solves:
  ``two_link`` with the human elbow as its pole (``Target.pole``: the branch, and a
  three-hinge shoulder's twist, that put the elbow in the pole's plane);
- otherwise ``lm``, after :data:`ELBOW_STEPS` null-space steps that turn the elbow
  towards the human's while tracking the hand (:func:`~.elbow.elbow_steps`, weighted by
  the elbow's pull; the first frame takes :data:`FIRST_STEPS`), started from the arm's
  path tracked over the clip without the speed limits (:func:`~.tracks.track_path`), so
  that after a frame the limits cut the arm returns to the path's branch.

A pose the arm cannot reach (outside the ranges) is solved again for the position
alone, with ``lm`` from that answer, so the hand stays on its path and only the
orientation gives way. The head: ``look_at`` at the gaze point. Then the joint speed
limits: an arm's answer that would move a joint more than ``limit x frame time`` from
the previous frame is solved again position first inside that box
(:func:`~.speed.bounded_solve`); the head's move is cut to it. Then self-collision: where the
derived pairs touch (:meth:`RobotSide.collisions`), the frame is solved again by the
QP (``UpperBodyIK`` with those pairs, warm from the previous frame) and cut to the
speed limits again.

With ``solver="mink"`` every frame is the QP's: ``UpperBodyIK`` (hands, gaze, the
derived collision pairs, and each bent human elbow as its arm's elbow pole: the QP's
low-cost elbow task), iterated to convergence from the previous frame, then cut to the
speed limits.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.rotations import axis_name, mat_to_quat
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.errors import RetargetError, choices
from humanoid_ik.experiments.retarget.elbow import elbow_error, elbow_steps, pole_for, swivel_for
from humanoid_ik.experiments.retarget.plan import Plan, plan_swivels
from humanoid_ik.experiments.retarget.robot import RobotArm, RobotSide
from humanoid_ik.experiments.retarget.speed import STEPS, bounded_solve
from humanoid_ik.experiments.retarget.targets import BENT, STRAIGHT, Targets, rest_offset
from humanoid_ik.experiments.retarget.tracks import track_path, tracking_lm
from humanoid_ik.solvers.analytic.closed_form import ClosedForm
from humanoid_ik.solvers.analytic.elbow import arm_points
from humanoid_ik.solvers.analytic.two_link import TwoLink
from humanoid_ik.solvers.auto import Auto
from humanoid_ik.solvers.base import error_buffers
from humanoid_ik.solvers.look_at import LookAt

__all__ = ["ELBOW_STEPS", "FIRST_STEPS", "SOLVERS", "FrameSolve", "Retargeter"]

SOLVERS = ("auto", "mink")
"""``--solver`` choices: the exact per-arm solvers where they apply, or the QP."""
ELBOW_STEPS = 1
"""Null-space elbow steps per frame before ``lm`` (arms without an exact solver)."""
FIRST_STEPS = 40
"""... on the first frame, from the home pose."""
START_TWISTS = (0.0, -1.2, 1.2, -2.4, 2.4)
"""Turns [rad] of the upper arm's twist joint the first frame starts from."""
SPEED_TRIES = 3
"""Tries of the elbow's pull (halved each time) within the speed limits."""
SWIVEL_STEPS = (0.0, -0.05, 0.05, -0.15, 0.15, -0.4, 0.4, -0.8, 0.8)
"""Swivels [rad] from the current one that ``closed_form`` tries next."""
POSITION_ONLY = "+lm(position)"
"""What an arm's answer says (``<side>_solver``) when its pose is out of reach and
``lm`` solved the position alone: it is then judged, and cut to the speed limits, by
its position."""
GAZE_TOL = 1e-4
"""``look_at``'s angle tolerance [rad]."""


@dataclass
class FrameSolve:
    """What one frame's solve did, per effector (arms by side, ``head``)."""

    results: dict[str, IKResult] = field(default_factory=dict)
    solver: dict[str, str] = field(default_factory=dict)
    cut: dict[str, bool] = field(default_factory=dict)
    seconds: float = 0.0
    cpu: float = 0.0
    collisions: int = 0
    fallback: bool = False


class Retargeter:
    """The frame loop's solvers and state for one robot and one clip's targets.

    Args:
        robot: the robot side.
        targets: the scaled targets.
        dt: the frame time [s].
        solver: ``auto`` or ``mink`` (:data:`SOLVERS`).

    Raises:
        RetargetError: an unknown solver.
    """

    def __init__(self, robot: RobotSide, targets: Targets, dt: float, solver: str = "auto"):
        if solver not in SOLVERS:
            raise RetargetError(f"solver '{solver}' unknown; choices: {choices(SOLVERS)}")
        self.robot, self.targets, self.dt, self.mode = robot, targets, dt, solver
        self.arms = {s: a for s, a in robot.arms.items() if s in targets.arms}
        auto = Auto()
        self.method: dict[str, str] = {}
        for side, arm in self.arms.items():
            name = auto.choice(arm.chain, arm.pose).name
            self.method[side] = name if solver == "auto" else "mink"
        self._lm = tracking_lm(restarts=0)  # the answer nearest the warm start
        self._lm_start = tracking_lm()
        self._two_link = TwoLink()
        self._gaze = None
        self.gaze_on = robot.head is not None and targets.gaze is not None
        if self.gaze_on:
            forward = axis_name(robot.gaze_axis)  # iCub's head frame looks along -x
            if forward is None:
                self.gaze_on = False  # look_at aims a frame axis (or its opposite) only
            else:
                self._gaze = LookAt(rot_tol=GAZE_TOL, max_iterations=20, forward_axis=forward)
        if self.gaze_on:
            self.method["head"] = "look_at" if solver == "auto" else "mink"
        self._qp: Any = None
        self.plan: dict[str, Plan] = {}
        """The plan of each ``closed_form`` arm (:mod:`.plan`)."""
        self.tracks: dict[str, NDArray] = {}
        """The tracked path ``(F, n)`` of each ``lm`` arm (:mod:`.tracks`)."""
        self.q = {s: a.chain.clip(a.chain.q_home) for s, a in self.arms.items()}
        if self.gaze_on:
            assert robot.head is not None
            self.q["head"] = robot.head.clip(robot.head.q_home)

    # ------------------------------------------------------------------ targets
    def target(self, side: str, f: int) -> Target:
        t = self.targets.arms[side]
        if not self.arms[side].pose:
            return Target(t.position[f])
        return Target(t.position[f], mat_to_quat(t.rotation(f)))

    def _chains(self) -> dict[str, Any]:
        out: dict[str, Any] = {s: a.chain for s, a in self.arms.items()}
        if self.gaze_on:
            out["head"] = self.robot.head
        return out

    # ------------------------------------------------------------------ first frame
    def start(self) -> None:
        """Frame 0's position and elbow reached with the wrist at home, and each arm's
        orientation offset set from it (:func:`~.targets.rest_offset`). The shoulder and
        elbow start from home and from home with the upper arm turned about itself by
        :data:`START_TWISTS`; the start whose elbow is nearest the human's is kept."""
        for side, arm in self.arms.items():
            t = self.targets.arms[side]
            c = arm.chain
            home = c.clip(c.q_home)
            k = arm.elbow
            sub = _sub_chain(arm, k + 1)
            best: tuple[float, NDArray] | None = None
            for twist in START_TWISTS:
                q = home.copy()
                if k >= 1:
                    q[k - 1] += twist  # the joint before the elbow: the upper arm's twist
                q = elbow_steps(
                    c, c.clip(q), t.position[0], None, t.elbow[0], FIRST_STEPS, free=k + 1
                )
                res = self._lm_start.solve(sub, Target(t.position[0]), q[: k + 1])
                q[: k + 1] = res.q
                c.set_q(q)
                a, _ = elbow_error(c, t.elbow[0])
                cost = res.position_error + 0.01 * (0.0 if math.isnan(a) else a)
                if best is None or cost < best[0]:
                    best = (cost, q)
            assert best is not None
            q = best[1]
            c.set_q(q)
            rest_offset(t, c.rotation.copy())
            self.q[side] = q
            if self.method[side] == "closed_form" and arm.pose:
                self.plan[side] = plan_swivels(arm, t, self.dt, q)
            elif self.method[side] == "lm" and self.mode == "auto":
                self.tracks[side] = track_path(arm, t, q, ELBOW_STEPS)

    # ------------------------------------------------------------------ one frame
    def solve(self, f: int) -> FrameSolve:
        """Solve frame ``f`` from the previous frame's joints (kept in :attr:`q`)."""
        out = FrameSolve()
        w0, c0 = time.perf_counter(), time.process_time()
        prev = dict(self.q)
        if self.mode == "mink":
            self._qp_frame(f, prev, out)
        else:
            for side, arm in self.arms.items():
                res, used = self._arm(side, arm, f, prev[side])
                out.results[side], out.solver[side] = res, used
            if self.gaze_on:
                assert self._gaze is not None and self.robot.head is not None
                assert self.targets.gaze is not None
                res = self._gaze.solve(self.robot.head, Target(self.targets.gaze[f]), prev["head"])
                out.results["head"], out.solver["head"] = res, "look_at"
        self._limit(f, prev, out)
        out.collisions = self.robot.collisions(self.robot.robot.data)
        if out.collisions and self.mode != "mink":
            out.fallback = True
            self._qp_frame(f, prev, out)
            self._limit(f, prev, out)
            out.collisions = self.robot.collisions(self.robot.robot.data)
        out.seconds = time.perf_counter() - w0
        out.cpu = time.process_time() - c0
        return out

    def _arm(self, side: str, arm: RobotArm, f: int, q0: NDArray) -> tuple[IKResult, str]:
        """One arm's frame, the hand's target first, the elbow's direction second, within
        the speed limits where a try allows:

        1. the elbow's pull (its weight from the human elbow's bend: 0 for a straight
           arm, 1 from twice :data:`~.targets.STRAIGHT`), halved up to
           :data:`SPEED_TRIES` times while the answer would move a joint faster than
           its limit;
        2. with ``closed_form``: the swivels :data:`SWIVEL_STEPS` away from the current
           one, the slowest answer (near the shoulder's gimbal lock, where a straight
           arm's swivel is a twist the shoulder and the wrist share, one swivel may
           turn both fast and a neighbour not);
        3. ``lm`` from the previous frame, without the elbow's pull (the smallest move).

        Else the slowest answer found, which the speed limits then cut."""
        t = self.targets.arms[side]
        w = min(1.0, max(0.0, (float(t.bend[f]) - STRAIGHT) / STRAIGHT))
        step = arm.speed * self.dt
        best: tuple[float, IKResult, str] | None = None

        def keep(res: IKResult, how: str) -> bool:
            nonlocal best
            ratio = float(np.max(np.abs(res.q - q0) / step)) if f > 0 else 0.0
            err = res.position_error
            if POSITION_ONLY not in how:  # an unreachable pose is judged by its position
                err += 0.1 * (res.orientation_error or 0.0)
            score = ratio + (1e3 if err > 1e-3 else 0.0)
            if best is None or score < best[0]:
                best = (score, res, how)
            return ratio <= 1.0 and err <= 1e-3

        if side in self.plan:
            plan = self.plan[side]
            tgt = self.target(side, f)
            res = ClosedForm(swivel=float(plan.swivel[f])).solve(arm.chain, tgt, plan.seeds[f])
            if keep(res, "closed_form"):
                return res, "closed_form"
            if res.converged and f > 0:
                # too fast: inside the speed box from the planned answer alone, which
                # keeps the arm on the plan's branches (the slower answers of the tries
                # below are on the previous frame's, where the plan may not go on)
                return self._bounded(side, arm, f, q0, (res.q,)), "closed_form+bounded"
        if side in self.tracks:
            res, how = self._arm_once(side, arm, f, self.tracks[side][f], w)
            if keep(res, how):
                return res, how
            if f > 0 and res.position_error <= 1e-3:
                # too fast: inside the speed box towards the tracked path's branch
                pose = POSITION_ONLY not in how
                return self._bounded(side, arm, f, q0, (res.q,), pose), how + "+bounded"
        for k in range(SPEED_TRIES if w > 0 else 0):
            if keep(*self._arm_once(side, arm, f, q0, w * 0.5**k)):
                return best[1], best[2]  # type: ignore[index]
        if self.method[side] == "closed_form" and f > 0:
            R = self.targets.arms[side].rotation(f) if arm.pose else None
            S, E, _ = arm_points(arm.chain, q0)
            now = swivel_for(arm.chain, t.position[f], R, E - S)
            tgt = self.target(side, f)
            for d in SWIVEL_STEPS:
                res = ClosedForm(swivel=now + d).solve(arm.chain, tgt, q0)
                if res.converged and keep(res, "closed_form"):
                    return best[1], best[2]  # type: ignore[index]
        if keep(*self._arm_once(side, arm, f, q0, 0.0)):
            return best[1], best[2]  # type: ignore[index]
        assert best is not None
        res, how = best[1], best[2]
        if f == 0:
            return res, how
        pose = POSITION_ONLY not in how
        return self._bounded(side, arm, f, q0, (res.q, q0), pose), how + "+bounded"

    def _bounded(
        self,
        side: str,
        arm: RobotArm,
        f: int,
        q0: NDArray,
        starts: tuple[NDArray, ...],
        pose: bool = True,
    ) -> IKResult:
        """The hand's position first inside the speed box around ``q0``
        (:func:`~.speed.bounded_solve`) from each of ``starts`` cut into the box; the
        best of them. ``pose=False`` (the pose is out of reach): the position alone."""
        c, t = arm.chain, self.targets.arms[side]
        step = arm.speed * self.dt
        lo, hi = np.maximum(c.lower, q0 - step), np.minimum(c.upper, q0 + step)
        R = t.rotation(f) if arm.pose and pose else None
        p = t.position[f]
        best = min((bounded_solve(c, s, lo, hi, p, R) for s in starts), key=lambda r: r[1])
        c.set_q(best[0])
        tgt = self.target(side, f)
        ep, er = pose_error(c.position, c.rotation, p, tgt.quat, *error_buffers(c))
        return IKResult(
            best[0].copy(),
            False,
            STEPS,
            ep,
            er if arm.pose else None,
            Status.MAX_ITERATIONS,
            "bounded",
            "the exact answer exceeds a joint speed limit",
        )

    def _arm_once(
        self, side: str, arm: RobotArm, f: int, q0: NDArray, w: float
    ) -> tuple[IKResult, str]:
        t = self.targets.arms[side]
        tgt = self.target(side, f)
        c, how = arm.chain, self.method[side]
        if how == "closed_form" and w > 0.0:
            R = t.rotation(f) if arm.pose else None
            S, E, _ = arm_points(c, q0)
            now = swivel_for(c, t.position[f], R, E - S)
            psi = swivel_for(c, t.position[f], R, t.elbow[f])
            psi = now + w * math.remainder(psi - now, 2.0 * math.pi)
            res = ClosedForm(swivel=psi).solve(c, tgt, q0)
        elif how == "two_link" and w > 0.0:
            c.set_q(q0)
            res = self._two_link.solve(c, Target(tgt.position, pole=pole_for(c, t.elbow[f])), q0)
        else:
            how = "lm"
            R = t.rotation(f) if arm.pose else None
            q = elbow_steps(c, q0, t.position[f], R, t.elbow[f], ELBOW_STEPS, w)
            res = self._lm.solve(c, tgt, q)
        if not res.converged and tgt.is_pose:
            pos = self._lm.solve(c, Target(tgt.position), res.q)
            if pos.position_error < res.position_error:
                res = pos.with_details(pose="position only: the pose is out of reach")
                how += POSITION_ONLY
        return res, how

    # ------------------------------------------------------------------ limits
    def _limit(self, f: int, prev: dict[str, NDArray], out: FrameSolve) -> None:
        """Cut each chain's move to its speed limits (not on frame 0, which starts the
        motion) and apply it to the robot state."""
        speeds = {s: a.speed for s, a in self.arms.items()}
        if self.gaze_on:
            speeds["head"] = self.robot.head_speed
        chains = self._chains()
        for name, res in out.results.items():
            q = res.q
            if f > 0:
                step = speeds[name] * self.dt
                dq = np.clip(q - prev[name], -step, step)
                cut = bool(np.any(np.abs(q - prev[name]) > step))
                q = prev[name] + dq
            else:
                cut = False
            q = chains[name].clip(q)
            out.cut[name] = cut
            self.q[name] = q
            chains[name].set_q(q)

    # ------------------------------------------------------------------ the QP
    def qp(self) -> Any:
        """The QP (``UpperBodyIK`` on the arms and the gaze, the derived collision pairs),
        built on first use."""
        if self._qp is None:
            from humanoid_ik.solvers.mink.upper_body import UpperBodyIK

            pairs = self.robot.limb_pairs
            named = all(isinstance(g, str) for a, b in pairs for g in (*a, *b))
            chains = [a.chain for a in self.arms.values()]
            gaze = self.robot.head if self.gaze_on else None
            self._qp = UpperBodyIK(
                self.robot.robot,
                hands=chains,
                gaze=gaze,
                gaze_axis=self.robot.gaze_axis,
                collision_pairs=pairs if named else "limbs",
                max_velocity=1e3,
            )
        return self._qp

    def _qp_frame(self, f: int, prev: dict[str, NDArray], out: FrameSolve) -> None:
        ik = self.qp()
        qpos = self.robot.robot.data.qpos.copy()
        chains = self._chains()
        for name, c in chains.items():
            qpos[c.qpos_adr] = prev[name]
        ik.set_q(qpos)
        goals: dict[str, Any] = {}
        for s, c in chains.items():
            if s != "head":
                t, tgt = self.targets.arms[s], self.target(s, f)
                if t.bend[f] > BENT:  # the elbow task: the human elbow as its pole
                    tgt = Target(tgt.position, tgt.quat, pole=pole_for(c, t.elbow[f]))
                goals[c.ee_name] = tgt
        if self.gaze_on:
            assert self.targets.gaze is not None and self.robot.head is not None
            goals[self.robot.head.ee_name] = self.targets.gaze[f]
        res = ik.solve(goals)
        for name, c in chains.items():
            out.results[name] = res[c.ee_name]
            out.solver[name] = "mink"


def _sub_chain(arm: RobotArm, n: int) -> Chain:
    """The arm's first ``n`` joints (shoulder and elbow) to the same end frame: the wrist
    held where it is."""
    c = arm.chain
    return Chain(c.robot, joints=list(c.joint_names[:n]), **{c.ee_kind: c.ee_name})
