"""Running one sweep job: a scene job through the runner
(:func:`~humanoid_ik.run.runner.run_scene`), a target-set job through the benchmark loop
(:func:`~humanoid_ik.experiments.bench.run_trials`), each into one result (a dict with
the keys :data:`COLUMNS`: what ``out/jobs/<id>.json`` holds).

This module is what the executors' workers import (it is the local pool's forkserver
preload), so it imports what a job needs and nothing for writing summaries.
"""

from __future__ import annotations

import math
import os
import time
import traceback
from collections.abc import Sequence
from typing import Any

import numpy as np

from humanoid_ik.config.scene import SolverSpec, load_scene
from humanoid_ik.config.sweep_file import Job, reseeded, scene_digest, target_set_chain
from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.models import load_model
from humanoid_ik.errors import SweepError, renamed
from humanoid_ik.experiments.bench import make_targets, not_reaching, run_trials
from humanoid_ik.run.runner import run_scene
from humanoid_ik.solvers import make_solver

__all__ = ["COLUMNS", "TIMING_COLUMNS", "failed_result", "new_result", "run_job"]

COLUMNS = (
    "id",
    "kind",
    "name",
    "solver",
    "config",
    "options",
    "seed",
    "status",
    "error",
    "samples",
    "success_rate",
    "max_error_m",
    "median_error_m",
    "max_orientation_error_rad",
    "median_solve_ms",
    "wall_s",
)
"""Columns of a job's result and of the summary CSV, in order."""
TIMING_COLUMNS = ("median_solve_ms", "wall_s")
"""Wall-clock columns: the only ones that differ between two runs of the same sweep."""


def _finite(values: Sequence[float | None]) -> np.ndarray:
    """The finite values (``None``, NaN and inf dropped) as a float array ``(k,)``."""
    return np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)


def _nan_max(values: Sequence[float | None]) -> float | None:
    """The largest finite value, or ``None`` when there is none."""
    arr = _finite(values)
    return float(arr.max()) if arr.size else None


def _nan_median(values: Sequence[float | None]) -> float | None:
    """The median of the finite values, or ``None`` when there is none."""
    arr = _finite(values)
    return float(np.median(arr)) if arr.size else None


def _check_model(job: Job, model: str | os.PathLike, packages: Any = None) -> None:
    """The model's files are those the job's id was made from (when it names them).

    Raises:
        SweepError: a model file changed after the sweep was loaded.
    """
    want = job.param.get("model_sha256")
    if want is not None and model_digest(model, packages=packages) != want:
        raise SweepError(
            str(model),
            "",
            "the model or a file it includes changed after the sweep was loaded; load it again",
        )


def _run_targets(job: Job) -> dict[str, Any]:
    """A target-set job: the seeded targets solved by the benchmark loop from home.

    Raises:
        SweepError: the job has no seed (a target set is always drawn from one), or the
            model changed after the sweep was loaded.
    """
    if job.seed is None:
        raise SweepError(None, "seed", f"target-set job {job.describe()} needs a seed")
    _check_model(job, job.location, job.package_dict)
    p = job.param
    model = load_model(job.location, packages=job.package_dict)
    chain = target_set_chain(model, job.location, p)
    pose = p["task"] == "pose"
    solver = make_solver(job.solver, **job.options_dict)
    reason = not_reaching(solver, chain, pose)
    if reason is not None:
        return {"status": "skipped", "error": reason}
    targets = make_targets(chain, p["n"], job.seed, pose)
    tr = run_trials(chain, solver, targets)
    return {
        "status": "ok",
        "samples": len(targets),
        "success_rate": float(tr.success.mean()),
        "max_error_m": _nan_max(tr.position_errors.tolist()),
        "median_error_m": _nan_median(tr.position_errors.tolist()),
        "max_orientation_error_rad": _nan_max(tr.orientation_errors.tolist()) if pose else None,
        "median_solve_ms": float(np.median(tr.times) * 1e3),
    }


def _run_scene(job: Job) -> dict[str, Any]:
    """A scene job: the scene file and its model (unchanged since the sweep was loaded)
    run with the job's solver and seed; errors and success over the frames whose target
    is in reach.

    Raises:
        SweepError: the scene file or its model changed after the sweep was loaded.
    """
    p = job.param
    scene = load_scene(job.location, packages=job.package_dict)
    if scene_digest(job.location) != p["scene_sha256"]:
        raise SweepError(
            job.location, "", "the scene file changed after the sweep was loaded; load it again"
        )
    _check_model(job, scene.model, scene.packages)
    scene = scene.with_overrides(solver=SolverSpec(job.solver, job.options_dict))
    if job.seed is not None:
        scene = reseeded(scene, job.seed)
    rows = run_scene(scene, p["frames"]).rows()
    reach = [r for r in rows if r["reachable"]]
    return {
        "status": "ok",
        "samples": len(rows),
        "success_rate": (sum(bool(r["on_target"]) for r in reach) / len(reach)) if reach else None,
        "max_error_m": _nan_max([r["position_error_m"] for r in reach]),
        "median_error_m": _nan_median([r["position_error_m"] for r in reach]),
        "max_orientation_error_rad": _nan_max([r["orientation_error_rad"] for r in reach]),
        "median_solve_ms": _nan_median([1e3 * r["solve_time_s"] for r in rows]),
    }


def new_result(job: Job) -> dict[str, Any]:
    """A job result (keys :data:`COLUMNS`) holding the job's parameters, the measured
    columns empty."""
    result: dict[str, Any] = dict.fromkeys(COLUMNS)
    result.update(
        id=job.id,
        kind=job.kind,
        name=job.name,
        solver=job.solver,
        config=job.config,
        options=job.options_dict,
        seed=job.seed,
    )
    return result


def run_job(job: Job) -> dict[str, Any]:
    """Run one job and return its result (keys :data:`COLUMNS`). Never raises: an
    exception becomes ``status = "failed"`` with ``error = "Type: message"`` and the
    traceback under ``traceback``."""
    result = new_result(job)
    t0 = time.perf_counter()
    try:
        result.update(_run_scene(job) if job.kind == "scene" else _run_targets(job))
    except Exception as exc:  # noqa: BLE001 - a failed job is data, not a crash
        result.update(status="failed", error=f"{type(exc).__name__}: {exc}")
        result["traceback"] = traceback.format_exc()
    result["wall_s"] = time.perf_counter() - t0
    return result


def failed_result(job: Job, exc: BaseException) -> dict[str, Any]:
    """The result of a job whose worker died (the exception came from the executor)."""
    result = new_result(job)
    result.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    return result


_RENAMED = {"failed_record": "failed_result", "new_record": "new_result"}
"""Former names (a job's result was its "record"): old -> new, for one release."""

__getattr__ = renamed(__name__, _RENAMED, globals())
