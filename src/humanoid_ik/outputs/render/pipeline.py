"""Filming a scene: :func:`render_scene` runs it through :meth:`SceneRunner.run
<humanoid_ik.run.runner.SceneRunner.run>`, the one frame loop, with a :class:`Film`
beside the metrics as a frame sink (drawing each frame into the video, the stills and
the GIF), then writes every output of the ``render`` command atomically."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from humanoid_ik.config.scene import Scene
from humanoid_ik.errors import RenderError
from humanoid_ik.outputs.atomic import write_json, write_text
from humanoid_ik.outputs.render.backend import Backend, select_backend
from humanoid_ik.outputs.render.drawing import Film, FrameRenderer
from humanoid_ik.outputs.render.plots import plot_metrics
from humanoid_ik.outputs.render.stills import GifFrames, Stills, sheet_indices, snapshot_indices
from humanoid_ik.outputs.render.video import VideoWriter
from humanoid_ik.run.metrics import FrameRecord, Metrics
from humanoid_ik.run.runner import SceneRunner

__all__ = ["RenderOutputs", "check_output_dir", "render_scene"]


@dataclass(frozen=True)
class RenderOutputs:
    """What a render wrote.

    Attributes:
        folder: the output folder.
        frames: frames rendered.
        interrupted: Ctrl-C stopped the run early (the outputs hold the frames so far).
        video, gif, contact_sheet, csv, json, plot: the files (``None`` when not written).
        snapshots: the PNG frames.
        backend: the OpenGL backend.
        frame_times: wall time of each frame in the runner's loop [s] (solve, draw,
            render, hand-off to the encoder, metrics).
        total_time: wall time of the whole render including set-up and writing [s].
        metrics: the run's metrics.
    """

    folder: Path
    frames: int
    interrupted: bool
    video: Path | None
    gif: Path | None
    snapshots: tuple[Path, ...]
    contact_sheet: Path | None
    csv: Path
    json: Path
    plot: Path | None
    backend: Backend
    frame_times: tuple[float, ...] = field(repr=False)
    total_time: float
    metrics: Metrics = field(repr=False, compare=False)

    def files(self) -> list[Path]:
        """Every file written."""
        out = [self.video, self.gif, *self.snapshots, self.contact_sheet, self.csv, self.json]
        out.append(self.plot)
        return [p for p in out if p is not None]


def check_output_dir(folder: str | os.PathLike) -> Path:
    """Create ``folder`` if needed and check a file can be written there.

    Raises:
        RenderError: it cannot be created or written.
    """
    import tempfile

    p = Path(folder)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RenderError(f"cannot create output folder '{p}': {exc.strerror or exc}") from None
    try:
        fd, name = tempfile.mkstemp(prefix=".write-check.", dir=p)
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise RenderError(f"output folder '{p}' is not writable: {exc.strerror or exc}") from None
    return p


def _run_filmed(
    runner: SceneRunner,
    film: Film,
    writer: VideoWriter | None,
    progress: Callable[[int, int], None] | None,
) -> tuple[Metrics, Path | None]:
    """Run the whole scene with ``film`` as a sink, then finish the video.

    Returns:
        The metrics and the video (``None`` when not written). Ctrl-C keeps the frames so
        far and a valid, shorter video; any other exception removes the video's
        temporary file (nothing under the final name) and propagates.
    """
    n = runner.n_frames

    def on_frame(record: FrameRecord) -> None:
        if progress is not None:
            progress(record.index + 1, n)

    try:
        metrics = runner.run(on_frame=on_frame, sinks=[film])
    except BaseException:  # a failed run leaves no video under the final name
        if writer is not None:
            writer.close(abort=True)
        raise
    return metrics, None if writer is None else writer.close()


def render_scene(
    scene: Scene,
    out_dir: str | os.PathLike | None = None,
    *,
    video: bool = True,
    plot: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> RenderOutputs:
    """Run a scene and film it.

    Writes into ``out_dir`` (default ``renders/<scene name>``): ``<name>.mp4``,
    ``<name>.gif`` (when ``scene.render.gif``), ``frame_NNNN.png`` snapshots,
    ``contact_sheet.png``, ``metrics.csv``, ``metrics.json`` and ``metrics.png``. Every
    file is written under a temporary name and renamed when complete. Ctrl-C stops the
    run early and the outputs are written for the frames rendered so far
    (``interrupted`` is then set).

    Args:
        scene: the scene (apply command-line choices with :meth:`Scene.with_overrides`).
        out_dir: the output folder.
        video: write the MP4.
        plot: write the metrics plot.
        progress: called with ``(frames done, frames total)`` after each frame.

    Raises:
        SceneError: the scene does not fit its model.
        RenderError: the folder cannot be written, the camera does not exist, or no
            OpenGL backend works.
    """
    t_start = time.perf_counter()
    folder = check_output_dir(Path("renders") / scene.name if out_dir is None else out_dir)
    runner = SceneRunner(scene)
    n = runner.n_frames
    rs = scene.render
    name = scene.name
    stills = Stills(
        snapshot_indices(rs.snapshots, scene.fps, n), sheet_indices(rs.contact_sheet, n)
    )
    gif = GifFrames(scene.fps) if rs.gif else None
    trail = round(rs.trail * scene.fps)
    with FrameRenderer(runner.model, rs.width, rs.height, rs.camera, trail) as fr:
        backend = select_backend()
        writer = (
            VideoWriter(folder / f"{name}.mp4", rs.width, rs.height, scene.fps) if video else None
        )
        images = [sink for sink in (writer, stills, gif) if sink is not None]
        metrics, video_path = _run_filmed(
            runner, Film(fr, runner.targets, images), writer, progress
        )
    snapshots, sheet_path = stills.write(folder)
    gif_path = None if gif is None else gif.write(folder / f"{name}.gif")
    csv_path = write_text(folder / "metrics.csv", metrics.csv_text())
    json_path = write_json(folder / "metrics.json", metrics.to_dict())
    plot_path = plot_metrics(metrics, folder / "metrics.png") if plot and len(metrics) else None
    return RenderOutputs(
        folder=folder,
        frames=len(metrics),
        interrupted=metrics.interrupted,
        video=video_path,
        gif=gif_path,
        snapshots=snapshots,
        contact_sheet=sheet_path,
        csv=csv_path,
        json=json_path,
        plot=plot_path,
        backend=backend,
        frame_times=tuple(metrics.frame_times),
        total_time=time.perf_counter() - t_start,
        metrics=metrics,
    )
