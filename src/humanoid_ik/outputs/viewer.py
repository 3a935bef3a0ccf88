"""The live viewer: MuJoCo's interactive viewer (``mujoco.viewer.launch_passive``) on a
scene, the targets as mocap bodies the user can drag, the scene's solver tracking them.

Per frame (the one frame loop, :func:`~humanoid_ik.run.runner.frame_loop`, paced to
the scene's frame rate): every target not dragged by the user moves along its motion
(unless paused: space bar), its mocap body follows; a dragged target stays where the
user put it (Backspace hands every target back to its motion); the solvers solve for
the mocap bodies' positions from the previous frame's joints, the viewer shows the
result, and the overlay shows each effector's solver, error and solve time. When the
window closes (or ``duration`` is up) the trajectory of the frames shown is written
before the viewer is shut down, so no data depends on a clean shutdown.

Start-up is signal-safe: the display is tried first (GLFW, in this thread), so a bad
``DISPLAY`` is one line, not MuJoCo's exit from C; SIGINT and SIGTERM are held back
while the window is being made (:func:`~humanoid_ik.outputs.atomic.signals_held`: a
signal there used to leave the window's thread running into the interpreter's exit, a
segfault or an X error) and handled once it is up; the window is closed, and its thread
joined, in every path; the trajectory is published as one set
(:func:`~humanoid_ik.outputs.atomic.staged_outputs`).
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.scene_check import check_scene
from humanoid_ik.config.specs import MAX_FRAMES, Scene, duration_problem
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import Target
from humanoid_ik.errors import RenderError, show_value
from humanoid_ik.outputs.atomic import signals_held, staged_outputs
from humanoid_ik.outputs.render.drawing import marker_radius
from humanoid_ik.outputs.stage import staged_spec
from humanoid_ik.outputs.trajectory import write_trajectory
from humanoid_ik.run.metrics import FrameSamples
from humanoid_ik.run.runner import SceneRunner, frame_loop
from humanoid_ik.run.trajectory import Trajectory

__all__ = [
    "KEY_PAUSE",
    "KEY_RELEASE",
    "LiveTargets",
    "ViewOutputs",
    "check_display",
    "duration_rule",
    "mocap_model",
    "scene_mocap_model",
    "view_scene",
]

KEY_PAUSE = 32
"""GLFW key code of the space bar: pause or resume the targets' motions."""
KEY_RELEASE = 259
"""GLFW key code of Backspace: every dragged target goes back to its motion."""
NO_DISPLAY = (
    "view needs a display ({why}); film the scene headless with 'humanoid-ik render "
    "SCENE' instead, or run the viewer under a virtual X server (xvfb-run -a humanoid-ik "
    "view ...)"
)


def mocap_model(
    path: str | os.PathLike,
    names: list[str],
    points: NDArray[np.float64] | None = None,
    chains: Sequence[Chain] = (),
    packages: Mapping[str, Path] | None = None,
) -> tuple[mujoco.MjModel, list[int]]:
    """The model at ``path`` in the default stage (facing the robot of ``chains`` and
    framed on ``points`` too, as a film's:
    :func:`~humanoid_ik.outputs.stage.staged_spec`) with one mocap body per target (a
    sphere that does not collide, of a film's marker radius for the reaching ``chains``:
    :func:`~humanoid_ik.outputs.render.drawing.marker_radius`), added through
    ``MjSpec``; returns it and each target's mocap index.

    Args:
        path: the model file.
        names: the targets' names.
        points: world points ``(k, 3)`` [m] the cameras also frame (the targets).
        chains: the reaching chains, on the model of ``path``.
        packages: ROS package folders for a URDF's ``package://`` paths.
    """
    compiled = chains[0].model if chains else None
    spec = staged_spec(path, points, compiled, chains=chains, packages=packages)
    radius = marker_radius(chains)
    for name in names:
        body = spec.worldbody.add_body(name=f"target_{name}", mocap=True)
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[radius, 0, 0],
            rgba=[1.0, 0.55, 0.0, 0.7],
            contype=0,
            conaffinity=0,
        )
    model = spec.compile()
    ids = [
        int(model.body_mocapid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"target_{n}")])
        for n in names
    ]
    return model, ids


def scene_mocap_model(scene: Scene) -> tuple[mujoco.MjModel, list[int]]:
    """The viewer's model of ``scene``: :func:`mocap_model` facing the robot of the
    scene's reaching effectors, its markers sized to them as a film's are.

    Raises:
        SceneError: the scene does not fit its model.
    """
    chains = check_scene(scene)  # on the scene's own model
    reaching = [c for c, e in zip(chains, scene.effectors, strict=True) if e.task == "reach"]
    names = [t.name for t in scene.targets]
    return mocap_model(scene.model, names, scene.target_points(), reaching, scene.packages)


class LiveTargets:
    """Where each target is in the viewer: on its motion at the live time, or where the
    user dragged its mocap body.

    Args:
        runner: the scene's runner on the mocap model.
        mocap: each scene target's mocap index (scene target order).
    """

    def __init__(self, runner: SceneRunner, mocap: list[int]):
        self.runner = runner
        self.tracks = list(runner.scene.targets)
        self.mocap = mocap
        self.paused = False
        self.time = 0.0
        self.dragged = [False] * len(mocap)
        self._placed: list[NDArray[np.float64] | None] = [None] * len(mocap)

    def key(self, code: int) -> None:
        """Space pauses or resumes the motions; Backspace releases dragged targets."""
        if code == KEY_PAUSE:
            self.paused = not self.paused
        elif code == KEY_RELEASE:
            self.dragged = [False] * len(self.mocap)

    def update(self, data: mujoco.MjData, dt: float) -> list[Target]:
        """Advance the live time by ``dt`` [s] (unless paused), move every target that is
        not dragged along its motion, and return each effector's target."""
        if not self.paused:
            self.time += dt
        by_name: dict[str, Target] = {}
        for k, (trk, m) in enumerate(zip(self.tracks, self.mocap, strict=True)):
            placed = self._placed[k]
            if placed is not None and not np.array_equal(data.mocap_pos[m], placed):
                self.dragged[k] = True  # the user moved it since the last frame
            target = trk.at(self.time)
            if self.dragged[k]:
                quat = None if target.quat is None else data.mocap_quat[m].copy()
                target = Target(data.mocap_pos[m].copy(), quat)
            else:
                data.mocap_pos[m] = target.position
                if target.quat is not None:
                    data.mocap_quat[m] = target.quat
            self._placed[k] = data.mocap_pos[m].copy()
            by_name[trk.name] = target
        return [by_name[e.target] for e in self.runner.scene.effectors]


@dataclass(frozen=True)
class ViewOutputs:
    """What a viewer session left: the frames shown and the trajectory files."""

    frames: int
    trajectory: tuple[Path, Path] | None
    recorded: Trajectory


def _overlay(frame: FrameSamples, solvers: list[str]) -> tuple[str, str]:
    """The overlay's two columns: per effector its solver, error and solve time."""
    left, right = ["time"], [f"{frame.time:.2f} s"]
    for s, label in zip(frame.samples, solvers, strict=True):
        left.append(s.effector)
        right.append(
            f"{label}  error {s.position_error * 1e3:.2f} mm  solve {s.solve_time * 1e3:.2f} ms"
        )
    return "\n".join(left), "\n".join(right)


def check_display() -> None:
    """Raise a one-line :class:`RenderError` when there is no display to open a window:
    none set, or GLFW (the viewer's window library) cannot initialise on it. Tried here,
    in the calling thread, because the viewer's own thread would stop the process from C
    (exit 1, a ``MUJOCO_LOG.TXT`` left in the current folder).

    Raises:
        RenderError: ``DISPLAY`` (and ``WAYLAND_DISPLAY``) unset on Linux, or no display
            there (``X11: Failed to open display :99``), or no GLFW.
    """
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise RenderError(NO_DISPLAY.format(why="DISPLAY is not set"))
    try:
        # held: importing glfw runs a child Python that reads the library's file name
        # from a pipe; a signal in the middle left it an EOF and a traceback on stderr
        with signals_held():
            import glfw
    except Exception as exc:  # ImportError, or the package's RuntimeError: no library
        raise RenderError(NO_DISPLAY.format(why=" ".join(str(exc).split()))) from None
    reporting, glfw.ERROR_REPORTING = glfw.ERROR_REPORTING, "ignore"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ok = glfw.init()
            _, why = glfw.get_error()
    finally:
        glfw.ERROR_REPORTING = reporting
    if not ok:
        text = why.decode(errors="replace") if isinstance(why, bytes) else "GLFW cannot start"
        raise RenderError(NO_DISPLAY.format(why=" ".join(text.split())))
    glfw.terminate()  # the viewer's thread initialises it again for its window


def duration_rule(duration: float, fps: float) -> str | None:
    """What a session's ``duration`` [s] must be at ``fps`` when it is not a finite
    number > 0 of at most :data:`~humanoid_ik.config.specs.MAX_FRAMES` frames, else
    ``None`` (as a scene's ``duration``: ``docs/limits.md``)."""
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        return "a finite number > 0"
    return duration_problem(min(duration, 2.0 * MAX_FRAMES / fps), fps)  # 1e308 x fps: inf


def view_scene(
    scene: Scene,
    out_dir: str | os.PathLike | None = None,
    *,
    duration: float | None = None,
    on_open: Callable[[], None] | None = None,
) -> ViewOutputs:
    """Open the live viewer on ``scene`` until its window closes (or ``duration`` [s] of
    frames have been shown; at most :data:`~humanoid_ik.config.specs.MAX_FRAMES` frames,
    what a trajectory file holds), then publish ``trajectory.npz``/``.csv`` into
    ``out_dir`` (when given) as one set, in place of the previous run's files there;
    ``on_open`` is called once the window is open.

    The targets' motions advance one frame time ``1 / fps`` per frame shown, paced to
    the wall clock; a display that cannot keep up plays them slower, never skips.
    Ctrl-C (or SIGTERM through the CLI) ends the session like closing the window, and
    the trajectory then says ``interrupted``; one while the window is being made is
    held back until it is up, then the window is closed and ``KeyboardInterrupt``
    raised with nothing written (no frame was shown: the previous set stays); a window
    closed before its first frame writes nothing either.

    Raises:
        RenderError: no display, the viewer's window cannot be opened, or ``duration``
            is not a finite number > 0 of at most ``MAX_FRAMES`` frames.
        SceneError: the scene does not fit its model.
        KeyboardInterrupt: stopped before the first frame was shown.
    """
    if duration is not None and (rule := duration_rule(duration, scene.fps)) is not None:
        raise RenderError(f"view duration: expected {rule}, got {show_value(duration)}")
    check_display()
    import mujoco.viewer

    model, mocap = scene_mocap_model(scene)
    runner = SceneRunner(scene, model)
    live = LiveTargets(runner, mocap)
    recording = runner.recording()
    solvers = runner.solver_labels()
    dt = 1.0 / scene.fps
    n = MAX_FRAMES if duration is None else max(1, round(duration * scene.fps))
    before = set(threading.enumerate())
    viewer = None
    try:
        with signals_held():  # a signal now is raised once the window is up
            try:
                viewer = mujoco.viewer.launch_passive(model, runner.data, key_callback=live.key)
            except Exception as exc:  # glfw raises several types without a display
                raise RenderError(NO_DISPLAY.format(why=" ".join(str(exc).split()))) from exc
        if on_open is not None:
            on_open()
        shown = viewer
        start = time.perf_counter()

        def step(i: int) -> FrameSamples:
            wait = start + i * dt - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            with shown.lock():
                targets = live.update(runner.data, 0.0 if i == 0 else dt)
                return runner.step(i, targets, live.time)

        class Show:
            def add_frame(self, frame: FrameSamples, data: mujoco.MjData) -> None:
                shown.set_texts((None, None, *_overlay(frame, solvers)))
                shown.sync()

        _, interrupted = frame_loop(
            n, step, runner.data, [recording, Show()], stop=lambda: not shown.is_running()
        )
        if interrupted and not len(recording):  # before its first frame: the set stays
            raise KeyboardInterrupt
        recording.interrupted = interrupted
        traj = recording.trajectory()
        files = None if out_dir is None or not len(recording) else _publish(traj, Path(out_dir))
    finally:
        with signals_held():  # the window's thread must not outlive this
            if viewer is not None:
                viewer.close()
            for thread in set(threading.enumerate()) - before:  # the viewer's window thread
                thread.join(timeout=10.0)
    return ViewOutputs(traj.n_frames, files, traj)


def _publish(traj: Trajectory, folder: Path) -> tuple[Path, Path]:
    """Write the trajectory files into ``folder`` as one set (in place of the previous
    run's: ``render``'s video and metrics too)."""
    with staged_outputs(folder) as stage:
        npz, csv = write_trajectory(traj, stage)
    return folder / npz.name, folder / csv.name
