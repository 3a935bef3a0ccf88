"""Run a scene: per frame move the targets, solve, write ``qpos``, ``mj_forward``, measure.

Per frame ``i`` at ``t = i / fps``:

1. every target moves to ``motion.position(t)`` (and ``orientation.quat_at(t)``);
2. every effector's solver solves from the joint values of the previous frame (warm
   start; the first frame starts at the ``home`` keyframe);
3. the solutions are written into the scene's ``MjData.qpos`` and ``mj_forward`` runs once;
4. metrics are read from that ``MjData`` (not from the solver): target and achieved
   position, position and orientation error, iterations, solve time, the nearest
   joint-limit margin, and whether the target is within reach.

Solvers that move several effectors at once (the hook): a registered solver class with
a ``solve_effectors(goals)`` method receives every effector that uses it in one call, as
a sequence of :class:`EffectorGoal`, and returns one
:class:`~humanoid_ik.types.IKResult` per goal, in order. Any other solver is called once
per effector through ``Solver.solve(chain, target, q0)``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.chain import Chain, load_model
from humanoid_ik.errors import HumanoidIKError, SceneError
from humanoid_ik.scenes import EffectorSpec, Scene, SolverSpec, check_scene
from humanoid_ik.types import IKResult, Target

__all__ = [
    "ON_TARGET_ANGLE",
    "ON_TARGET_DISTANCE",
    "EffectorGoal",
    "EffectorSample",
    "FrameRecord",
    "Metrics",
    "SceneRunner",
    "atomic_path",
    "chain_reach",
    "run_scene",
]

ON_TARGET_DISTANCE = 1e-3
"""An effector is on target within this distance [m] (look-at: of the gaze ray)."""
ON_TARGET_ANGLE = 1e-2
"""... and, for a pose target, within this angle [rad]."""


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


@dataclass(frozen=True)
class EffectorSample:
    """What one effector did in one frame (measured on the scene's ``MjData``).

    Attributes:
        effector: the site name.
        target_name: the target it tracks.
        task: ``reach`` or ``look_at``.
        target: target position ``(3,)`` [m].
        achieved: the site position ``(3,)`` [m]; for ``look_at`` the gaze point (on the
            site's x axis, as far from the site as the target).
        position_error: distance from the site to the target [m]; for ``look_at`` the
            distance from the target to the gaze ray.
        orientation_error: angle between achieved and target orientation [rad] (pose
            targets), the gaze's angle off the target (``look_at``), else ``None``.
        iterations: the solver's iterations.
        solve_time: the solver's wall time [s] (a solver that moves several effectors
            at once splits its time equally).
        limit_margin: smallest distance of a chain joint to its range end [rad].
        reachable: the target lies within the chain's reach (``look_at``: the gaze can
            turn onto it within the joint ranges).
        on_target: within :data:`ON_TARGET_DISTANCE` (and :data:`ON_TARGET_ANGLE`).
        status: the solver's status.
    """

    effector: str
    target_name: str
    task: str
    target: NDArray[np.float64]
    achieved: NDArray[np.float64]
    position_error: float
    orientation_error: float | None
    iterations: int
    solve_time: float
    limit_margin: float
    reachable: bool
    on_target: bool
    status: str


@dataclass(frozen=True)
class FrameRecord:
    """One frame: its index, time [s] and one sample per effector (scene order)."""

    index: int
    time: float
    samples: tuple[EffectorSample, ...]

    @property
    def solve_time(self) -> float:
        """Total solver time of the frame [s]."""
        return float(sum(s.solve_time for s in self.samples))


_CSV_FIELDS = [
    "frame",
    "time_s",
    "effector",
    "target_name",
    "task",
    "target_x",
    "target_y",
    "target_z",
    "achieved_x",
    "achieved_y",
    "achieved_z",
    "position_error_m",
    "orientation_error_rad",
    "iterations",
    "solve_time_s",
    "limit_margin_rad",
    "reachable",
    "on_target",
    "status",
]


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` when the block succeeds,
    removed when it fails, so ``path`` is never half written.

    Args:
        path: the final file.
        suffix: the temporary file's extension (default: that of ``path``; some
            writers choose the format from it).
    """
    final = Path(path)
    ext = final.suffix if suffix is None else suffix
    tmp = final.with_name(f".{final.stem}.{os.getpid()}.{threading.get_ident()}.tmp{ext}")
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        if tmp.exists():
            tmp.unlink()


class Metrics:
    """Every frame's record of a run, with CSV/JSON export and a summary.

    Args:
        scene: the scene that ran.
        solvers: the solver label of each effector (scene order).
    """

    def __init__(self, scene: Scene, solvers: Sequence[str]):
        self.scene = scene
        self.solvers = list(solvers)
        self.frames: list[FrameRecord] = []
        self.interrupted = False

    def __len__(self) -> int:
        return len(self.frames)

    def append(self, frame: FrameRecord) -> None:
        """Add a frame's record."""
        self.frames.append(frame)

    def series(self, effector: int, attribute: str) -> NDArray[np.float64]:
        """One attribute of one effector over the frames ``(frames,)`` (``None`` -> NaN)."""
        vals = [getattr(f.samples[effector], attribute) for f in self.frames]
        return np.array([math.nan if v is None else v for v in vals], dtype=np.float64)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per frame and effector, keyed like the CSV columns."""
        out = []
        for f in self.frames:
            for s in f.samples:
                out.append(
                    {
                        "frame": f.index,
                        "time_s": f.time,
                        "effector": s.effector,
                        "target_name": s.target_name,
                        "task": s.task,
                        "target_x": float(s.target[0]),
                        "target_y": float(s.target[1]),
                        "target_z": float(s.target[2]),
                        "achieved_x": float(s.achieved[0]),
                        "achieved_y": float(s.achieved[1]),
                        "achieved_z": float(s.achieved[2]),
                        "position_error_m": s.position_error,
                        "orientation_error_rad": s.orientation_error,
                        "iterations": s.iterations,
                        "solve_time_s": s.solve_time,
                        "limit_margin_rad": s.limit_margin,
                        "reachable": s.reachable,
                        "on_target": s.on_target,
                        "status": s.status,
                    }
                )
        return out

    def summary(self) -> list[dict[str, Any]]:
        """Per effector: frames, reachable frames, share on target while reachable, worst
        and median position error while reachable [m], median and worst solve time [s]."""
        out = []
        for k, eff in enumerate(self.scene.effectors):
            err = self.series(k, "position_error")
            reach = self.series(k, "reachable").astype(bool)
            on = self.series(k, "on_target").astype(bool)
            st = self.series(k, "solve_time")
            er = err[reach]
            out.append(
                {
                    "effector": eff.site,
                    "target": eff.target,
                    "task": eff.task,
                    "solver": self.solvers[k],
                    "frames": len(self.frames),
                    "reachable_frames": int(reach.sum()),
                    "on_target_when_reachable": float(on[reach].mean()) if er.size else None,
                    "max_position_error_reachable_m": float(er.max()) if er.size else None,
                    "median_position_error_reachable_m": float(np.median(er)) if er.size else None,
                    "median_solve_time_s": float(np.median(st)) if st.size else None,
                    "max_solve_time_s": float(st.max()) if st.size else None,
                    "max_iterations": int(self.series(k, "iterations").max()) if self.frames else 0,
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the scene, the summary and every sample."""
        sc = self.scene
        return {
            "scene": sc.name,
            "source": sc.source,
            "fps": sc.fps,
            "frames": len(self.frames),
            "interrupted": self.interrupted,
            "effectors": [
                {"site": e.site, "target": e.target, "task": e.task, "solver": s}
                for e, s in zip(sc.effectors, self.solvers, strict=True)
            ],
            "summary": self.summary(),
            "samples": self.rows(),
        }

    def csv_text(self) -> str:
        """The samples as CSV text (one row per frame and effector)."""
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=_CSV_FIELDS, lineterminator="\n")
        w.writeheader()
        for row in self.rows():
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()

    def write_csv(self, path: str | os.PathLike) -> Path:
        """Write :meth:`csv_text` to ``path`` atomically; returns the path."""
        with atomic_path(path) as tmp:
            tmp.write_text(self.csv_text())
        return Path(path)

    def write_json(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_dict` as JSON to ``path`` atomically; returns the path."""
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=1) + "\n")
        return Path(path)


def chain_reach(chain: Chain) -> tuple[NDArray[np.float64], float]:
    """The chain's base point ``(3,)`` [m] and an upper bound of its reach [m].

    The base is the first joint's anchor; the reach is the length of the polyline through
    the distinct joint anchors to the end effector, ``sum |a_{k+1} - a_k| + |p - a_last|``,
    measured at the chain's current pose (joints are hinges, so these distances never
    change); the chain is left as it was.
    """
    chain.set_q(chain.q)
    anchors, _ = chain.joint_axes()
    pts = [anchors[0]]
    for a in anchors[1:]:
        if float(np.linalg.norm(a - pts[-1])) > 1e-9:
            pts.append(a)
    pts.append(chain.position.copy())
    reach = float(sum(np.linalg.norm(b - a) for a, b in zip(pts[:-1], pts[1:], strict=True)))
    return anchors[0].copy(), reach


class SceneRunner:
    """Runs a scene frame by frame on its own ``MjModel``/``MjData``.

    Args:
        scene: the scene.
        model: a compiled model to use instead of compiling ``scene.model``.

    Raises:
        SceneError: the scene does not fit the model (see :func:`check_scene`).

    Attributes:
        model, data: MuJoCo's model and the data the frames are written to.
        chains: one chain per effector.
    """

    def __init__(self, scene: Scene, model: mujoco.MjModel | None = None):
        self.scene = scene
        if model is None:
            try:
                model = load_model(scene.model)
            except HumanoidIKError as exc:
                raise SceneError(scene.source, "model", str(exc)) from None
        self.model = model
        self.chains = check_scene(scene, model)
        self.data = mujoco.MjData(model)
        self.specs: list[SolverSpec] = [scene.solver_for(e) for e in scene.effectors]
        self.targets = [scene.target(e.target) for e in scene.effectors]
        self._site_ids = [c.ee_id for c in self.chains]
        self._reach = [chain_reach(c) for c in self.chains]
        # one solver object per distinct spec; effectors sharing a multi-effector solver
        # are solved together
        self._groups: list[tuple[Any, list[int]]] = []
        by_spec: dict[tuple, int] = {}
        for i, spec in enumerate(self.specs):
            key = (spec.name, tuple(sorted((k, repr(v)) for k, v in spec.options.items())))
            solver = None
            if key in by_spec:
                solver = self._groups[by_spec[key]][0]
            if solver is not None and callable(getattr(solver, "solve_effectors", None)):
                self._groups[by_spec[key]][1].append(i)
                continue
            if solver is None:
                solver = spec.make()
                by_spec[key] = len(self._groups)
            self._groups.append((solver, [i]))
        self.reset()

    @property
    def n_frames(self) -> int:
        """Frames of a full run."""
        return self.scene.n_frames

    def solver_labels(self) -> list[str]:
        """Each effector's solver, as ``name`` or ``name(options)``."""
        return [s.label() for s in self.specs]

    def reset(self) -> None:
        """Back to the home keyframe (warm starts forgotten)."""
        m, d = self.model, self.data
        kid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home")
        if kid >= 0:
            mujoco.mj_resetDataKeyframe(m, d, kid)
        else:
            mujoco.mj_resetData(m, d)
        for c in self.chains:
            d.qpos[c.qpos_adr] = c.q_home
        mujoco.mj_forward(m, d)
        self.q = [c.q_home.copy() for c in self.chains]

    def time_of(self, index: int) -> float:
        """Time of frame ``index`` [s]."""
        return index / self.scene.fps

    def step(self, index: int) -> FrameRecord:
        """Solve and apply frame ``index`` (warm-started from the previous call)."""
        t = self.time_of(index)
        m, d = self.model, self.data
        targets = [trk.at(t) for trk in self.targets]
        results: list[IKResult | None] = [None] * len(self.chains)
        times = [0.0] * len(self.chains)
        for solver, members in self._groups:
            for i in members:
                self.chains[i].load(d)
            if callable(getattr(solver, "solve_effectors", None)):  # several effectors at once
                goals = [
                    EffectorGoal(
                        self.chains[i], targets[i], self.q[i], self.scene.effectors[i].task
                    )
                    for i in members
                ]
                t0 = time.perf_counter()
                out = list(solver.solve_effectors(goals))
                dt = (time.perf_counter() - t0) / len(members)
                if len(out) != len(members):
                    raise HumanoidIKError(
                        f"solver '{solver.name}' returned {len(out)} results for "
                        f"{len(members)} effectors"
                    )
                for i, res in zip(members, out, strict=True):
                    results[i], times[i] = res, dt
            else:
                i = members[0]
                t0 = time.perf_counter()
                res = solver.solve(self.chains[i], targets[i], self.q[i])
                times[i] = time.perf_counter() - t0
                results[i] = res
        for i, res in enumerate(results):
            assert res is not None
            q = self.chains[i].clip(res.q)
            self.q[i] = q
            d.qpos[self.chains[i].qpos_adr] = q
        mujoco.mj_forward(m, d)
        samples = tuple(
            self._measure(i, targets[i], results[i], times[i])  # type: ignore[arg-type]
            for i in range(len(self.chains))
        )
        return FrameRecord(index, t, samples)

    def _measure(self, i: int, target: Target, res: IKResult, dt: float) -> EffectorSample:
        eff: EffectorSpec = self.scene.effectors[i]
        d = self.data
        sid = self._site_ids[i]
        p = d.site_xpos[sid].copy()
        R = d.site_xmat[sid].reshape(3, 3)
        pd = target.position
        orient: float | None = None
        if eff.task == "look_at":
            v = pd - p
            dist = float(np.linalg.norm(v))
            fwd = R[:, 0]
            ang = math.atan2(float(np.linalg.norm(np.cross(fwd, v))), float(fwd @ v))
            miss = dist * math.sin(ang) if ang < math.pi / 2 else dist
            achieved = p + dist * fwd
            err, orient = miss, ang
            reachable = bool(res.converged)
        else:
            achieved = p
            err = float(np.linalg.norm(pd - p))
            if target.quat is not None:
                q_site = np.empty(4)
                mujoco.mju_mat2Quat(q_site, R.reshape(9))
                dot = min(1.0, abs(float(q_site @ target.quat)))
                orient = 2.0 * math.acos(dot)
            base, reach = self._reach[i]
            reachable = float(np.linalg.norm(pd - base)) <= reach
        on = err <= ON_TARGET_DISTANCE and (
            orient is None or eff.task == "look_at" or orient <= ON_TARGET_ANGLE
        )
        return EffectorSample(
            effector=eff.site,
            target_name=eff.target,
            task=eff.task,
            target=np.array(pd),
            achieved=achieved,
            position_error=err,
            orientation_error=orient,
            iterations=int(res.iterations),
            solve_time=dt,
            limit_margin=self.chains[i].limit_margin(self.q[i]),
            reachable=reachable,
            on_target=bool(on),
            status=res.status,
        )

    def run(
        self,
        frames: int | None = None,
        on_frame: Callable[[FrameRecord], None] | None = None,
    ) -> Metrics:
        """Run ``frames`` frames (default: the whole scene) from the home pose.

        Args:
            frames: how many frames.
            on_frame: called after each frame (with ``self.data`` at that frame).

        Returns:
            The metrics of every frame run. Ctrl-C (``KeyboardInterrupt``) stops the run
            early: the frames so far are returned with ``interrupted`` set.
        """
        n = self.n_frames if frames is None else frames
        self.reset()
        metrics = Metrics(self.scene, self.solver_labels())
        try:
            for i in range(n):
                rec = self.step(i)
                metrics.append(rec)
                if on_frame is not None:
                    on_frame(rec)
        except KeyboardInterrupt:
            metrics.interrupted = True
        return metrics


def run_scene(scene: Scene | str | os.PathLike, frames: int | None = None) -> Metrics:
    """Run a scene (a :class:`Scene`, a scene file or a bundled scene's name) without
    rendering and return its metrics."""
    from humanoid_ik.scenes import load_scene

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    return SceneRunner(sc).run(frames)
