"""Filming a scene: :func:`render_scene` runs it through :meth:`SceneRunner.run
<humanoid_ik.run.runner.SceneRunner.run>`, the one frame loop, with a :class:`Film`
beside the metrics and the trajectory recorder as frame sinks (drawing each frame into
the video, the stills and the GIF), then writes every output of the ``render`` command
atomically. :func:`replay_trajectory` films a recorded trajectory the same way, its
frames read by a :class:`~humanoid_ik.run.replay.TrajectoryPlayer` instead of solved.

A model filmed in the default stage (``outputs/stage.py``) is solved first and filmed
after: the stage's cameras frame the whole run (every frame's pose, targets and
effectors), which is known once it has run, so the run's trajectory is then played to
the film (:func:`~humanoid_ik.outputs.stage.trajectory_stage`)."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import mujoco

from humanoid_ik.config.scene import Scene
from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.models import needs_stage
from humanoid_ik.core.mujoco_warnings import mujoco_warnings
from humanoid_ik.core.names import check_name
from humanoid_ik.errors import MotionError, RenderError, TrajectoryFileError
from humanoid_ik.outputs.atomic import check_not_theirs, staged_outputs
from humanoid_ik.outputs.render.backend import Backend, select_backend
from humanoid_ik.outputs.render.drawing import (
    Film,
    FrameRenderer,
    Quats,
    marker_radius,
    track_quats,
)
from humanoid_ik.outputs.render.plots import plot_metrics
from humanoid_ik.outputs.render.stills import GifFrames, Stills, sheet_indices, snapshot_plan
from humanoid_ik.outputs.render.video import VideoWriter
from humanoid_ik.outputs.run_files import (
    RUN_FILES,
    check_output_dir,
    progress_reporter,
    relocated,
    scene_output_dir,
    write_metrics,
)
from humanoid_ik.outputs.stage import trajectory_chains, trajectory_stage
from humanoid_ik.outputs.trajectory import write_trajectory
from humanoid_ik.run.recording import Recording
from humanoid_ik.run.replay import TrajectoryPlayer
from humanoid_ik.run.runner import FrameSink, SceneRunner
from humanoid_ik.run.trajectory import Trajectory

__all__ = [
    "FilmOutputs",
    "RenderOutputs",
    "Renderer",
    "check_buffer",
    "check_output_dir",
    "film_trajectory",
    "render_scene",
    "replay_trajectory",
]


@dataclass(frozen=True, kw_only=True)
class FilmOutputs:
    """What filming a run wrote (a replay's outputs; a render adds its own).

    Attributes:
        folder: the output folder.
        frames: frames rendered.
        interrupted: Ctrl-C stopped the run early (the outputs hold the frames so far).
        video, gif, contact_sheet: the files (``None`` when not written).
        snapshots: the PNG frames.
        backend: the OpenGL backend.
        frame_times: wall time of each frame in the frame loop [s] (solve or read,
            draw, render, hand-off to the encoder, the other sinks).
        notes: one line each about what was not rendered as asked (a snapshot time
            after the last frame, snapshot times on the same frame).
    """

    folder: Path
    frames: int
    interrupted: bool
    video: Path | None
    gif: Path | None
    snapshots: tuple[Path, ...]
    contact_sheet: Path | None
    backend: Backend
    frame_times: tuple[float, ...] = field(repr=False)
    notes: tuple[str, ...] = ()

    def files(self) -> list[Path]:
        """Every file written."""
        out = [self.video, self.gif, *self.snapshots, self.contact_sheet]
        return [p for p in out if p is not None]


@dataclass(frozen=True, kw_only=True)
class RenderOutputs(FilmOutputs):
    """What a render wrote: :class:`FilmOutputs` and the run's files.

    Attributes:
        csv, json, plot: the metrics files (``plot`` is ``None`` when not written).
        trajectory: ``trajectory.npz`` and ``trajectory.csv`` (empty when not recorded).
        total_time: wall time of the whole render including set-up and writing [s].
        metrics: the run's metrics.
    """

    csv: Path
    json: Path
    plot: Path | None
    total_time: float
    metrics: Recording = field(repr=False, compare=False)
    trajectory: tuple[Path, ...] = ()

    def files(self) -> list[Path]:
        """Every file written."""
        out = [*super().files(), self.csv, self.json, self.plot, *self.trajectory]
        return [p for p in out if p is not None]


@dataclass
class _Filmed:
    """What filming a run left: the video, the stills, the GIF, and any notes."""

    video: Path | None
    snapshots: tuple[Path, ...]
    sheet: Path | None
    gif: Path | None
    notes: tuple[str, ...]


Renderer = Callable[[mujoco.MjModel, int, int, str, int, float], FrameRenderer]
"""What makes a film's frame renderer: ``FrameRenderer`` or a subclass (``(model,
width, height, camera, trail, marker)``; ``functools.partial`` binds more)."""


def _film(
    model: mujoco.MjModel,
    rs: RenderSpec,
    fps: float,
    n: int,
    folder: Path,
    name: str,
    video: bool,
    quats: Quats,
    run: Callable[[FrameSink], object],
    marker: float,
    renderer: Renderer = FrameRenderer,
) -> tuple[_Filmed, Backend]:
    """Film ``n`` frames at ``fps``: ``run(film)`` runs the frame loop with the film as a
    sink; then the video is finished and the stills and the GIF written. ``marker``:
    the target markers' radius [m] (:func:`marker_radius`); ``renderer`` makes the frame
    renderer (a subclass draws more in each frame).

    A failed run leaves no video under its final name (its temporary file is removed)
    and the exception propagates; Ctrl-C (handled by the frame loop) keeps the frames so
    far and a valid, shorter video.
    """
    snaps, notes = snapshot_plan(rs.snapshots, fps, n)
    stills = Stills(snaps, sheet_indices(rs.contact_sheet, n))
    gif = GifFrames(fps) if rs.gif else None
    trail = round(rs.trail * fps)
    with renderer(model, rs.width, rs.height, rs.camera, trail, marker) as fr:
        backend = select_backend()
        mp4 = _named(folder, name, ".mp4")
        writer = VideoWriter(mp4, rs.width, rs.height, fps) if video else None
        images = [sink for sink in (writer, stills, gif) if sink is not None]
        try:
            run(Film(fr, quats, images))
        except BaseException:  # a failed run leaves no video under the final name
            if writer is not None:
                writer.close(abort=True)
            raise
        video_path = None if writer is None else writer.close()
    snapshots, sheet_path = stills.write(folder)
    gif_path = None if gif is None else gif.write(_named(folder, name, ".gif"))
    return _Filmed(video_path, snapshots, sheet_path, gif_path, tuple(notes)), backend


def _named(folder: Path, name: str, suffix: str) -> Path:
    """``folder/<name><suffix>``, a file named after a scene: ``name`` is a
    :data:`~humanoid_ik.core.names.NAME` (no separator, no ``..``), so the file is in
    ``folder`` (the callers check the name first, with their own error)."""
    path = folder / (check_name("scene", name) + suffix)
    if path.parent != folder:  # cannot happen for a NAME; the rule is what keeps it so
        raise MotionError("scene", "a name that stays inside the output folder", name)
    return path


@mujoco_warnings()
def render_scene(
    scene: Scene,
    out_dir: str | os.PathLike | None = None,
    *,
    video: bool = True,
    plot: bool = True,
    trajectory: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> RenderOutputs:
    """Run a scene and film it.

    Writes into ``out_dir`` (default ``renders/<scene name>``): ``<name>.mp4``,
    ``<name>.gif`` (when ``scene.render.gif``), ``frame_NNNN.png`` snapshots,
    ``contact_sheet.png``, ``metrics.csv``, ``metrics.json``, ``metrics.png``,
    ``trajectory.npz`` and ``trajectory.csv``. The files are written into a staging
    folder and replace the previous run's in ``out_dir`` as one set when all are
    complete (``outputs/atomic.py``: :func:`staged_outputs`); a failed run leaves the
    previous ones untouched. Ctrl-C (or SIGTERM) stops the run early and the outputs
    are written for the frames rendered so far (``interrupted`` is then set).

    A model without its own stage is solved first and filmed after, in the default
    stage framing the whole run (:func:`~humanoid_ik.outputs.stage.trajectory_stage`):
    ``progress`` then counts the frames filmed; Ctrl-C while solving films the frames
    solved, and while filming keeps the metrics of every frame solved.

    Args:
        scene: the scene (apply command-line choices with :meth:`Scene.with_overrides`).
        out_dir: the output folder.
        video: write the MP4.
        plot: write the metrics plot.
        trajectory: record and write the trajectory (a sink of the same loop).
        progress: called with ``(frames done, frames total)`` after each frame.

    Raises:
        SceneError: the scene's name is not a :data:`~humanoid_ik.core.names.NAME` (it
            names the folder and the files), or the scene does not fit its model.
        RenderError: the folder cannot be written, the camera does not exist, or no
            OpenGL backend works.
    """
    t_start = time.perf_counter()
    folder = scene_output_dir(scene, out_dir)
    known = [  # the files this render writes whatever its length (the stills depend on it)
        *RUN_FILES,
        *([f"{scene.name}.mp4"] if video else []),
        *([f"{scene.name}.gif"] if scene.render.gif else []),
        *(["contact_sheet.png"] if scene.render.contact_sheet > 0 else []),
        *(["metrics.png"] if plot else []),
    ]
    check_not_theirs(folder, known)
    runner = SceneRunner(scene)
    n, rs = runner.n_frames, scene.render
    reaching = [c for c, e in zip(runner.chains, scene.effectors, strict=True) if e.task == "reach"]
    marker = marker_radius(reaching)

    with staged_outputs(folder) as stage:
        recorded: Trajectory | None = None
        if needs_stage(runner.model):  # solved first, then filmed in a stage framing the run
            metrics = runner.run()  # the progress shown is the film's, the longer part
            recorded = metrics.trajectory()
            aspect = rs.width / rs.height
            film_model = trajectory_stage(
                scene.model, recorded, aspect, runner.model, packages=scene.packages
            )
            player = TrajectoryPlayer(recorded, film_model)
            report = progress_reporter(progress, len(metrics))
            loops: list[tuple[list[float], bool]] = []
            filmed, backend = _film(
                film_model,
                rs,
                scene.fps,
                len(metrics),
                stage,
                scene.name,
                video,
                lambda frame: recorded.quats(frame.index),
                lambda film: loops.append(player.run([film], report)),
                marker,
            )
            film_times, cut = loops[0]
            frame_times = [a + b for a, b in zip(metrics.frame_times, film_times, strict=False)]
        else:
            done: list[Recording] = []
            filmed, backend = _film(
                runner.model,
                rs,
                scene.fps,
                n,
                stage,
                scene.name,
                video,
                track_quats(runner.targets),
                lambda film: done.append(
                    runner.run(on_frame=progress_reporter(progress, n), sinks=[film])
                ),
                marker,
            )
            metrics, cut = done[0], False
            frame_times = list(metrics.frame_times)
        if not frame_times:  # stopped before its first frame: the previous set stays
            raise KeyboardInterrupt
        csv_path, json_path = write_metrics(metrics, stage)
        plot_path = plot_metrics(metrics, stage / "metrics.png") if plot and len(metrics) else None
        traj_files: tuple[Path, ...] = ()
        if trajectory:
            traj_files = write_trajectory(recorded or metrics.trajectory(), stage)
        result = RenderOutputs(
            folder=stage,
            frames=len(frame_times),
            interrupted=metrics.interrupted or cut,
            video=filmed.video,
            gif=filmed.gif,
            snapshots=filmed.snapshots,
            contact_sheet=filmed.sheet,
            csv=csv_path,
            json=json_path,
            plot=plot_path,
            backend=backend,
            frame_times=tuple(frame_times),
            total_time=0.0,
            metrics=metrics,
            trajectory=traj_files,
            notes=filmed.notes,
        )
    return dataclasses.replace(
        relocated(result, stage, folder), total_time=time.perf_counter() - t_start
    )


@mujoco_warnings()
def replay_trajectory(
    trajectory: Trajectory,
    model: mujoco.MjModel,
    out_dir: str | os.PathLike,
    *,
    digest: str | None,
    render: RenderSpec | None = None,
    video: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> FilmOutputs:
    """Film a trajectory without solving: the same video, PNG snapshots, contact sheet
    (and GIF) as the render that recorded it, published into ``out_dir`` as one set
    (:func:`~humanoid_ik.outputs.atomic.staged_outputs`).

    Args:
        trajectory: what to play.
        model: the model it was recorded on.
        out_dir: the output folder.
        digest: the model file's digest, checked against the trajectory's (``None``:
            only the joints are checked).
        render: how to film it (default: as the trajectory's scene was filmed).
        video: write the MP4.
        progress: called with ``(frames done, frames total)`` after each frame.

    Raises:
        TrajectoryFileError: the trajectory's scene name is not a
            :data:`~humanoid_ik.core.names.NAME` (it names the video), or the
            trajectory does not fit the model.
        RenderError: the folder cannot be written, the camera does not exist, the frame
            is larger than the model's off-screen buffer, or no OpenGL backend works.
    """
    try:
        check_name("scene", trajectory.scene)
    except MotionError as exc:
        raise TrajectoryFileError(f"trajectory {exc}") from None
    player = TrajectoryPlayer(trajectory, model, digest)
    rs = trajectory.render if render is None else render
    check_buffer(model, rs)
    folder = check_output_dir(out_dir)
    with staged_outputs(folder) as stage:
        result = film_trajectory(
            trajectory, model, stage, render=rs, video=video, progress=progress, player=player
        )
    return relocated(result, stage, folder)


def check_buffer(model: mujoco.MjModel, rs: RenderSpec) -> None:
    """Refuse a frame larger than ``model``'s off-screen buffer.

    Raises:
        RenderError: naming both sizes and the model's setting.
    """
    buffer = (int(model.vis.global_.offwidth), int(model.vis.global_.offheight))
    if rs.width > buffer[0] or rs.height > buffer[1]:
        raise RenderError(
            f"frame {rs.width}x{rs.height} is larger than the model's off-screen buffer "
            f"{buffer[0]}x{buffer[1]} (visual/global offwidth, offheight)"
        )


@mujoco_warnings()
def film_trajectory(
    trajectory: Trajectory,
    model: mujoco.MjModel,
    folder: str | os.PathLike,
    *,
    render: RenderSpec | None = None,
    name: str | None = None,
    video: bool = True,
    progress: Callable[[int, int], None] | None = None,
    renderer: Renderer = FrameRenderer,
    player: TrajectoryPlayer | None = None,
) -> FilmOutputs:
    """Film a trajectory into ``folder`` (which must exist; a caller's staging folder:
    nothing is published here): ``<name>.mp4``, ``frame_NNNN.png`` snapshots,
    ``contact_sheet.png`` and ``<name>.gif`` with ``render.gif``.

    Args:
        trajectory, model: what to play, on the model it fits (a staged copy is fine).
        folder: where the files go.
        render: size, camera, snapshots, contact sheet (default: the trajectory's).
        name: the video's name (default: the trajectory's scene).
        video: write the MP4.
        progress: called with ``(frames done, frames total)`` after each frame.
        renderer: makes the frame renderer (:data:`Renderer`).
        player: the trajectory's player on ``model``, if the caller has made it.

    Raises:
        KeyboardInterrupt: stopped before its first frame (nothing to keep).
    """
    player = TrajectoryPlayer(trajectory, model) if player is None else player
    rs = trajectory.render if render is None else render
    check_buffer(model, rs)
    n = player.n_frames
    done: list[tuple[list[float], bool]] = []

    def run(film: FrameSink) -> None:
        done.append(player.run([film], on_frame=progress_reporter(progress, n)))

    folder = Path(folder)
    filmed, backend = _film(
        model,
        rs,
        trajectory.fps,
        n,
        folder,
        trajectory.scene if name is None else name,
        video,
        lambda frame: trajectory.quats(frame.index),
        run,
        marker_radius(trajectory_chains(model, trajectory, task="reach")),
        renderer,
    )
    times, interrupted = done[0]
    if not times:  # stopped before its first frame: the previous set stays
        raise KeyboardInterrupt
    return FilmOutputs(
        folder=folder,
        frames=len(times),
        interrupted=interrupted,
        video=filmed.video,
        gif=filmed.gif,
        snapshots=filmed.snapshots,
        contact_sheet=filmed.sheet,
        backend=backend,
        frame_times=tuple(times),
        notes=filmed.notes,
    )
