"""Running a whole sweep, resumably: each finished job's result is a file
``out/jobs/<id>.json``, so a rerun runs only the jobs without a finished result (new
ones, failed ones, ones whose file was deleted or damaged), then writes the summary of
all. A result file that is not a whole result of its job (cut short, edited, another
job's) counts as missing: :func:`damaged_results` says which and why.

``read_records``, ``damaged_records`` and :attr:`SweepResult.records` are the former
names of :func:`read_results`, :func:`damaged_results` and :attr:`SweepResult.results`,
kept as deprecated aliases for one release.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from humanoid_ik.config.sweep_file import Job, Sweep
from humanoid_ik.errors import SweepError, renamed
from humanoid_ik.experiments.sweep.executors import MAX_WORKERS, import_ray, run_local, run_ray
from humanoid_ik.experiments.sweep.jobs import COLUMNS
from humanoid_ik.experiments.sweep.summary import plot_summary, status_counts, write_summary
from humanoid_ik.outputs.atomic import write_json

__all__ = [
    "WORKER_LOG",
    "SweepResult",
    "check_out",
    "damaged_results",
    "read_results",
    "run_sweep",
]

_RESULTS = "jobs"
"""The folder under ``out`` of the job results."""
WORKER_LOG = "workers.log"
"""The file under ``out`` that receives what the local pool's processes print."""
SWEEP_FILES = ("summary.csv", "summary.json", "summary.png", "run.json", WORKER_LOG)
"""The files a sweep writes in ``out`` beside ``jobs/``: never over a user's own."""


@dataclass(frozen=True)
class SweepResult:
    """What a sweep run did.

    Attributes:
        results: every job's result (keys :data:`~humanoid_ik.experiments.sweep.jobs.COLUMNS`),
            in grid order.
        executed: ids of the jobs run this time.
        cached: ids of the jobs whose result was already there.
        files: the summary CSV, the summary JSON, the plot (if any) and ``run.json``.
        wall_s: the run's wall time [s].
    """

    results: list[dict[str, Any]]
    executed: list[str]
    cached: list[str]
    files: list[Path]
    wall_s: float

    def counts(self) -> dict[str, int]:
        """Jobs by status (``ok``, ``failed``, ``skipped``, each present even at 0)."""
        return {"ok": 0, "failed": 0, "skipped": 0} | status_counts(self.results)

    @property
    def records(self) -> list[dict[str, Any]]:
        """Deprecated (one release): :attr:`results`, by its former name."""
        warnings.warn(
            "SweepResult.records is deprecated; use SweepResult.results",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.results


def _result_path(out: Path, job: Job) -> Path:
    """Where ``job``'s result is kept under ``out``."""
    return out / _RESULTS / f"{job.id}.json"


_NUMBERS = COLUMNS[COLUMNS.index("success_rate") :]
"""Columns holding a number or ``null``: the measured ones, from ``success_rate`` on."""


def _problem(result: Any, job: Job) -> str | None:
    """Why ``result`` is not a whole result of ``job`` (``None`` when it is one)."""
    if not isinstance(result, dict):
        return "not a JSON object"
    missing = [k for k in COLUMNS if k not in result]
    if missing:
        more = ", ..." if len(missing) > 3 else ""
        return f"no {', '.join(missing[:3])}{more}"
    if result["status"] not in ("ok", "skipped", "failed"):
        return f"status {result['status']!r}"
    mine: dict[str, Any] = {"id": job.id, "kind": job.kind, "name": job.name}
    mine |= {"solver": job.solver, "config": job.config, "options": job.options_dict}
    mine["seed"] = job.seed
    mine = json.loads(json.dumps(mine))  # as the result file holds them (tuples as lists)
    wrong = [k for k, v in mine.items() if result[k] != v]
    if wrong:
        return f"{wrong[0]} {result[wrong[0]]!r} is not the job's"
    for k in _NUMBERS:
        v = result[k]
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float))):
            return f"{k} {v!r} is not a number"
    if result["samples"] is not None and (
        isinstance(result["samples"], bool) or not isinstance(result["samples"], int)
    ):
        return f"samples {result['samples']!r} is not an integer"
    return None


def _scan(out: Path, jobs: Sequence[Job]) -> tuple[dict[str, dict[str, Any]], dict[Path, str]]:
    """The whole results under ``out`` of the given jobs by id, and the result files that
    are there but damaged, with the reason."""
    found: dict[str, dict[str, Any]] = {}
    damaged: dict[Path, str] = {}
    for job in jobs:
        path = _result_path(out, job)
        try:
            text = path.read_text()
        except FileNotFoundError:
            continue
        except (OSError, UnicodeDecodeError) as exc:
            damaged[path] = f"cannot be read: {exc}"
            continue
        try:
            result = json.loads(text)
        except ValueError:
            damaged[path] = "not JSON"
            continue
        why = _problem(result, job)
        if why is None:
            found[job.id] = result
        else:
            damaged[path] = why
    return found, damaged


def read_results(out: str | os.PathLike, jobs: Sequence[Job]) -> dict[str, dict[str, Any]]:
    """The finished results under ``out`` of the given jobs, by id (``ok`` and ``skipped``;
    a failed job, and one whose result is damaged, is run again)."""
    found, _ = _scan(Path(out), jobs)
    return {k: r for k, r in found.items() if r["status"] in ("ok", "skipped")}


def damaged_results(out: str | os.PathLike, jobs: Sequence[Job]) -> dict[Path, str]:
    """The result files under ``out`` of the given jobs that are not whole results of
    their job (unreadable, not JSON, a column missing or of the wrong type, another
    job's), each with the reason; :func:`run_sweep` runs those jobs again."""
    _, damaged = _scan(Path(out), jobs)
    return damaged


def check_out(out: str | os.PathLike) -> None:
    """Fail unless a sweep can write ``out``: the nearest of ``out`` and the folders above
    it that exists is a writable folder, and so is ``out/jobs`` if it exists; a folder no
    sweep ran in (no ``jobs/``) holds none of :data:`SWEEP_FILES`. Checked before a sweep
    announces or runs anything; nothing is created.

    Raises:
        SweepError: naming ``out`` and the folder that cannot be written.
    """
    out = Path(out)
    base = next((p for p in (out, *out.parents) if p.exists()), Path("."))

    def what(folder: Path) -> str:
        return "it" if folder == out else f"folder '{folder}'"

    if not base.is_dir():
        raise SweepError(None, "", f"cannot write '{out}': {what(base)} is not a folder")
    for folder in (base, out / _RESULTS):
        if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
            raise SweepError(None, "", f"cannot write '{out}': {what(folder)} is not writable")
    if not (out / _RESULTS).is_dir():  # no sweep ran here: a file of its names is the user's
        for theirs in (out / name for name in SWEEP_FILES):
            if os.path.lexists(theirs):
                why = "not written over a file that no earlier sweep wrote here"
                advice = "remove it or choose another output folder"
                raise SweepError(None, "", f"{why} ({advice}): {theirs}")


def _make_out(out: Path) -> None:
    """Create ``out/jobs`` (after :func:`check_out`).

    Raises:
        SweepError: it cannot be created.
    """
    check_out(out)
    try:
        (out / _RESULTS).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError(None, "", f"cannot write '{out}': {exc.strerror or exc}") from None


def run_sweep(
    sweep: Sweep,
    out: str | os.PathLike,
    *,
    workers: int | None = None,
    ray_address: str | None = None,
    progress: Callable[[int, int, dict[str, Any]], None] | None = None,
    plot: bool = True,
) -> SweepResult:
    """Run every job of a sweep that has no finished result under ``out`` yet, then write
    the summary.

    Each finished job's result goes to ``out/jobs/<id>.json`` (atomically, written by
    this process as results come back, so a Ray cluster needs no shared file system).
    A failed job is recorded with its error and does not stop the others; it runs again
    on the next call.

    Args:
        sweep: the sweep (:func:`~humanoid_ik.config.sweep_file.load_sweep`).
        out: output folder (created).
        workers: local processes (default ``os.cpu_count()``), or Ray CPUs for a local
            Ray instance.
        ray_address: run on Ray: ``"local"`` starts a local instance, anything else is
            passed to ``ray.init(address=...)`` (e.g. ``"auto"``, ``"ray://host:10001"``).
            A Ray already initialised in this process is used as it is.
        progress: called ``(done, total, result)`` after each job run now.
        plot: also write ``summary.png``.

    Returns:
        The :class:`SweepResult`.

    Raises:
        SweepError: ``workers`` not from 1 to :data:`MAX_WORKERS`, Ray missing, Ray not
            answering at ``ray_address``, or ``out`` not writable.
    """
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        raise SweepError(
            None, "", f"workers must be an integer >= 1 and <= {MAX_WORKERS}, got {workers}"
        )
    out = Path(out)
    _make_out(out)
    if ray_address is not None:
        import_ray(ray_address)
    t0 = time.perf_counter()
    results = read_results(out, sweep.jobs)
    cached = [j.id for j in sweep.jobs if j.id in results]
    todo = [j for j in sweep.jobs if j.id not in results]
    executed: list[str] = []

    def on_done(job: Job, result: dict[str, Any]) -> None:
        write_json(_result_path(out, job), result)
        results[job.id] = result
        executed.append(job.id)
        if progress is not None:
            progress(len(executed), len(todo), result)

    if todo:
        if ray_address is None:
            run_local(
                todo, min(workers or os.cpu_count() or 1, len(todo)), on_done, out / WORKER_LOG
            )
        else:
            run_ray(todo, workers, ray_address, on_done)
    wall = time.perf_counter() - t0
    ordered = [results[j.id] for j in sweep.jobs]
    files = write_summary(sweep, ordered, out)
    if plot:
        files.append(plot_summary(ordered, out / "summary.png", sweep.name))
    run_doc = {
        "sweep": sweep.name,
        "executor": "local" if ray_address is None else f"ray {ray_address}",
        "workers": workers or os.cpu_count(),
        "executed": len(executed),
        "cached": len(cached),
        "wall_s": wall,
    }
    files.append(write_json(out / "run.json", run_doc))
    return SweepResult(ordered, executed, cached, files, wall)


_RENAMED = {"damaged_records": "damaged_results", "read_records": "read_results"}
"""Former names (a job's result was its "record"): old -> new, for one release."""

__getattr__ = renamed(__name__, _RENAMED, globals())
