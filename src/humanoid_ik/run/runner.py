"""Run a scene: per frame move the targets, solve, write ``qpos``, update MuJoCo, measure.

Per frame ``i`` at ``t = i / fps``:

1. every target moves to ``motion.position(t)`` (and ``orientation.quat_at(t)``), once
   however many effectors track it (:meth:`Target.from_motion
   <humanoid_ik.core.types.Target.from_motion>`: the motion's output is not checked again);
   an effector with an elbow ``pole`` gets it in its target (``Target.pole``): its fixed
   point, or the position at ``t`` of the target it names;
2. every effector's solver solves from the joint values of the previous frame (warm
   start; the first frame starts at the ``home`` keyframe), in the one robot state all
   the scene's chains share (:class:`~humanoid_ik.core.robot.Robot`): nothing is
   copied between chains;
3. the solutions are in the robot's ``MjData.qpos`` and MuJoCo runs once: ``mj_forward``
   when a sink needs it (a film of the model itself, the viewer; a sink says so with
   ``needs_forward``, true unless it sets it false), else ``mj_kinematics``, all the
   recording and the measures read;
4. metrics are read from that ``MjData`` and the results: target and achieved
   position, position and orientation error (a result's errors, a gaze's too, are
   measured once, by MuJoCo FK at the pose it returns, which is the pose the frame
   shows), iterations,
   solve time, the nearest joint-limit margin, and whether the target is within reach
   (no farther from the chain's base, its first joint's anchor at this frame, than the
   chain's sampled reach, :meth:`Chain.reach <humanoid_ik.core.chain.Chain.reach>`).

Solvers that move several effectors at once (the hook): a solver with
``solves_effectors`` set receives every effector that uses it in one
``solve_effectors(goals)`` call, as a sequence of :class:`EffectorGoal`, and returns one
:class:`~humanoid_ik.core.types.IKResult` per goal, in order. Any other solver is called
once per effector through ``Solver.solve(chain, target, q0)``.

Outputs are collected beside the loop, not inside it: :meth:`SceneRunner.run` is the one
frame loop of the package, and hands every frame to its *sinks* (:class:`FrameSink`), the
run's :class:`~humanoid_ik.run.recording.Recording` last; the renderer, the video, the
stills and the GIF of :mod:`humanoid_ik.outputs.render` are sinks too.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.scene import Scene, SolverSpec, check_scene, scene_model
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import on_target
from humanoid_ik.core.types import EffectorGoal, IKResult, Target
from humanoid_ik.errors import HumanoidIKError, SceneError
from humanoid_ik.run.metrics import EffectorSample, FrameSamples
from humanoid_ik.run.recording import Recording

__all__ = [
    "FrameSink",
    "SceneRunner",
    "chain_reach",
    "frame_loop",
    "needs_forward",
    "run_scene",
]


chain_reach = Chain.reach
"""``chain_reach(chain)``: :meth:`Chain.reach <humanoid_ik.core.chain.Chain.reach>`, by
the name it had here."""


class FrameSink(Protocol):
    """Takes each frame of a run, beside :meth:`SceneRunner.run`'s loop (the metrics, the
    renderer...)."""

    def add_frame(self, frame: FrameSamples, data: mujoco.MjData) -> None:
        """Take one frame: its samples (``frame``) and the scene's ``data`` at that frame
        (after ``mj_forward``, or ``mj_kinematics`` when no sink of the run needs more,
        see :func:`needs_forward`; read it now, the next frame overwrites it)."""


def needs_forward(sinks: Sequence[object]) -> bool:
    """Whether a frame must run ``mj_forward`` for ``sinks``: a sink that only reads
    ``qpos`` and the kinematics sets ``needs_forward = False``; any other sink needs it."""
    return any(getattr(sink, "needs_forward", True) for sink in sinks)


def frame_loop(
    n: int,
    step: Callable[[int], FrameSamples],
    data: mujoco.MjData,
    sinks: Sequence[FrameSink],
    on_frame: Callable[[FrameSamples], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> tuple[list[float], bool]:
    """THE frame loop: for ``i`` in ``0 .. n-1``, ``frame = step(i)`` (which leaves the
    frame in ``data``), every sink in order gets ``(frame, data)``, then ``on_frame``;
    ``stop`` (asked before each frame) ends it early.

    Used by :meth:`SceneRunner.run` (``step`` solves), by a replay (``step`` reads a
    trajectory) and by the live viewer (``stop``: the window was closed).

    Returns:
        The wall time [s] of each frame's step and sinks, and whether Ctrl-C
        (``KeyboardInterrupt``) stopped the loop early. Any other exception propagates.
    """
    times: list[float] = []
    try:
        for i in range(n):
            if stop is not None and stop():
                break
            t0 = time.perf_counter()
            frame = step(i)
            for sink in sinks:
                sink.add_frame(frame, data)
            times.append(time.perf_counter() - t0)
            if on_frame is not None:
                on_frame(frame)
    except KeyboardInterrupt:
        return times, True
    return times, False


class SceneRunner:
    """Runs a scene frame by frame on its own ``MjModel``/``MjData``.

    Args:
        scene: the scene.
        model: a compiled model to use instead of compiling ``scene.model``.

    Raises:
        SceneError: the scene does not fit the model (see :func:`check_scene`).

    Attributes:
        robot: the one robot state of the scene's chains.
        model, data: its model and its ``MjData``, where the solvers work and the frames
            are written.
        chains: one chain per effector, all on ``robot``.
    """

    def __init__(self, scene: Scene, model: mujoco.MjModel | None = None):
        self.scene = scene
        if model is None:
            try:
                model = scene_model(scene)
            except HumanoidIKError as exc:
                raise SceneError(scene.source, "model", str(exc)) from None
        self.model = model
        self.chains = check_scene(scene, model)
        self.robot = self.chains[0].robot
        self.data = self.robot.data
        self.forward = True
        """Whether :meth:`step` runs ``mj_forward`` (else ``mj_kinematics``): :meth:`run`
        sets it for its sinks (:func:`needs_forward`)."""
        self.specs: list[SolverSpec] = [scene.solver_for(e) for e in scene.effectors]
        self.targets = [scene.target(e.target) for e in scene.effectors]
        # each target moves once per frame, however many effectors track it (or have it
        # as their elbow's pole)
        effs = scene.effectors
        poles = [e.pole for e in effs if isinstance(e.pole, str)]
        names = list(dict.fromkeys([*(e.target for e in effs), *poles]))
        self._tracks = [scene.target(n) for n in names]
        self._track_of = [names.index(e.target) for e in effs]
        # each effector with an elbow pole: (effector, the index of the pole's track, or
        # the fixed point); empty without poles, and a frame then costs nothing more
        self._poles: list[tuple[int, int | NDArray[np.float64]]] = [
            (i, names.index(e.pole) if isinstance(e.pole, str) else np.array(e.pole, float))
            for i, e in enumerate(effs)
            if e.pole is not None
        ]
        # what every sample of an effector repeats: its name, its target's, its task
        self._labels = [(e.name, e.target, e.task) for e in scene.effectors]
        # each end effector's position and rotation and its chain's base: views of the
        # robot's one MjData, read after each frame's kinematics pass
        self._views = [(c.position, c.rotation, c.base) for c in self.chains]
        # each reaching chain's sampled reach [m], computed once (the robot keeps it)
        self._reach = [
            c.reach()[1] if e.task == "reach" else math.inf
            for c, e in zip(self.chains, scene.effectors, strict=True)
        ]
        # one solver object per distinct spec; effectors sharing a multi-effector solver
        # are solved together
        self._groups: list[tuple[Any, list[int]]] = []
        by_spec: dict[tuple, int] = {}
        for i, spec in enumerate(self.specs):
            key = (spec.name, tuple(sorted((k, repr(v)) for k, v in spec.options.items())))
            solver = None
            if key in by_spec:
                solver = self._groups[by_spec[key]][0]
            if solver is not None and solver.solves_effectors:
                self._groups[by_spec[key]][1].append(i)
                continue
            if solver is None:
                solver = spec.make()
                by_spec[key] = len(self._groups)
            self._groups.append((solver, [i]))
        # the site axis each look_at effector's solver aims, measured with the same axis
        self._gaze_axes: list[NDArray[np.float64]] = [np.zeros(3)] * len(self.chains)
        for solver, members in self._groups:
            for i in members:
                self._gaze_axes[i] = solver.gaze_axis()
        # where each gaze looks: a view of the column of the site's rotation when the axis
        # is one of the frame's (R @ axis without the product; else None: the product)
        self._looks = [
            R[:, a.tolist().index(1.0)] if sorted(a.tolist()) == [0.0, 0.0, 1.0] else None
            for (_p, R, _base), a in zip(self._views, self._gaze_axes, strict=True)
        ]
        self.reset()
        self._prepare_solvers()

    def _prepare_solvers(self) -> None:
        """Each solver builds what it derives from its chains now, so no frame's solve
        time includes it (mink's QP set-up, the Jacobian family's seed library)."""
        for solver, members in self._groups:
            if solver.solves_effectors:
                solver.prepare_effectors(self._goals(members, self._targets_at(0.0)))
            else:
                solver.prepare(self.chains[members[0]])

    def _targets_at(self, t: float) -> list[Target]:
        """Every effector's target at time ``t`` [s], with its elbow's pole."""
        moved = [trk.at(t) for trk in self._tracks]
        targets = [moved[k] for k in self._track_of]
        for i, pole in self._poles:
            tg, at = targets[i], moved[pole].position if isinstance(pole, int) else pole
            targets[i] = Target.from_motion(tg.position, tg.quat, at)
        return targets

    def _goals(self, members: list[int], targets: list[Target]) -> list[EffectorGoal]:
        """The goals of effectors ``members`` (``targets``: every effector's target),
        warm-started from the previous frame."""
        return [
            EffectorGoal(self.chains[i], targets[i], self.q[i], self.scene.effectors[i].task)
            for i in members
        ]

    @property
    def n_frames(self) -> int:
        """Frames of a full run."""
        return self.scene.n_frames

    @property
    def solvers(self) -> list[tuple[Any, tuple[int, ...]]]:
        """Each solver object of the run and the effectors it moves (scene order).
        Effectors of one solver spec share its object; a solver that moves several
        effectors at once gets them in one entry, any other one entry per effector."""
        return [(solver, tuple(members)) for solver, members in self._groups]

    def solver_labels(self) -> list[str]:
        """Each effector's solver, as ``name`` or ``name(options)``."""
        return [s.label() for s in self.specs]

    def recording(self) -> Recording:
        """An empty :class:`~humanoid_ik.run.recording.Recording` of this runner's scene:
        the sink :meth:`run` fills (a frame loop of one's own may fill it too)."""
        return Recording(self.scene, self.solver_labels(), self.model, self.chains, self.targets)

    def reset(self) -> None:
        """Back to the home keyframe (warm starts forgotten)."""
        m, d = self.model, self.data
        self.robot.reset()
        for c in self.chains:
            d.qpos[c.qpos_adr] = c.q_home
        mujoco.mj_forward(m, d)
        self.q = [c.q_home.copy() for c in self.chains]

    def time_of(self, index: int) -> float:
        """Time of frame ``index`` [s]."""
        return index / self.scene.fps

    def step(
        self, index: int, targets: Sequence[Target] | None = None, t: float | None = None
    ) -> FrameSamples:
        """Solve and apply frame ``index`` (warm-started from the previous call).

        Args:
            index: the frame.
            targets: each effector's target (default: the scene's tracks at ``t``).
            t: the frame's time [s] (default: :meth:`time_of` ``index``).
        """
        t = self.time_of(index) if t is None else float(t)
        m, d = self.model, self.data
        if targets is None:
            targets = self._targets_at(t)
        else:
            targets = list(targets)
        results: list[IKResult | None] = [None] * len(self.chains)
        times = [0.0] * len(self.chains)
        for solver, members in self._groups:
            if solver.solves_effectors:  # several effectors at once
                goals = self._goals(members, targets)
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
        qpos, chains = d.qpos, self.chains
        for i, res in enumerate(results):
            assert res is not None
            self.q[i] = res.q
            qpos[chains[i].qpos_adr] = res.q
        (mujoco.mj_forward if self.forward else mujoco.mj_kinematics)(m, d)
        samples = map(self._measure, range(len(results)), targets, results, times)  # type: ignore[arg-type]
        return FrameSamples(index, t, tuple(samples))

    def _measure(self, i: int, target: Target, res: IKResult, dt: float) -> EffectorSample:
        """Effector ``i``'s sample of this frame. Its errors are its result's, measured once
        by MuJoCo FK at the pose it returns, which is the pose the frame shows (a gaze's
        by the gaze measure, :func:`~humanoid_ik.core.measures.gaze_error`)."""
        name, target_name, task = self._labels[i]
        p, R, base = self._views[i]
        pd = target.position
        orient: float | None
        if task == "look_at":
            err, orient = float(res.position_error), float(res.orientation_error)  # type: ignore[arg-type]
            v = pd - p
            # the gaze point: on the gaze axis, as far from the site as the target
            # (sqrt(v . v) is np.linalg.norm(v) without its checks and its numpy scalar)
            look = self._looks[i]
            achieved = p + math.sqrt(v.dot(v)) * (R @ self._gaze_axes[i] if look is None else look)
            on = on_target(err)
            reachable = bool(res.converged)
        else:
            achieved = p.copy()
            err = res.position_error
            orient = None if target.quat is None else res.orientation_error
            on = on_target(err, orient)
            reachable = math.dist(pd.tolist(), base.tolist()) <= self._reach[i]
        return EffectorSample(
            name,
            target_name,
            task,
            pd,  # read-only: a Target's position
            achieved,
            err,
            orient,
            int(res.iterations),
            dt,
            self.chains[i].limit_margin(res.q),
            reachable,
            bool(on),
            res.status,
        )

    def run(
        self,
        frames: int | None = None,
        on_frame: Callable[[FrameSamples], None] | None = None,
        sinks: Sequence[FrameSink] = (),
    ) -> Recording:
        """Run ``frames`` frames (default: the whole scene) from the home pose: the frame
        loop.

        Per frame: :meth:`step`, then every sink in order gets the frame's samples and
        ``self.data``, then the returned recording (also a sink) and the frame's loop
        time, then ``on_frame``.

        Args:
            frames: how many frames.
            on_frame: called after each frame (with ``self.data`` at that frame).
            sinks: the outputs that take each frame (e.g. the renderer).

        Returns:
            The recording of every frame run, with ``frame_times``: the wall time [s] of each
            frame's step and sinks. Ctrl-C (``KeyboardInterrupt``) stops the run early: the
            frames so far are returned with ``interrupted`` set. Any other exception
            propagates (the sinks are left to their owner to abort).
        """
        n = self.n_frames if frames is None else frames
        self.reset()
        recording = self.recording()
        self.forward = needs_forward(sinks)
        try:
            recording.frame_times, recording.interrupted = frame_loop(
                n, self.step, self.data, (*sinks, recording), on_frame
            )
        finally:
            self.forward = True
        return recording


def run_scene(scene: Scene | str | os.PathLike, frames: int | None = None) -> Recording:
    """Run a scene (a :class:`Scene`, a scene file or a bundled scene's name) without
    rendering and return its recording."""
    from humanoid_ik.config.scene import load_scene

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    return SceneRunner(sc).run(frames)
