"""The files of a run (:data:`RUN_FILES`) and a scene run without rendering:
:func:`write_run` runs the scene through :meth:`SceneRunner.run
<humanoid_ik.run.runner.SceneRunner.run>` (the one frame loop, whose recording is a sink),
then writes the metrics and the trajectory atomically; :func:`write_metrics` writes a
run's metrics for ``render`` too. (This module was ``outputs/record.py``, and
:func:`write_run` was ``record_scene``; the old names stay as deprecated aliases for one
release.)"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

from humanoid_ik.config.specs import Scene
from humanoid_ik.core.names import check_name
from humanoid_ik.errors import MotionError, RenderError, SceneError, show_value
from humanoid_ik.outputs.atomic import check_not_theirs, staged_outputs, write_json, write_text
from humanoid_ik.outputs.trajectory import write_trajectory
from humanoid_ik.run.metrics import FrameSamples
from humanoid_ik.run.recording import Recording
from humanoid_ik.run.runner import SceneRunner
from humanoid_ik.run.trajectory import Trajectory

__all__ = [
    "RUN_FILES",
    "RunOutputs",
    "check_output_dir",
    "progress_reporter",
    "relocated",
    "scene_output_dir",
    "write_metrics",
    "write_run",
]

T = TypeVar("T")

RUN_FILES = ("metrics.csv", "metrics.json", "trajectory.npz", "trajectory.csv")
"""What every run writes in its folder (``run``; ``render`` adds its films and stills):
checked against the user's own files before the run starts (:func:`check_not_theirs`)."""


def relocated(outputs: T, staging: Path, folder: Path) -> T:
    """``outputs`` (a frozen dataclass of what a run wrote) with every path into
    ``staging`` pointing into ``folder`` instead, where the files were published."""

    def move(value: object) -> object:
        if isinstance(value, Path) and value.parent == staging:
            return folder / value.name
        if isinstance(value, Path) and value == staging:
            return folder
        if isinstance(value, tuple) and value and all(isinstance(v, Path) for v in value):
            return tuple(move(v) for v in value)
        return value

    assert dataclasses.is_dataclass(outputs) and not isinstance(outputs, type)
    changes = {f.name: move(getattr(outputs, f.name)) for f in dataclasses.fields(outputs)}
    return dataclasses.replace(outputs, **changes)


@dataclass(frozen=True)
class RunOutputs:
    """What a run wrote.

    Attributes:
        folder: the output folder.
        frames: frames run.
        interrupted: Ctrl-C stopped the run early (the files hold the frames so far).
        csv, json: the metrics.
        trajectory: ``trajectory.npz`` and ``trajectory.csv``.
        metrics: the run's metrics.
        recorded: the run's trajectory.
    """

    folder: Path
    frames: int
    interrupted: bool
    csv: Path
    json: Path
    trajectory: tuple[Path, Path]
    metrics: Recording = field(repr=False, compare=False)
    recorded: Trajectory = field(repr=False, compare=False)

    def files(self) -> list[Path]:
        """Every file written."""
        return [self.csv, self.json, *self.trajectory]


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


def scene_output_dir(scene: Scene, out_dir: str | os.PathLike | None) -> Path:
    """``out_dir``, else ``renders/<scene name>``, created and checked writable
    (:func:`check_output_dir`). The scene's name is checked first, wherever the scene
    came from (a file, a script): it names the folder and the video's files, so it must
    be a :data:`~humanoid_ik.core.names.NAME` (``../x`` or ``/x`` would lead out of it).

    Raises:
        SceneError: the name is not a NAME.
        RenderError: the folder cannot be created or written.
    """
    try:
        check_name("name", scene.name)
    except MotionError as exc:
        expected = f"expected {exc.expected}, got {show_value(exc.got)}"
        raise SceneError(scene.source, "name", expected) from None
    return check_output_dir(Path("renders") / scene.name if out_dir is None else out_dir)


def write_metrics(metrics: Recording, folder: Path) -> tuple[Path, Path]:
    """Write ``metrics.csv`` and ``metrics.json`` into ``folder``, each atomically."""
    return (
        write_text(folder / "metrics.csv", metrics.csv_text()),
        write_json(folder / "metrics.json", metrics.to_dict()),
    )


def progress_reporter(
    progress: Callable[[int, int], None] | None, n: int
) -> Callable[[FrameSamples], None] | None:
    """The frame loop's ``on_frame`` that reports ``(frames done, n)`` to ``progress``."""
    if progress is None:
        return None
    report = progress

    def on_frame(frame: FrameSamples) -> None:
        report(frame.index + 1, n)

    return on_frame


def write_run(
    scene: Scene,
    out_dir: str | os.PathLike | None = None,
    *,
    progress: Callable[[int, int], None] | None = None,
) -> RunOutputs:
    """Run a scene without rendering and write ``metrics.csv``, ``metrics.json``,
    ``trajectory.npz`` and ``trajectory.csv`` into ``out_dir`` (default
    ``renders/<scene name>``). Ctrl-C stops the run early; the files are then written for
    the frames done (``interrupted`` is set); stopped before its first frame, it raises
    ``KeyboardInterrupt`` and writes nothing. The files replace the previous run's in
    that folder as one set (``outputs/atomic.py``: :func:`staged_outputs`).

    Raises:
        SceneError: the scene's name is not a :data:`~humanoid_ik.core.names.NAME`, or
            the scene does not fit its model.
        RenderError: the folder cannot be created or written.
    """
    folder = scene_output_dir(scene, out_dir)
    check_not_theirs(folder, RUN_FILES)
    runner = SceneRunner(scene)
    metrics = runner.run(on_frame=progress_reporter(progress, runner.n_frames))
    if not len(metrics):  # stopped before its first frame: the previous set stays
        raise KeyboardInterrupt
    traj = metrics.trajectory()
    with staged_outputs(folder) as stage:
        csv_path, json_path = write_metrics(metrics, stage)
        result = RunOutputs(
            folder=stage,
            frames=len(metrics),
            interrupted=metrics.interrupted,
            csv=csv_path,
            json=json_path,
            trajectory=write_trajectory(traj, stage),
            metrics=metrics,
            recorded=traj,
        )
    return relocated(result, stage, folder)
