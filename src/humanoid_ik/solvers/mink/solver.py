"""The ``mink`` solver: differential IK as a quadratic program through mink and daqp.

One QP step finds the displacement ``dq`` ``(nv,)`` minimising the weighted task errors
linearised at ``q``::

    min  sum_tasks |W_i (J_i dq + e_i)|^2 + damping |dq|^2
    s.t. gain_r (q_min - q) <= dq <= gain_r (q_max - q)     active joints (JointRangeLimit)
         |dq| <= v_max dt                                   active joints (JointVelocityLimit)
         -n' (J_2 - J_1) dq <= gain_c (d - d_min)           geom pairs nearer than d_detect
         dq_k = 0                                           joints of no active chain

Tasks: a ``mink.FrameTask`` per hand with a target (position, or full pose), a
:class:`~humanoid_ik.solvers.mink.ext.GazeTask` for the head, and a ``mink.PostureTask``
toward the ``home`` keyframe. The active chains are those of the effectors that have a
target in the call; every other joint is frozen by a ``mink.DofFreezingTask`` passed as
an equality constraint, and only the active joints are integrated, so frozen joints keep
their values bit for bit. ``dq = 0`` satisfies every constraint (active joints are
moved inside their ranges before a step, frozen joints have no range row, collision
bounds are >= 0), so the QP is never infeasible, even when a frozen joint sits outside
its range. Both hands and the gaze are solved jointly in one QP per step.

Entry points:

- :class:`MinkSolver` (``"mink"``): the :class:`~humanoid_ik.solvers.base.Solver` on one
  :class:`~humanoid_ik.core.chain.Chain`, iterating QP steps to convergence; usable by name
  in ``solve``, ``bench`` and the CLI. Its ``solve_effectors(goals)`` is the scene
  runner's multi-effector hook: every effector of a scene whose solver is ``mink``
  (``reach`` hands and one ``look_at`` gaze) is solved in one QP per step; with the
  option ``dt`` (the frame time [s]) each frame is one velocity-limited step.
- :class:`UpperBodyIK`: both hands and the gaze of the upper body; owns a
  ``mink.Configuration``. Per frame of a scene::

      ik = UpperBodyIK(model)             # once (the scene's MjModel)
      ik.load(data)                       # once, start from the scene's qpos
      res = ik.step(                      # every frame, dt = frame time [s]
          {"right_palm_site": Target(p_r, quat_r), "left_palm_site": p_l,
           "gaze_site": p_look},
          dt,
      )
      ik.apply(data)                      # writes the chains' joints, runs mj_forward

  ``res`` is an :class:`UpperBodyResult`: the full ``qpos`` and an ``IKResult`` per
  target (errors measured with MuJoCo FK after the step). ``ik.solve(targets)``
  iterates steps to convergence instead.

mink (with qpsolvers and SciPy) takes about 0.2 s to import, so it is imported when the
first mink object is built, not with :mod:`humanoid_ik`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import pose_error
from humanoid_ik.core.models import home_qpos, load_model
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import ChainError, NameNotFoundError, SolverError, TargetError, choices
from humanoid_ik.solvers.base import Solver

__all__ = [
    "MinkSolver",
    "UpperBodyIK",
    "UpperBodyResult",
    "DEFAULT_HANDS",
    "DEFAULT_GAZE",
    "DEFAULT_COLLISION_PAIRS",
]

DEFAULT_HANDS = ("right_palm_site", "left_palm_site")
DEFAULT_GAZE = "gaze_site"
_BODY = ("torso_collision", "chest_collision", "head_collision")
DEFAULT_COLLISION_PAIRS: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = (
    (("right_forearm_collision", "right_hand_collision"), _BODY),
    (("left_forearm_collision", "left_hand_collision"), _BODY),
    (("right_hand_collision",), ("left_hand_collision",)),
)
"""Each forearm and hand against torso, chest and head, and hand against hand."""
_HALVINGS = 6
_TASKS = ("reach", "look_at")


@dataclass(frozen=True)
class UpperBodyResult:
    """What one :meth:`UpperBodyIK.step` or :meth:`UpperBodyIK.solve` did.

    One ``IKResult`` per effector with a target (chosen over a new per-effector type so
    metrics and the CLI read every solver's errors the same way): its ``q`` holds that
    chain's joints, its errors are measured with MuJoCo FK at the returned pose; for the
    gaze, ``position_error`` is the distance from the target to the gaze ray and
    ``orientation_error`` the angle between the forward axis and the target direction.

    Attributes:
        q: full ``qpos`` ``(nq,)`` [rad] after the call.
        effectors: ``IKResult`` per effector name with a target (hands in the order
            configured, then the gaze).
        converged: every effector within ``tol`` / ``rot_tol``.
        iterations: QP steps taken (1 for ``step``).
        status: ``converged`` or ``max_iterations`` (also after a stall; see ``message``).
        message: why it did not converge, or ``""``.
    """

    q: NDArray[np.float64]
    effectors: Mapping[str, IKResult]
    converged: bool
    iterations: int
    status: str
    message: str = ""

    def __post_init__(self) -> None:
        q = np.array(self.q, dtype=np.float64)
        q.setflags(write=False)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "effectors", MappingProxyType(dict(self.effectors)))

    def __getitem__(self, name: str) -> IKResult:
        return self.effectors[name]


@dataclass
class _Problem:
    """Tasks, limits and constraints of one set of active effectors, built once."""

    key: tuple[tuple[str, bool], ...]
    tasks: list[Any]
    limits: list[Any]
    constraints: list[Any] | None
    qpos_adr: NDArray[np.int64]
    dof_adr: NDArray[np.int64]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    frozen_dof: NDArray[np.int64]


def _import_mink():
    """mink and the extensions, imported on first use (about 0.2 s)."""
    import mink
    import qpsolvers

    from humanoid_ik.solvers.mink import ext as mink_ext

    return mink, qpsolvers, mink_ext


class UpperBodyIK:
    """Both hands and the gaze of a humanoid solved jointly by mink, one QP per step.

    Args:
        model: an ``MjModel``, an MJCF path, or ``None`` for the bundled humanoid.
        hands: hand effectors: site names (chain by the path rule) or
            :class:`~humanoid_ik.core.chain.Chain` objects on the same model (custom joints or
            a body end effector).
        gaze: the gaze effector (a site name or a chain), or ``None`` for no gaze.
        collision_pairs: pairs of geom-name groups kept apart (every geom of a group
            against every geom of the other); ``()`` or ``None`` for none. Default:
            :data:`DEFAULT_COLLISION_PAIRS`.
        gaze_axis: the gaze site's forward axis ``(3,)`` in its frame.
        **options: numbers overriding :attr:`defaults`, and ``qp_solver`` (a qpsolvers
            backend name, default ``daqp``):

            - ``position_cost`` [1/m], ``orientation_cost`` [1/rad], ``gaze_cost``,
              ``posture_cost`` [1/rad]: task weights.
            - ``posture_gain``: fraction of the way back to ``home`` the posture task asks
              for per step (below 1 so its pull in the null space of the hand tasks does
              not overshoot and oscillate).
            - ``damping``: Levenberg-Marquardt damping on ``dq`` (all tasks);
              ``lm_damping``: error-scaled damping of the hand tasks (mink).
            - ``max_velocity`` [rad/s]: joint velocity limit of :meth:`step`.
            - ``max_step`` [rad]: largest joint change per iteration of :meth:`solve`.
            - ``range_gain``: fraction of the distance to a range end one step may use.
            - ``collision_gain``, ``min_distance`` [m], ``detection_distance`` [m]:
              collision pairs may close ``collision_gain`` of their margin over
              ``min_distance`` per step; pairs farther than ``detection_distance`` add
              no row.
            - ``tol`` [m], ``rot_tol`` [rad], ``max_iterations``, ``stall_window``:
              convergence of :meth:`solve` (no 1 % progress in ``stall_window``
              iterations stops it).

    Raises:
        ModelError, NameNotFoundError: a bad model path, site or geom name (the message
            lists the valid names).
        ChainError: a chain on another model, or an effector given twice.
        SolverError: a bad option.
    """

    defaults: ClassVar[dict[str, float | int]] = {
        "position_cost": 1.0,
        "orientation_cost": 0.5,
        "gaze_cost": 1.0,
        "posture_cost": 1e-3,
        "posture_gain": 0.1,
        "damping": 1e-12,
        "lm_damping": 0.0,
        "max_velocity": 4.0,
        "max_step": 0.2,
        "range_gain": 0.95,
        "collision_gain": 0.85,
        "min_distance": 0.01,
        "detection_distance": 0.1,
        "tol": 1e-4,
        "rot_tol": 1e-3,
        "max_iterations": 200,
        "stall_window": 10,
    }
    _positive: ClassVar[frozenset[str]] = frozenset(
        {"max_velocity", "max_step", "range_gain", "collision_gain", "detection_distance"}
    )
    _at_most_one: ClassVar[frozenset[str]] = frozenset(
        {"range_gain", "collision_gain", "posture_gain"}
    )

    def __init__(
        self,
        model: mujoco.MjModel | str | os.PathLike | None = None,
        *,
        hands: Sequence[str | Chain] = DEFAULT_HANDS,
        gaze: str | Chain | None = DEFAULT_GAZE,
        collision_pairs: Sequence[tuple[Sequence[str], Sequence[str]]]
        | None = DEFAULT_COLLISION_PAIRS,
        gaze_axis: ArrayLike = (1.0, 0.0, 0.0),
        **options: Any,
    ):
        self.options = self._check_options(options)
        given = [c for c in (*hands, gaze) if isinstance(c, Chain)]
        if model is None and given:
            self.model = given[0].model
        else:
            self.model = load_model(model)
        m = self.model
        self._hand_chains = [self._chain(h) for h in hands]
        self._gaze_chain = None if gaze is None else self._chain(gaze)
        chains = [*self._hand_chains] + ([self._gaze_chain] if self._gaze_chain else [])
        names = [c.ee_name for c in chains]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ChainError(f"effector '{dup[0]}' is given twice; effectors: {', '.join(names)}")
        self.chains: dict[str, Chain] = {c.ee_name: c for c in chains}
        """The effectors' chains by effector name (hands first, then the gaze)."""
        pairs = () if collision_pairs is None else tuple(collision_pairs)
        self._check_geoms(pairs)

        mink, qpsolvers, ext = _import_mink()
        solver = self.options["qp_solver"]
        if solver not in qpsolvers.available_solvers:
            raise SolverError(
                f"QP solver '{solver}' not installed; QP solvers: "
                f"{choices(qpsolvers.available_solvers)}"
            )
        self._mink, self._qpsolvers = mink, qpsolvers
        o = self.options
        self.configuration = mink.Configuration(m)
        """The ``mink.Configuration`` holding the solver's ``qpos`` and kinematics."""
        self._pose_tasks = {
            c.ee_name: mink.FrameTask(
                c.ee_name,
                c.ee_kind,
                position_cost=o["position_cost"],
                orientation_cost=o["orientation_cost"],
                lm_damping=o["lm_damping"],
            )
            for c in self._hand_chains
        }
        self._position_tasks = {
            c.ee_name: ext.PositionTask(
                m, c.ee_name, c.ee_kind, cost=o["position_cost"], lm_damping=o["lm_damping"]
            )
            for c in self._hand_chains
        }
        self._gaze_task = None
        if self._gaze_chain is not None:
            if self._gaze_chain.ee_kind != "site":
                raise ChainError(
                    f"the gaze effector must be a site, got body '{self._gaze_chain.ee_name}'"
                )
            self._gaze_task = ext.GazeTask(
                m, self._gaze_chain.ee_name, gaze_axis, cost=o["gaze_cost"]
            )
        self.q_home = self._home()
        self._posture = mink.PostureTask(m, cost=o["posture_cost"], gain=o["posture_gain"])
        self._posture.set_target(self.q_home)
        all_ids = sorted({int(j) for c in chains for j in c.joint_ids})
        self._velocity = ext.JointVelocityLimit(m, all_ids, o["max_velocity"])
        self._collision = None
        if pairs:
            self._collision = ext.CollisionLimit(
                m,
                [(list(a), list(b)) for a, b in pairs],
                gain=o["collision_gain"],
                minimum_distance_from_collisions=o["min_distance"],
                collision_detection_distance=o["detection_distance"],
            )
        self._problems: dict[tuple[tuple[str, bool], ...], _Problem] = {}
        self._err_buffers = (np.empty(6), np.empty((2, 4)))  # error vector, quaternion scratch
        self._dq = np.zeros(m.nv)
        self._dist = np.empty(0 if self._collision is None else len(self._collision.geom_id_pairs))
        self.reset()

    # ------------------------------------------------------------------ set-up
    @classmethod
    def _check_options(cls, options: Mapping[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = {**cls.defaults, "qp_solver": "daqp"}
        for key, value in options.items():
            if key not in out:
                raise SolverError(
                    f"option '{key}' unknown for the mink solver; options: {choices(out)}"
                )
            if key == "qp_solver":
                if not isinstance(value, str):
                    raise SolverError(f"option 'qp_solver' must be a name, got {value!r}")
                out[key] = value
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SolverError(f"option '{key}' must be a number, got {value!r}")
            v = float(value)
            bad = (
                not math.isfinite(v)
                or v < 0
                or (key in cls._positive and v == 0)
                or (key in cls._at_most_one and v > 1)
            )
            if bad:
                rule = (
                    "in (0, 1]"
                    if key in cls._at_most_one
                    else ("> 0" if key in cls._positive else ">= 0")
                )
                raise SolverError(f"option '{key}' must be a finite number {rule}, got {value!r}")
            out[key] = int(v) if isinstance(cls.defaults[key], int) else v
        return out

    def _chain(self, spec: str | Chain) -> Chain:
        if isinstance(spec, Chain):
            if spec.model is not self.model:
                raise ChainError(
                    f"chain of '{spec.ee_name}' is built on another MjModel; build every "
                    "chain on the model given to UpperBodyIK"
                )
            return spec
        return Chain(self.model, spec)

    def _check_geoms(self, pairs: Sequence[tuple[Sequence[str], Sequence[str]]]) -> None:
        m = self.model
        unknown: list[str] = []
        for pair in pairs:
            if len(pair) != 2:
                raise ChainError(f"collision pair {pair!r} must be two groups of geom names")
            for group in pair:
                for name in [group] if isinstance(group, str) else group:
                    if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) < 0:
                        if name not in unknown:
                            unknown.append(name)
        if unknown:
            valid = [m.geom(i).name for i in range(m.ngeom) if m.geom(i).name]
            raise NameNotFoundError("geom", "', '".join(unknown), valid)

    def _home(self) -> NDArray[np.float64]:
        """``qpos`` of the ``home`` keyframe (else ``qpos0``), chain joints inside ranges."""
        q = home_qpos(self.model)
        for c in self.chains.values():
            q[c.qpos_adr] = c.clip(q[c.qpos_adr])
        return q

    def _problem(self, key: tuple[tuple[str, bool], ...]) -> _Problem:
        """The tasks and limits for the effectors in ``key`` (name, pose target?) pairs,
        built on first use."""
        prob = self._problems.get(key)
        if prob is not None:
            return prob
        mink, _, ext = _import_mink()
        names = tuple(n for n, _ in key)
        m, o = self.model, self.options
        ids = sorted({int(j) for n in names for j in self.chains[n].joint_ids})
        jids = np.array(ids, dtype=np.int64)
        gaze_name = None if self._gaze_chain is None else self._gaze_chain.ee_name
        tasks: list[Any] = [
            self._gaze_task
            if n == gaze_name
            else (self._pose_tasks[n] if pose else self._position_tasks[n])
            for n, pose in key
        ]
        tasks.append(self._posture)
        limits: list[Any] = [ext.JointRangeLimit(m, ids, o["range_gain"]), self._velocity]
        if self._collision is not None:
            limits.append(self._collision)
        dof = m.jnt_dofadr[jids].astype(np.int64)
        frozen = np.setdiff1d(np.arange(m.nv), dof)
        constraints = [mink.DofFreezingTask(m, frozen.tolist())] if frozen.size else None
        limited = m.jnt_limited[jids].astype(bool)
        prob = _Problem(
            key=key,
            tasks=tasks,
            limits=limits,
            constraints=constraints,
            qpos_adr=m.jnt_qposadr[jids].astype(np.int64),
            dof_adr=dof,
            lower=np.where(limited, m.jnt_range[jids, 0], -np.inf),
            upper=np.where(limited, m.jnt_range[jids, 1], np.inf),
            frozen_dof=frozen,
        )
        self._problems[key] = prob
        return prob

    # ------------------------------------------------------------------ state
    @property
    def q(self) -> NDArray[np.float64]:
        """Full ``qpos`` ``(nq,)`` [rad] (a copy)."""
        return self.configuration.data.qpos.copy()

    @property
    def last_dq(self) -> NDArray[np.float64]:
        """Displacement ``(nv,)`` [rad] the last QP step returned (a copy)."""
        return self._dq.copy()

    @property
    def effector_names(self) -> list[str]:
        """Names that :meth:`step` and :meth:`solve` accept as target keys."""
        return list(self.chains)

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
        """Start from the caller's ``qpos`` (every joint); ``data`` is only read."""
        self.set_q(data.qpos)

    def apply(self, data: mujoco.MjData) -> None:
        """Write the chains' joints into the caller's ``data`` and run ``mj_forward``."""
        src = self.configuration.data.qpos
        for c in self.chains.values():
            data.qpos[c.qpos_adr] = src[c.qpos_adr]
        mujoco.mj_forward(self.model, data)

    # ------------------------------------------------------------------ targets
    def _set_targets(self, targets: Mapping[str, Any]) -> tuple[tuple, dict[str, Target]]:
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
                self._gaze_task.set_target(tgt.position)
            elif tgt.is_pose:
                wxyz_xyz = np.concatenate([tgt.quat, tgt.position])
                self._pose_tasks[name].transform_target_to_world = self._mink.SE3(wxyz_xyz)
            else:
                self._position_tasks[name].set_target(tgt.position)
            parsed[name] = tgt
        key = tuple((n, parsed[n].is_pose) for n in self.chains if n in parsed)
        return key, parsed

    def _errors(self, name: str, tgt: Target) -> tuple[float, float | None]:
        """(position error [m], orientation error [rad] or None) of one effector now."""
        chain = self.chains[name]
        d = self.configuration.data
        if self._gaze_chain is not None and name == self._gaze_chain.ee_name:
            miss, theta = self._gaze_task.error(self.configuration)
            return miss, theta
        pos = (d.site_xpos if chain.ee_kind == "site" else d.xpos)[chain.ee_id]
        xmat = (d.site_xmat if chain.ee_kind == "site" else d.xmat)[chain.ee_id]
        ep, er = pose_error(pos, xmat, tgt.position, tgt.quat, *self._err_buffers)
        return ep, (er if tgt.is_pose else None)

    def _within(self, name: str, ep: float, er: float | None) -> bool:
        o = self.options
        if self._gaze_chain is not None and name == self._gaze_chain.ee_name:
            return er is not None and er < o["rot_tol"]
        return ep < o["tol"] and (er is None or er < o["rot_tol"])

    # ------------------------------------------------------------------ QP
    def _qp_step(self, prob: _Problem, dt: float) -> bool:
        """One QP step of length ``dt``; integrates the active joints. False if no solution.

        With collision pairs, a step after which some pair is closer than
        ``min(its distance before, min_distance / 2)`` (the linearised row missed a
        second-order loss) is halved, up to ``_HALVINGS`` times, then dropped.
        """
        cfg = self.configuration
        qpos = cfg.data.qpos
        q_act = qpos[prob.qpos_adr]
        if np.any(q_act < prob.lower) or np.any(q_act > prob.upper):
            np.clip(q_act, prob.lower, prob.upper, out=q_act)
            qpos[prob.qpos_adr] = q_act
            cfg.update()
        problem = self._mink.build_ik(
            cfg,
            prob.tasks,
            dt,
            self.options["damping"],
            prob.limits,
            prob.constraints,
        )
        sol = self._qpsolvers.solve_problem(problem, solver=self.options["qp_solver"])
        if not sol.found or sol.x is None:
            self._dq[:] = 0.0
            return False
        self._dq[:] = sol.x
        # the QP meets its bounds to the solver's tolerance (about 1e-6 for daqp); clip
        # so the velocity and range limits hold exactly
        vmax = self.options["max_velocity"] * dt
        step = np.clip(self._dq[prob.dof_adr], -vmax, vmax)
        q_new = q_act + step
        np.clip(q_new, prob.lower, prob.upper, out=q_new)
        qpos[prob.qpos_adr] = q_new
        cfg.update()
        coll = self._collision
        if coll is None:
            return True
        floor = np.minimum(coll.last_distances, 0.5 * self.options["min_distance"])
        floor -= 1e-9
        dist = self._dist
        for _ in range(_HALVINGS):
            if np.all(coll.distances(cfg.data, dist) >= floor):
                return True
            step *= 0.5
            np.add(q_act, step, out=q_new)
            np.clip(q_new, prob.lower, prob.upper, out=q_new)
            qpos[prob.qpos_adr] = q_new
            cfg.update()
        if np.all(coll.distances(cfg.data, dist) >= floor):
            return True
        qpos[prob.qpos_adr] = q_act
        cfg.update()
        return True

    def _result(
        self,
        parsed: Mapping[str, Target],
        order: Sequence[str],
        iterations: int,
        status: str | None = None,
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
                status="converged" if ok else "max_iterations",
                solver=MinkSolver.name,
                message="" if ok else message,
            )
        ok = all(r.converged for r in per.values())
        if status is None:
            status = "converged" if ok else "max_iterations"
        return UpperBodyResult(qpos, per, ok, iterations, status, "" if ok else message)

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
        found = self._qp_step(self._problem(key), float(dt))
        msg = "" if found else "the QP solver found no solution; the step was skipped"
        return self._result(parsed, order, 1, message=msg)

    def solve(self, targets: Mapping[str, Target | ArrayLike | None]) -> UpperBodyResult:
        """Iterate QP steps toward ``targets`` until every effector is within tolerance.

        Each iteration moves every joint by at most ``max_step`` [rad]. Stops after
        ``max_iterations``, or when the summed error (position [m] + 0.1 orientation
        [rad]) has not dropped 1 % in ``stall_window`` iterations. The pose reached is
        kept (not the best seen).

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
        prob = self._problem(key)
        dt = o["max_step"] / o["max_velocity"]
        window = max(2, int(o["stall_window"]))
        history = np.full(window, math.inf)
        message = f"no convergence in {o['max_iterations']} iterations"
        it = 0
        while True:
            cost, done = 0.0, True
            for name in order:
                ep, er = self._errors(name, parsed[name])
                done = done and self._within(name, ep, er)
                cost += ep + 0.1 * (er or 0.0)
            if done:
                return self._result(parsed, order, it)
            if it >= o["max_iterations"]:
                break
            if it >= window and cost > 0.99 * history[it % window]:
                message = f"stalled after {it} iterations (no 1 % progress in {window})"
                break
            history[it % window] = cost
            if not self._qp_step(prob, dt):
                message = f"the QP solver found no solution at iteration {it + 1}"
                break
            it += 1
        return self._result(parsed, order, it, "max_iterations", message)


class MinkSolver(Solver):
    """Differential IK as a QP through mink on one chain, or on several at once.

    On one chain (:meth:`solve`): a frame task on the chain's end effector (position,
    or pose with ``orientation_cost``), a posture task toward ``home`` and joint range
    limits; the model's joints outside the chain are frozen by an equality constraint
    and keep their values exactly. Iterates QP steps (each joint moving at most
    ``max_step`` [rad] per step) until within ``tol`` / ``rot_tol``, restarting from
    seeded random in-range poses after a stall (``restarts``).

    On several chains (:meth:`solve_effectors`, the scene runner's hook): every
    ``reach`` effector gets a hand task and one ``look_at`` effector the gaze task, all
    in one QP per step. With ``dt`` > 0 each call is one tracking step of ``dt`` [s]
    under the joint velocity limit ``max_velocity`` (set ``dt`` to the scene's frame
    time); with ``dt = 0`` each call iterates to convergence.

    With ``collisions`` the chains also keep the bundled humanoid's collision pairs
    apart (:data:`DEFAULT_COLLISION_PAIRS`); use :class:`UpperBodyIK` directly for other
    geom names. Off by default so that the bench's random targets (some of which put
    the hand inside the torso) stay comparable with the other solvers.
    """

    name: ClassVar[str] = "mink"
    summary: ClassVar[str] = "differential IK as a QP through mink (daqp), limits as constraints"
    supports_orientation: ClassVar[bool] = True
    defaults: ClassVar[dict[str, Any]] = {
        "max_iterations": 200,
        "restarts": 20,
        "seed": 0,
        "max_step": 0.2,
        "stall_window": 10,
        "posture_cost": 1e-3,
        "posture_gain": 0.1,
        "orientation_cost": 0.5,
        "damping": 1e-12,
        "lm_damping": 0.0,
        "collisions": False,
        "dt": 0.0,
        "max_velocity": 4.0,
        "qp_solver": "daqp",
        "forward_axis": "x",
    }
    forward_axis_choices: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    _forwarded: ClassVar[tuple[str, ...]] = (
        "tol",
        "rot_tol",
        "max_iterations",
        "max_step",
        "stall_window",
        "posture_cost",
        "posture_gain",
        "orientation_cost",
        "damping",
        "lm_damping",
        "max_velocity",
        "qp_solver",
    )

    def __init__(self, **options: Any):
        super().__init__(**options)
        self._cache: tuple[Chain, UpperBodyIK] | None = None
        self._multi_cache: tuple[tuple[tuple[Chain, bool], ...], UpperBodyIK] | None = None

    def upper_body(self, chain: Chain) -> UpperBodyIK:
        """The :class:`UpperBodyIK` this solver runs on ``chain`` (built once per chain).

        Raises:
            SolverError: a bad option value (e.g. an unknown ``qp_solver``).
        """
        if self._cache is not None and self._cache[0] is chain:
            return self._cache[1]
        opts = {k: self.options[k] for k in self._forwarded}
        ik = UpperBodyIK(
            chain.model,
            hands=(chain,),
            gaze=None,
            collision_pairs=DEFAULT_COLLISION_PAIRS if self.collisions else None,
            **opts,
        )
        self._cache = (chain, ik)
        return ik

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        ik = self.upper_body(chain)
        qpos = chain.data.qpos.copy()
        key = {chain.ee_name: target}
        best_q, best_cost, iterations, message = q0.copy(), math.inf, 0, ""
        for start in self.starts(chain, q0):
            qpos[chain.qpos_adr] = start
            ik.set_q(qpos)
            res = ik.solve(key)
            iterations += res.iterations
            r = res[chain.ee_name]
            if res.converged:
                return self._result(chain, target, r.q, iterations)
            cost = r.position_error + 0.1 * (r.orientation_error or 0.0)
            if cost < best_cost:
                best_cost, best_q, message = cost, r.q.copy(), res.message
        return self._result(chain, target, best_q, iterations, message=message)

    def _multi(self, goals: Sequence[Any]) -> UpperBodyIK:
        """The :class:`UpperBodyIK` for these goals' chains and tasks (built once)."""
        key = tuple((g.chain, g.task == "look_at") for g in goals)
        cached = self._multi_cache
        if (
            cached is not None
            and len(cached[0]) == len(key)
            and all(a is b and la == lb for (a, la), (b, lb) in zip(cached[0], key, strict=True))
        ):
            return cached[1]
        for g in goals:
            if g.task not in _TASKS:
                raise SolverError(
                    f"task '{g.task}' of '{g.chain.ee_name}' unknown; tasks: {choices(_TASKS)}"
                )
        looks = [c for c, look in key if look]
        if len(looks) > 1:
            raise SolverError(
                "mink aims one look_at effector per call, got "
                f"{len(looks)}: {', '.join(c.ee_name for c in looks)}"
            )
        opts = {k: self.options[k] for k in self._forwarded}
        ik = UpperBodyIK(
            key[0][0].model,
            hands=[c for c, look in key if not look],
            gaze=looks[0] if looks else None,
            collision_pairs=DEFAULT_COLLISION_PAIRS if self.collisions else None,
            gaze_axis=self.gaze_axis(),
            **opts,
        )
        self._multi_cache = (key, ik)
        return ik

    def solve_effectors(self, goals: Sequence[Any]) -> list[IKResult]:
        """Solve several effectors jointly: the scene runner's multi-effector hook.

        Args:
            goals: items with ``chain`` (all on one model; their scratch ``qpos`` holds
                the scene's current joints), ``target`` (a :class:`Target`; for
                ``look_at`` its position is the point to look at), ``q0`` (the chain's
                warm start ``(n,)`` [rad]) and ``task`` (``reach`` or ``look_at``).

        Returns:
            One ``IKResult`` per goal, in order (``q`` in the chain's joint order). Joints
            outside the goals' chains are frozen.

        Raises:
            SolverError: an unknown task, more than one ``look_at``, a bad option.
            ChainError: chains on different models.
            TargetError: a bad warm start or target.
        """
        if not goals:
            return []
        ik = self._multi(goals)
        qpos = goals[0].chain.data.qpos.copy()
        targets: dict[str, Any] = {}
        for g in goals:
            chain = g.chain
            qpos[chain.qpos_adr] = chain.clip(chain.check_q(g.q0))
            tgt = Target.of(g.target)
            targets[chain.ee_name] = tgt.position if g.task == "look_at" else tgt
        ik.set_q(qpos)
        res = ik.step(targets, self.dt) if self.dt > 0 else ik.solve(targets)
        return [res[g.chain.ee_name] for g in goals]
