"""A folder of clips retargeted: one output folder per clip (its :func:`~.pipeline.clip_name`),
resumable, a summary table; one clip after the other, or on the sweep's executors (the
local pool, ``--workers N``, or Ray, ``--ray ADDRESS``: ``experiments/sweep/executors.py``,
whose workers die with the calling process).

A clip is skipped when its folder holds a complete set of its files made with the same
settings (:func:`done`): that is decided here, before anything is sent to a worker. A
clip that fails is a row with its one-line error, and the others run.
"""

from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from humanoid_ik.errors import HumanoidIKError, RetargetError
from humanoid_ik.experiments.retarget.pipeline import (
    CLIP_FILES,
    FILM_FILES,
    clip_name,
    clip_settings,
    retarget,
)
from humanoid_ik.experiments.retarget.targets import REACH
from humanoid_ik.outputs.atomic import published, write_text

__all__ = ["SUMMARY_FIELDS", "ClipJob", "done", "failed_clip", "retarget_folder", "run_clip"]

SUMMARY_FIELDS = (
    "clip",
    "status",
    "frames",
    "left_median_mm",
    "left_p99_mm",
    "right_median_mm",
    "right_p99_mm",
    "elbow_median_deg",
    "gaze_median_deg",
    "frames_out_of_range",
    "frames_over_speed_limit",
    "collision_frames",
    "qp_fallback_frames",
    "frames_per_s_cpu",
    "error",
)
"""The columns of a folder's ``summary.csv``."""
_OPTIONS = ("solver", "frames", "mapping", "limbs", "packages", "reach", "plot", "film")
""":func:`~.pipeline.retarget`'s keyword arguments a folder run passes on."""
PRELOAD = ("humanoid_ik.experiments.retarget.folder",)
"""What the local pool's forkserver imports once (the pipeline, MuJoCo, the solvers)."""


def done(folder: Path, settings: dict[str, Any]) -> bool:
    """Whether ``folder`` holds a complete set of a clip's outputs made with ``settings``
    (:data:`~.pipeline.CLIP_FILES` but the plot; with a film, :data:`~.pipeline.FILM_FILES`
    and the snapshots ``metrics.json`` lists)."""
    names = set(published(folder))
    need = {n for n in CLIP_FILES if n != "metrics.png"}
    if "film" in settings:
        need |= set(FILM_FILES)
    if not need <= names:
        return False
    try:
        doc = json.loads((folder / "metrics.json").read_text())
    except (OSError, ValueError):
        return False
    if "film" in settings and not set(doc.get("film", {}).get("files", [None])) <= names:
        return False
    return bool(doc.get("settings") == settings) and all((folder / n).is_file() for n in names)


def _row(clip: str, status: str, doc: dict[str, Any] | None, error: str = "") -> dict[str, Any]:
    row: dict[str, Any] = {"clip": clip, "status": status, "error": error}
    if doc is None:
        return row
    s = doc["summary"]
    row["frames"] = s["frames"]
    elbows = []
    for side in ("left", "right"):
        if side in s:
            pe = s[side]["position_error_reachable_m"]
            row[f"{side}_median_mm"] = None if pe["median"] is None else pe["median"] * 1e3
            row[f"{side}_p99_mm"] = None if pe["p99"] is None else pe["p99"] * 1e3
            if s[side]["elbow_error_deg"]["median"] is not None:
                elbows.append(s[side]["elbow_error_deg"]["median"])
    row["elbow_median_deg"] = max(elbows) if elbows else None
    row["gaze_median_deg"] = s.get("gaze_error_deg", {}).get("median")
    for k in (
        "frames_out_of_range",
        "frames_over_speed_limit",
        "collision_frames",
        "qp_fallback_frames",
        "frames_per_s_cpu",
    ):
        row[k] = s[k]
    return row


@dataclass(frozen=True)
class ClipJob:
    """One clip of a folder run, as a worker gets it (picklable)."""

    clip: Path
    dest: Path
    model: str | os.PathLike[str] | None
    options: dict[str, Any] = field(default_factory=dict)


def run_clip(job: ClipJob) -> dict[str, Any]:
    """Retarget one clip into its folder; its summary row (``failed`` with the one-line
    error of a :class:`~humanoid_ik.errors.HumanoidIKError`)."""
    try:
        res = retarget(job.clip, job.model, job.dest, **job.options)
    except HumanoidIKError as exc:
        return _row(job.clip.name, "failed", None, str(exc))
    return _row(job.clip.name, "ok", res.doc)


def failed_clip(job: ClipJob, exc: BaseException) -> dict[str, Any]:
    """The row of a clip whose worker died."""
    return _row(job.clip.name, "failed", None, f"{type(exc).__name__}: {exc}")


def retarget_folder(
    folder: str | os.PathLike[str],
    model: str | os.PathLike[str] | None,
    out_dir: str | os.PathLike[str],
    *,
    progress: Any = None,
    workers: int | None = None,
    ray: str | None = None,
    **options: Any,
) -> tuple[list[dict[str, Any]], Path]:
    """Retarget every ``.bvh`` of ``folder`` into ``out_dir/<clip name>/``
    (:func:`~.pipeline.clip_name`), skipping a clip whose outputs are complete and were
    made with the same settings; writes ``out_dir/summary.csv`` (rows sorted by file
    name, whatever order the clips end in).

    Without ``workers`` and ``ray`` the clips run one after the other in this process
    (a short clip is a few seconds: less than a pool's start-up); with ``workers`` N
    they run on N local processes, with ``ray`` on Ray at that address (``local``: a
    private instance of ``workers`` CPUs), as a sweep's jobs do.

    Args:
        progress: called as ``progress(clip, status)`` as each clip ends.
        workers: local processes (1 to ``MAX_WORKERS``).
        ray: a Ray address (``local``, ``auto``, ``HOST:PORT``).
        options: :func:`~.pipeline.retarget`'s keyword arguments.

    Returns:
        The summary rows and the summary file.

    Raises:
        RetargetError: ``folder`` holds no ``.bvh`` file, two clips' names make the
            same output folder, ``workers`` is out of bounds or an option unknown
            (nothing is run then).
        SweepError: Ray is not installed, cannot start or cannot be joined.
    """
    from humanoid_ik.experiments.sweep.executors import MAX_WORKERS

    src, out = Path(folder), Path(out_dir)
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise RetargetError(f"option '{unknown[0]}' unknown; options: {', '.join(_OPTIONS)}")
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise RetargetError(f"workers must be an integer from 1 to {MAX_WORKERS}, got {workers}")
    clips = sorted(p for p in src.iterdir() if p.suffix.lower() == ".bvh" and p.is_file())
    if not clips:
        raise RetargetError(f"folder '{src}' holds no .bvh file")
    names: dict[str, Path] = {}
    for clip in clips:
        other = names.setdefault(clip_name(clip), clip)
        if other is not clip:
            raise RetargetError(
                f"clips '{other.name}' and '{clip.name}' both make the output folder "
                f"'{clip_name(clip)}'; rename one"
            )
    out.mkdir(parents=True, exist_ok=True)
    rows: dict[str, dict[str, Any]] = {}
    todo: list[ClipJob] = []

    def finish(row: dict[str, Any]) -> None:
        rows[row["clip"]] = row
        if progress is not None:
            progress(row["clip"], row["status"])

    for clip in clips:
        dest = out / clip_name(clip)
        try:
            settings = clip_settings(
                clip,
                model,
                options.get("solver", "auto"),
                options.get("frames"),
                options.get("mapping"),
                options.get("limbs"),
                options.get("packages"),
                options.get("reach", REACH),
                options.get("film"),
            )
        except HumanoidIKError as exc:
            finish(_row(clip.name, "failed", None, str(exc)))
            continue
        if done(dest, settings):
            finish(
                _row(clip.name, "skipped (done)", json.loads((dest / "metrics.json").read_text()))
            )
        else:
            todo.append(ClipJob(clip, dest, model, dict(options)))
    if ray is not None:
        from humanoid_ik.experiments.sweep.executors import run_ray

        run_ray(todo, workers, ray, lambda j, r: finish(r), run=run_clip, failed=failed_clip)
    elif workers is not None and workers > 1 and len(todo) > 1:
        from humanoid_ik.experiments.sweep.executors import run_local
        from humanoid_ik.experiments.sweep.resume import WORKER_LOG

        run_local(
            todo,
            min(workers, len(todo)),
            lambda j, r: finish(r),
            out / WORKER_LOG,
            run=run_clip,
            failed=failed_clip,
            preload=PRELOAD,
        )
    else:
        for job in todo:
            finish(run_clip(job))
    ordered = [rows[c.name] for c in clips]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS, lineterminator="\n")
    w.writeheader()
    for row in ordered:
        w.writerow({k: "" if row.get(k) is None else row.get(k) for k in SUMMARY_FIELDS})
    path = write_text(out / "summary.csv", buf.getvalue())
    return ordered, path
