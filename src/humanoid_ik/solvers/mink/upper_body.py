"""Several hands and a gaze solved jointly by mink, one QP per step, on any model.

Tasks: a ``mink.FrameTask`` per hand with a pose target, a
:class:`~humanoid_ik.solvers.mink.tasks.PositionTask` per hand with a position target, an
:class:`~humanoid_ik.solvers.mink.tasks.ElbowTask` (cost ``pole_cost``) per hand whose
target has an elbow ``pole``, a :class:`~humanoid_ik.solvers.mink.tasks.GazeTask` for the
gaze, and a
``mink.PostureTask`` toward the ``home`` keyframe. The active chains are those of the
effectors that have a target in the call; every other joint is frozen (the QP of
:mod:`humanoid_ik.solvers.mink.problem`). All of them are solved jointly in one QP per
step. Nothing here knows a particular robot: the caller names the hands, the gaze and
the collision pairs with its model's names. Per frame of a scene (the bundled
humanoid's names here)::

    ik = UpperBodyIK(                   # once (the scene's MjModel)
        model,
        hands=("right_palm_site", "left_palm_site"),
        gaze="gaze_site",
        collision_pairs=pairs,          # e.g. the [solver] options of the scene file
    )
    ik.load(data)                       # once, start from the scene's qpos
    res = ik.step(                      # every frame, dt = frame time [s]
        {"right_palm_site": Target(p_r, quat_r), "left_palm_site": p_l,
         "gaze_site": p_look},
        dt,
    )
    ik.apply(data)                      # writes the chains' joints, runs mj_forward

``res`` is an :class:`~humanoid_ik.solvers.mink.result.UpperBodyResult`: the full
``qpos`` and an ``IKResult`` per target (errors measured with MuJoCo FK after the
step). ``ik.solve(targets)`` iterates steps to convergence instead.

The options are a :class:`~humanoid_ik.solvers.mink.options.MinkOptions` (the one place
their defaults and bounds are written), given as ``options=`` or as its fields.

mink (with qpsolvers and SciPy) takes about 0.2 s to import, so this module does not
import it: the first :class:`UpperBodyIK` built does.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.models import home_qpos
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.errors import ChainError, NameNotFoundError, SolverError, TargetError, choices
from humanoid_ik.solvers.analytic.elbow import pole_angle
from humanoid_ik.solvers.iterate import Stall, pose_cost
from humanoid_ik.solvers.mink.options import LIMBS, NAME, CollisionPairs, MinkOptions
from humanoid_ik.solvers.mink.pairs import LimbPairs, limb_collision_pairs
from humanoid_ik.solvers.mink.result import UpperBodyResult

if TYPE_CHECKING:
    import mink

    from humanoid_ik.solvers.mink.limits import CollisionLimit
    from humanoid_ik.solvers.mink.problem import ActiveKey, Problem
    from humanoid_ik.solvers.mink.tasks import ElbowTask, GazeTask, PositionTask

__all__ = ["NAME", "UpperBodyIK"]


def __getattr__(name: str) -> Any:
    """The deprecated ``DEFAULTS``, ``check_options`` and ``DEFAULT_*`` names
    (:mod:`~humanoid_ik.solvers.mink.deprecated`)."""
    from humanoid_ik.solvers.mink.deprecated import lookup

    return lookup(__name__, name)


class UpperBodyIK:
    """Hands and a gaze of one model solved jointly by mink, one QP per step.

    Args:
        model: the :class:`~humanoid_ik.core.robot.Robot`, ``MjModel`` or MJCF/URDF path
            the effectors are on; ``None`` takes the model of the :class:`Chain` objects
            among ``hands`` and ``gaze`` (then at least one must be a chain).
        hands: the hand effectors (at least one, unless there is a gaze): site names
            (chain by the path rule) or :class:`~humanoid_ik.core.chain.Chain` objects
            on the same model (custom joints or a body end effector).
        gaze: the gaze effector (a site name or a chain, whose end may be a site or a
            body: a head limb's gaze frame, ``core/limbs.py``), or ``None`` for no gaze.
        gaze_axis: the gaze frame's forward axis, the one aimed at the gaze target:
            ``"x"``, ``"y"``, ``"z"`` or ``(3,)`` in that frame (a head limb's ``axis``);
            ``None`` (the default) for the options' ``forward_axis``.
        options: a :class:`~humanoid_ik.solvers.mink.options.MinkOptions` (default: its
            defaults).
        **fields: :class:`MinkOptions` fields overriding ``options``, checked as
            ``make_solver("mink", ...)`` checks them, e.g. ``collision_pairs=[(group,
            group), ...]`` (pairs of geom-name groups kept apart, every geom of a group
            against every geom of the other; ``()``, the default, or ``None`` for none;
            ``"limbs"``: each forearm and hand against the torso and head and hand
            against hand, derived from the limbs found in the model,
            :func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`),
            ``max_velocity=3.0``. Used here: the task costs and gains, ``damping``,
            ``lm_damping``, ``range_gain``, the collision options, ``max_velocity``
            (:meth:`step`), ``max_step``, ``tol``, ``rot_tol``, ``max_iterations``,
            ``stall_window`` (:meth:`solve`) and ``qp_solver``; ``restarts``, ``seed``
            and ``dt`` are the solver's (:class:`~humanoid_ik.solvers.mink.MinkSolver`).

    State: the object owns a ``mink.Configuration`` (its own ``MjData``), the tasks, the
    limits and, per set of active effectors, the :class:`~humanoid_ik.solvers.mink.problem.Problem`
    built on its first use (or by :meth:`prepare`) and kept for the object's life; all of
    them depend only on the model, the effectors and the options, which are fixed. One
    thread at a time: give each thread its own (``MinkSolver`` keeps one per robot state).

    Raises:
        ModelError, NameNotFoundError: a bad model path, site or geom name (the message
            lists the valid names).
        ChainError: no model, no effector, a chain on another model, an effector given
            twice.
        SolverError: a bad option.
    """

    def __init__(
        self,
        model: Robot | mujoco.MjModel | str | os.PathLike[str] | None = None,
        *,
        hands: Sequence[str | Chain],
        gaze: str | Chain | None = None,
        gaze_axis: str | ArrayLike | None = None,
        options: MinkOptions | None = None,
        **fields: Any,
    ):
        if options is None:
            options = MinkOptions.parse(NAME, fields)
        elif fields:
            options = MinkOptions.parse(NAME, {**options.as_dict(), **fields})
        self.options: MinkOptions = options
        """The options (read-only)."""
        if isinstance(hands, (str, Chain)):
            hands = (hands,)
        self._robot = self._robot_of(model, [*hands, gaze])
        self.model = self._robot.model
        self._hand_chains = [self._chain(h) for h in hands]
        self._gaze_chain = None if gaze is None else self._chain(gaze)
        chains = [*self._hand_chains] + ([self._gaze_chain] if self._gaze_chain else [])
        if not chains:
            raise ChainError("UpperBodyIK needs at least one effector (hands or a gaze)")
        names = [c.ee_name for c in chains]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ChainError(f"effector '{dup[0]}' is given twice; effectors: {', '.join(names)}")
        self.chains: dict[str, Chain] = {c.ee_name: c for c in chains}
        """The effectors' chains by effector name (hands first, then the gaze)."""
        given = self.options.collision_pairs
        if isinstance(given, str):  # LIMBS, the only string MinkOptions lets through
            assert given == LIMBS
            pairs: LimbPairs = limb_collision_pairs(self.model)
        else:
            self._check_geoms(given)
            pairs = given
        self.collision_pairs: LimbPairs = pairs
        """The geom groups kept apart (``collision_pairs="limbs"``: those derived from
        the model's limbs, :func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`;
        geoms by name, an unnamed MJCF geom by id)."""

        import mink  # the first mink object: import mink and our mink modules now
        import qpsolvers

        from humanoid_ik.solvers.mink.problem import QPStep

        if self.options.qp_solver not in qpsolvers.available_solvers:
            raise SolverError(
                f"QP solver '{self.options.qp_solver}' not installed; QP solvers: "
                f"{choices(qpsolvers.available_solvers)}"
            )
        self._se3 = mink.SE3
        self.configuration = mink.Configuration(self.model)
        """The ``mink.Configuration`` holding the solver's ``qpos`` and kinematics."""
        self._build_tasks(self.options.forward_axis if gaze_axis is None else gaze_axis)
        self._build_limits(pairs)
        self._problems: dict[tuple[ActiveKey, tuple[str, ...]], Problem] = {}
        self._err_buffers = (np.empty(6), np.empty((2, 4)))  # error vector, quaternion scratch
        self._step = QPStep(self.configuration, self.options, self._collision)
        self.reset()

    @staticmethod
    def _robot_of(
        model: Robot | mujoco.MjModel | str | os.PathLike[str] | None,
        effectors: Sequence[str | Chain | None],
    ) -> Robot:
        """The robot the effectors named by site are built on: ``model``'s, else the
        first given chain's."""
        if isinstance(model, Robot):
            return model
        if model is None:
            given = [c for c in effectors if isinstance(c, Chain)]
            if not given:
                raise ChainError(
                    "UpperBodyIK needs a model (a Robot, an MjModel or a model file) or "
                    "Chain objects as effectors"
                )
            return given[0].robot
        return Robot(model)

    # ------------------------------------------------------------------ set-up
    def _build_tasks(self, gaze_axis: str | ArrayLike) -> None:
        """A frame task and a position task per hand, the gaze task, the posture task."""
        import mink

        from humanoid_ik.solvers.mink.tasks import GazeTask, PositionTask

        m, o = self.model, self.options
        self._pose_tasks: dict[str, mink.FrameTask] = {
            c.ee_name: mink.FrameTask(
                c.ee_name,
                c.ee_kind,
                position_cost=o.position_cost,
                orientation_cost=o.orientation_cost,
                lm_damping=o.lm_damping,
            )
            for c in self._hand_chains
        }
        self._position_tasks: dict[str, PositionTask] = {
            c.ee_name: PositionTask(
                m, c.ee_name, c.ee_kind, cost=o.position_cost, lm_damping=o.lm_damping
            )
            for c in self._hand_chains
        }
        self._elbow_tasks: dict[str, ElbowTask] = {}
        """Per hand, built on the first target with a pole (an arm chain's elbow)."""
        self._gaze_task: GazeTask | None = None
        if self._gaze_chain is not None:
            g = self._gaze_chain
            self._gaze_task = GazeTask(m, g.ee_name, gaze_axis, cost=o.gaze_cost, kind=g.ee_kind)
        self.q_home = self._home()
        """``qpos`` of the ``home`` keyframe (else ``qpos0``), chain joints inside ranges."""
        self._posture = mink.PostureTask(m, cost=o.posture_cost, gain=o.posture_gain)
        self._posture.set_target(self.q_home)

    def _build_limits(self, pairs: LimbPairs) -> None:
        """The velocity limit of every chain joint and the collision limit (if pairs)."""
        from humanoid_ik.solvers.mink.limits import CollisionLimit, JointVelocityLimit

        m, o = self.model, self.options
        all_ids = sorted({int(j) for c in self.chains.values() for j in c.joint_ids})
        self._velocity = JointVelocityLimit(m, all_ids, o.max_velocity)
        self._collision: CollisionLimit | None = None
        if pairs:
            self._collision = CollisionLimit(
                m,
                [(list(a), list(b)) for a, b in pairs],
                gain=o.collision_gain,
                minimum_distance_from_collisions=o.min_distance,
                collision_detection_distance=o.detection_distance,
            )

    def _chain(self, spec: str | Chain) -> Chain:
        if isinstance(spec, Chain):
            if spec.model is not self.model:
                raise ChainError(
                    f"chain of '{spec.ee_name}' is built on another MjModel; build every "
                    "chain on the model given to UpperBodyIK"
                )
            return spec
        return Chain(self._robot, spec)

    def _check_geoms(self, pairs: CollisionPairs) -> None:
        """Every geom name of ``pairs`` (already of the right shape) is the model's."""
        m = self.model
        unknown: list[str] = []
        for pair in pairs:
            for group in pair:
                for name in group:
                    if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) < 0:
                        if name not in unknown:
                            unknown.append(name)
        if unknown:
            valid = [m.geom(i).name for i in range(m.ngeom) if m.geom(i).name]
            raise NameNotFoundError("geom", "', '".join(unknown), valid)

    def _home(self) -> NDArray[np.float64]:
        q = home_qpos(self.model)
        for c in self.chains.values():
            q[c.qpos_adr] = c.clip(q[c.qpos_adr])
        return q

    def _elbow_task(self, name: str) -> ElbowTask:
        """The hand's :class:`~humanoid_ik.solvers.mink.tasks.ElbowTask` (built once)."""
        task = self._elbow_tasks.get(name)
        if task is None:
            from humanoid_ik.solvers.mink.tasks import ElbowTask

            task = ElbowTask(self.model, self.chains[name], cost=self.options.pole_cost)
            self._elbow_tasks[name] = task
        return task

    def _problem(self, key: ActiveKey, poles: tuple[str, ...] = ()) -> Problem:
        """The problem of the effectors in ``key`` (with the elbow tasks of the hands in
        ``poles``), built on first use and kept."""
        prob = self._problems.get((key, poles))
        if prob is not None:
            return prob
        from humanoid_ik.solvers.mink.problem import build_problem

        gaze_name = None if self._gaze_chain is None else self._gaze_chain.ee_name
        tasks: list[mink.Task] = []
        for name, pose in key:
            if name == gaze_name:
                assert self._gaze_task is not None
                tasks.append(self._gaze_task)
            else:
                tasks.append(self._pose_tasks[name] if pose else self._position_tasks[name])
        tasks += [self._elbow_task(name) for name in poles]
        tasks.append(self._posture)
        ids = sorted({int(j) for n, _ in key for j in self.chains[n].joint_ids})
        shared: list[mink.Limit] = [self._velocity]
        if self._collision is not None:
            shared.append(self._collision)
        prob = build_problem(self.model, key, ids, tasks, shared, self.options.range_gain)
        self._problems[(key, poles)] = prob
        return prob

    def prepare(self) -> None:
        """Build the problem of every effector with a target, for each mix of position and
        pose targets of the hands, so a later timed step or solve does not pay for it.

        Other sets of effectors (some without a target) are built on their first use.
        """
        gaze = [] if self._gaze_chain is None else [(self._gaze_chain.ee_name, False)]
        for mask in range(2 ** len(self._hand_chains)):
            hands = [(c.ee_name, bool(mask >> i & 1)) for i, c in enumerate(self._hand_chains)]
            self._problem((*hands, *gaze))

    # ------------------------------------------------------------------ state
    @property
    def q(self) -> NDArray[np.float64]:
        """Full ``qpos`` ``(nq,)`` [rad] (a copy)."""
        return self.configuration.data.qpos.copy()

    @property
    def last_dq(self) -> NDArray[np.float64]:
        """Displacement ``(nv,)`` [rad] the last QP step returned, before it was clipped to
        the limits (a copy; zeros if the QP found no solution)."""
        return self._step.dq.copy()

    @property
    def effector_names(self) -> list[str]:
        """Names that :meth:`step` and :meth:`solve` accept as target keys."""
        return list(self.chains)

    @property
    def collision_limit(self) -> CollisionLimit | None:
        """The collision limit (its ``geom_id_pairs`` are the pairs kept apart), or
        ``None`` without collision pairs."""
        return self._collision

    def reset(self) -> None:
        """Every joint to the ``home`` keyframe (or ``qpos0``), chain joints inside ranges."""
        self.configuration.update(self.q_home.copy())

    def set_q(self, qpos: ArrayLike) -> None:
        """Set the full ``qpos`` ``(nq,)`` [rad] and run the kinematics.

        Raises:
            TargetError: wrong shape or not finite.
        """
        q = np.asarray(qpos, dtype=np.float64)
        if q.shape != (self.model.nq,) or not np.all(np.isfinite(q)):
            raise TargetError(f"qpos must be {self.model.nq} finite numbers, got shape {q.shape}")
        self.configuration.update(q.copy())

    def load(self, data: mujoco.MjData) -> None:
        """Start from the caller's ``qpos`` (every joint) and mocap poses; ``data`` is
        only read."""
        self.set_mocap(data)
        self.set_q(data.qpos)

    def set_mocap(self, data: mujoco.MjData) -> None:
        """Take the mocap bodies' poses of ``data`` (a chain below a mocap body moves
        with it; :meth:`set_q` sets ``qpos`` only), from the next :meth:`set_q` on."""
        if self.model.nmocap:
            own = self.configuration.data
            own.mocap_pos[:] = data.mocap_pos
            own.mocap_quat[:] = data.mocap_quat

    def apply(self, data: mujoco.MjData) -> None:
        """Write the chains' joints into the caller's ``data`` and run ``mj_forward``."""
        src = self.configuration.data.qpos
        for c in self.chains.values():
            data.qpos[c.qpos_adr] = src[c.qpos_adr]
        mujoco.mj_forward(self.model, data)

    # ------------------------------------------------------------------ targets
    def _set_targets(self, targets: Mapping[str, Any]) -> tuple[ActiveKey, dict[str, Target]]:
        """Parse ``targets`` and point the tasks at them.

        Returns:
            ``(key, parsed)``: ``(name, pose target?)`` per effector with a target, in
            effector order, and the parsed targets by name.
        """
        parsed: dict[str, Target] = {}
        gaze_name = None if self._gaze_chain is None else self._gaze_chain.ee_name
        for name, value in targets.items():
            if value is None:
                continue
            if name not in self.chains:
                raise TargetError(
                    f"target for '{name}', which is no effector; effectors: "
                    f"{', '.join(self.chains)}"
                )
            tgt = Target.of(value)
            if name == gaze_name:
                if tgt.is_pose:
                    raise TargetError(
                        f"'{name}' looks at a point; give a position without orientation"
                    )
                assert self._gaze_task is not None
                self._gaze_task.set_target(tgt.position)
            elif tgt.is_pose:
                assert tgt.quat is not None
                wxyz_xyz = np.concatenate([tgt.quat, tgt.position])
                self._pose_tasks[name].transform_target_to_world = self._se3(wxyz_xyz)
            else:
                self._position_tasks[name].set_target(tgt.position)
            if tgt.pole is not None and name != gaze_name:
                self._elbow_task(name).set_pole(tgt.pole)
            parsed[name] = tgt
        key = tuple((n, parsed[n].is_pose) for n in self.chains if n in parsed)
        return key, parsed

    def _errors(self, name: str, tgt: Target) -> tuple[float, float | None]:
        """(position error [m], orientation error [rad] or None) of one effector now."""
        if self._gaze_task is not None and name == self._gaze_task.site:
            miss, theta = self._gaze_task.error(self.configuration)
            return miss, theta
        chain = self.chains[name]
        d = self.configuration.data
        pos = (d.site_xpos if chain.ee_kind == "site" else d.xpos)[chain.ee_id]
        xmat = (d.site_xmat if chain.ee_kind == "site" else d.xmat)[chain.ee_id]
        ep, er = pose_error(pos, xmat, tgt.position, tgt.quat, *self._err_buffers)
        return ep, (er if tgt.is_pose else None)

    def _within(self, name: str, ep: float, er: float | None) -> bool:
        o = self.options
        if self._gaze_task is not None and name == self._gaze_task.site:
            return er is not None and er < o.rot_tol
        return ep < o.tol and (er is None or er < o.rot_tol)

    def _result(
        self,
        parsed: Mapping[str, Target],
        order: Sequence[str],
        iterations: int,
        status: Status | None = None,
        message: str = "",
    ) -> UpperBodyResult:
        qpos = self.configuration.data.qpos
        per: dict[str, IKResult] = {}
        for name in order:
            ep, er = self._errors(name, parsed[name])
            ok = self._within(name, ep, er)
            per[name] = IKResult(
                q=qpos[self.chains[name].qpos_adr],
                converged=ok,
                iterations=iterations,
                position_error=ep,
                orientation_error=er,
                status=Status.CONVERGED if ok else Status.MAX_ITERATIONS,
                solver=NAME,
                message="" if ok else message,
            )
        for name, r in per.items():
            pole = parsed[name].pole
            if pole is not None and name in self._elbow_tasks:
                task = self._elbow_tasks[name]
                pts = task.frame.points(task.chain, self.configuration.data)
                per[name] = r.with_details(pole="secondary task", pole_error=pole_angle(pts, pole))
        ok = all(r.converged for r in per.values())
        if status is None:
            status = Status.CONVERGED if ok else Status.MAX_ITERATIONS
        return UpperBodyResult(qpos, per, ok, iterations, status, "" if ok else message)

    # ------------------------------------------------------------------ calls
    def measure(self, targets: Mapping[str, Target | ArrayLike | None]) -> UpperBodyResult:
        """The errors toward ``targets`` at the current pose, without a step.

        Raises:
            TargetError: as in :meth:`step`.
        """
        key, parsed = self._set_targets(targets)
        return self._result(parsed, [n for n, _ in key], 0)

    def step(self, targets: Mapping[str, Target | ArrayLike | None], dt: float) -> UpperBodyResult:
        """One QP step toward ``targets`` with the joint velocity limit, for tracking.

        Args:
            targets: effector name -> :class:`~humanoid_ik.core.types.Target` or position
                ``(3,)`` [m] (a hand), or the point ``(3,)`` [m] to look at (the gaze).
                Effectors without a target (absent or ``None``) keep their joints
                frozen this step.
            dt: step duration in [s]; each joint moves at most ``max_velocity * dt``.

        Returns:
            The pose after the step and the errors measured there.

        Raises:
            TargetError: an unknown effector name, a bad target, or an orientation for
                the gaze.
            SolverError: ``dt`` not a finite number > 0.
        """
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
            raise SolverError(f"dt must be a finite number > 0 [s], got {dt!r}")
        key, parsed = self._set_targets(targets)
        order = [n for n, _ in key]
        if not order:
            return self._result(parsed, order, 0)
        found = self._step(self._problem(key, _poles(parsed, order)), float(dt))
        msg = "" if found else "the QP solver found no solution; the step was skipped"
        return self._result(parsed, order, 1, message=msg)

    def solve(self, targets: Mapping[str, Target | ArrayLike | None]) -> UpperBodyResult:
        """Iterate QP steps toward ``targets`` until every effector is within tolerance.

        Each iteration moves every joint by at most ``max_step`` [rad] (a step of
        ``dt = max_step / max_velocity``). Stops after ``max_iterations``, or when the
        summed error (position [m] + 0.1 orientation [rad]) has not dropped 1 % in
        ``stall_window`` iterations. The pose reached is kept (not the best seen).

        Args:
            targets: as in :meth:`step`.

        Raises:
            TargetError: as in :meth:`step`.
        """
        o = self.options
        key, parsed = self._set_targets(targets)
        order = [n for n, _ in key]
        if not order:
            return self._result(parsed, order, 0)
        prob = self._problem(key, _poles(parsed, order))
        dt = o.max_step / o.max_velocity
        stalled = Stall(o.stall_window)
        message = f"no convergence in {o.max_iterations} iterations"
        it = 0
        while True:
            cost, done = 0.0, True
            for name in order:
                ep, er = self._errors(name, parsed[name])
                done = done and self._within(name, ep, er)
                cost += pose_cost(ep, er)
            if done:
                return self._result(parsed, order, it)
            if it >= o.max_iterations:
                break
            if stalled(it, cost):
                message = f"stalled after {it} iterations (no 1 % progress in {stalled.window})"
                break
            if not self._step(prob, dt):
                message = f"the QP solver found no solution at iteration {it + 1}"
                break
            it += 1
        return self._result(parsed, order, it, Status.MAX_ITERATIONS, message)


def _poles(parsed: Mapping[str, Target], order: Sequence[str]) -> tuple[str, ...]:
    """The effectors in ``order`` whose target has an elbow pole."""
    return tuple(n for n in order if parsed[n].pole is not None)
