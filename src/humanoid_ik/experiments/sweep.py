"""Sweeps: a grid of scenes or target sets x solvers (with option grids) x seeds, run as
independent jobs on a local process pool or on a Ray cluster.

A sweep is a TOML file (read with ``tomllib``)::

    name = "compare_solvers"           # optional, default: the file name
    description = "..."
    seeds = [0, 1, 2]                  # default [0]

    [[solvers]]                        # or solvers = ["dls", "ccd"]
    name = "dls"
    options = { restarts = 0 }         # fixed options
    grid = { damping = [0.02, 0.1] }   # every combination is its own configuration

    [[scenes]]                         # a scene run for `frames` frames
    scene = "compare_dls"              # a bundled scene or a path relative to this file
    frames = 60                        # optional, default the scene's length

    [[targets]]                        # a seeded target set (FK of random in-range joints)
    name = "right_pose"
    task = "pose"                      # position or pose (default pose)
    n = 200
    site = "right_palm_site"           # optional; also model (relative path) and joints

The grid is ``(scenes + target sets) x solver configurations x seeds``. A seed draws a
target set; for a scene it replaces the seed of every ``random_walk`` motion, and a scene
without one runs once per configuration (its ``seed`` is empty). Every job has a stable
id, a hash of what it computes (for a scene, of the scene file's bytes), so a rerun
finds the results it already has.

Every mistake raises :class:`~humanoid_ik.errors.SweepError` naming the file, the key and
what was expected, e.g. ``sweeps/x.toml: seeds[1]: expected an integer >= 0, got -1``.
"""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from humanoid_ik.config.scene import _Reader as _SceneReader
from humanoid_ik.errors import HumanoidIKError, SweepError, show_value
from humanoid_ik.outputs.atomic import atomic_path, write_json

__all__ = [
    "COLUMNS",
    "TIMING_COLUMNS",
    "Job",
    "Sweep",
    "SweepResult",
    "load_sweep",
    "parse_sweep",
    "run_job",
    "run_sweep",
    "read_records",
    "summary_rows",
    "write_summary",
    "plot_summary",
]

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
"""Columns of a job's record and of the summary CSV, in order."""
TIMING_COLUMNS = ("median_solve_ms", "wall_s")
"""Wall-clock columns: the only ones that differ between two runs of the same sweep."""
KINDS = ("scene", "targets")
_TASKS = ("position", "pose")
_RESULTS = "jobs"


# ----------------------------------------------------------------------------- values
def _frozen(value: Any) -> Any:
    """Lists -> tuples and dicts -> sorted item tuples, recursively (hashable)."""
    if isinstance(value, Mapping):
        return tuple(sorted((str(k), _frozen(v)) for k, v in value.items()))
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def _thawed(items: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in items}


@dataclass(frozen=True)
class Job:
    """One cell of the grid: a scene or a target set, solved by one solver configuration
    with one seed.

    Attributes:
        kind: ``scene`` or ``targets``.
        name: the scene's or the target set's name.
        solver: the solver's name.
        options: the solver's options as sorted ``(key, value)`` pairs.
        seed: the seed (``None`` for a scene without random motion).
        params: what else defines the job, as sorted ``(key, value)`` pairs: for a scene
            ``frames`` and ``scene_sha256`` (of the file), for a target set ``task``,
            ``n``, ``site``, ``joints`` and ``model`` (as written in the sweep file).
        location: the scene file or model to load (resolved); not part of the id.
    """

    kind: str
    name: str
    solver: str
    options: tuple[tuple[str, Any], ...] = ()
    seed: int | None = None
    params: tuple[tuple[str, Any], ...] = ()
    location: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise SweepError(None, "kind", f"expected one of {', '.join(KINDS)}, got {self.kind!r}")
        object.__setattr__(self, "options", _frozen(dict(self.options)))
        object.__setattr__(self, "params", _frozen(dict(self.params)))

    @property
    def id(self) -> str:
        """12 hex digits of the SHA-256 of the job's parameters (not of ``location``)."""
        doc = {
            "kind": self.kind,
            "name": self.name,
            "solver": self.solver,
            "options": self.options,
            "seed": self.seed,
            "params": self.params,
        }
        text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    @property
    def options_dict(self) -> dict[str, Any]:
        """The solver's options as a dict (tuples back to lists)."""
        return _thawed(self.options)

    @property
    def param(self) -> dict[str, Any]:
        """``params`` as a dict."""
        return _thawed(self.params)

    @property
    def config(self) -> str:
        """The solver configuration's label: ``dls`` or ``dls(damping=0.02)``."""
        if not self.options:
            return self.solver
        opts = ", ".join(f"{k}={show_value(v)}" for k, v in self.options)
        return f"{self.solver}({opts})"

    def describe(self) -> str:
        """``kind name config seed`` on one line."""
        seed = "" if self.seed is None else f" seed {self.seed}"
        return f"{self.kind} {self.name} {self.config}{seed}"


@dataclass(frozen=True)
class Sweep:
    """A validated sweep and its jobs (grid order: sets, then configurations, then
    seeds).

    Attributes:
        name: the sweep's name (also the default output folder's).
        jobs: every job of the grid.
        description: one line.
        source: the file it came from (for messages).
    """

    name: str
    jobs: tuple[Job, ...]
    description: str = ""
    source: str = ""


# ----------------------------------------------------------------------------- parsing
_NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-")
_TOP = {
    "name": "a name of letters, digits, '_', '-' or '.'",
    "description": "a string",
    "seeds": "a non-empty list of integers >= 0",
    "solvers": "a non-empty list of solver names or tables [[solvers]] with name",
    "scenes": "a list of tables [[scenes]] with scene",
    "targets": "a list of tables [[targets]] with name and n",
}
_SOLVER = {
    "name": "a solver name",
    "options": "a table of solver options",
    "grid": "a table of option name -> non-empty list of values",
}
_SCENE = {"scene": "a bundled scene's name or a scene file", "frames": "an integer >= 1"}
_TARGETS = {
    "name": "a name of letters, digits, '_', '-' or '.'",
    "task": "one of 'position', 'pose'",
    "n": "an integer >= 1",
    "site": "a site name",
    "model": "an MJCF path (relative to the sweep file)",
    "joints": "a list of joint names",
}


class _Reader(_SceneReader):
    """The scene files' reader, failing with :class:`SweepError`, and the sweep's types."""

    error = SweepError

    def integer(self, key: str, value: Any, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.expect(key, f"an integer >= {low}", value)
        return value

    def name(self, key: str, value: Any) -> str:
        if not isinstance(value, str) or not value or not set(value) <= _NAME_CHARS:
            raise self.expect(key, "a name of letters, digits, '_', '-' or '.'", value)
        return value

    def array(self, key: str, doc: Mapping[str, Any], what: str) -> list:
        value = doc.get(key, [])
        if not isinstance(value, list):
            raise self.expect(key, what, value)
        return value


def _solver_configs(r: _Reader, doc: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    from humanoid_ik.solvers import SOLVERS, make_solver

    entries = r.array("solvers", doc, _TOP["solvers"])
    if not entries:
        raise r.expect("solvers", _TOP["solvers"], doc.get("solvers", []))
    configs: list[tuple[str, dict[str, Any]]] = []
    for i, entry in enumerate(entries):
        key = f"solvers[{i}]"
        if isinstance(entry, str):
            entry = {"name": entry}
        tbl = r.keys(key, entry, _SOLVER, required=("name",))
        name = tbl["name"]
        if not isinstance(name, str) or name not in SOLVERS:
            raise r.expect(f"{key}.name", f"one of {', '.join(SOLVERS)}", name)
        options = tbl.get("options", {})
        if not isinstance(options, dict):
            raise r.expect(f"{key}.options", _SOLVER["options"], options)
        grid = tbl.get("grid", {})
        if not isinstance(grid, dict):
            raise r.expect(f"{key}.grid", _SOLVER["grid"], grid)
        for opt, values in grid.items():
            if not isinstance(values, list) or not values:
                raise r.expect(f"{key}.grid.{opt}", "a non-empty list of values", values)
            if opt in options:
                raise r.fail(f"{key}.grid.{opt}", "also given in options; give it in one place")
        axes = [[(opt, v) for v in values] for opt, values in grid.items()]
        for combo in itertools.product(*axes):
            opts = {**options, **dict(combo)}
            try:
                make_solver(name, **opts)
            except HumanoidIKError as exc:
                bad = next((k for k, _ in combo if f"'{k}'" in str(exc)), None)
                where = f"{key}.grid.{bad}" if bad else f"{key}.options"
                raise r.fail(where, str(exc)) from None
            configs.append((name, opts))
    return configs


def _seeds(r: _Reader, doc: Mapping[str, Any]) -> list[int]:
    seeds = doc.get("seeds", [0])
    if not isinstance(seeds, list) or not seeds:
        raise r.expect("seeds", _TOP["seeds"], seeds)
    out = [r.integer(f"seeds[{i}]", s, 0) for i, s in enumerate(seeds)]
    for i, s in enumerate(out):
        if s in out[:i]:
            raise r.fail(f"seeds[{i}]", f"seed {s} given twice")
    return out


def _has_random_motion(scene) -> bool:
    from humanoid_ik.motion.trajectories import RandomWalk

    return any(isinstance(t.motion, RandomWalk) for t in scene.targets)


def _scene_sets(r: _Reader, doc: Mapping[str, Any], base: Path) -> list[dict[str, Any]]:
    from humanoid_ik.config.scene import find_scene, load_scene

    out = []
    for i, entry in enumerate(r.array("scenes", doc, _TOP["scenes"])):
        key = f"scenes[{i}]"
        if isinstance(entry, str):
            entry = {"scene": entry}
        tbl = r.keys(key, entry, _SCENE, required=("scene",))
        ref = tbl["scene"]
        if not isinstance(ref, str) or not ref:
            raise r.expect(f"{key}.scene", _SCENE["scene"], ref)
        rel = base / ref
        try:
            path = find_scene(rel if rel.is_file() else ref)
            scene = load_scene(path)
        except HumanoidIKError as exc:
            raise r.fail(f"{key}.scene", str(exc)) from None
        frames = tbl.get("frames")
        if frames is not None:
            frames = r.integer(f"{key}.frames", frames, 1)
        sha = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
        out.append(
            {
                "kind": "scene",
                "name": scene.name,
                "params": {"frames": frames or scene.n_frames, "scene_sha256": sha},
                "location": str(path.resolve()),
                "seeded": _has_random_motion(scene),
            }
        )
    return out


def _target_sets(r: _Reader, doc: Mapping[str, Any], base: Path) -> list[dict[str, Any]]:
    from humanoid_ik.core.chain import DEFAULT_SITE, Chain
    from humanoid_ik.core.models import bundled_model_path

    out = []
    for i, entry in enumerate(r.array("targets", doc, _TOP["targets"])):
        key = f"targets[{i}]"
        tbl = r.keys(key, entry, _TARGETS, required=("name", "n"))
        name = r.name(f"{key}.name", tbl["name"])
        n = r.integer(f"{key}.n", tbl["n"], 1)
        task = tbl.get("task", "pose")
        if task not in _TASKS:
            raise r.expect(f"{key}.task", _TARGETS["task"], task)
        site = tbl.get("site", DEFAULT_SITE)
        if not isinstance(site, str) or not site:
            raise r.expect(f"{key}.site", _TARGETS["site"], site)
        model = tbl.get("model")
        if model is not None and (not isinstance(model, str) or not model):
            raise r.expect(f"{key}.model", _TARGETS["model"], model)
        joints = tbl.get("joints")
        if joints is not None and (
            not isinstance(joints, list)
            or not joints
            or not all(isinstance(j, str) and j for j in joints)
        ):
            raise r.expect(f"{key}.joints", _TARGETS["joints"], joints)
        location = bundled_model_path() if model is None else (base / model).resolve()
        try:
            Chain(location, site, joints)
        except HumanoidIKError as exc:
            kind = getattr(exc, "kind", "")
            sub = {"site": "site", "joint": "joints"}.get(kind, "model" if model else "")
            raise r.fail(f"{key}.{sub}" if sub else key, str(exc)) from None
        out.append(
            {
                "kind": "targets",
                "name": name,
                "params": {"task": task, "n": n, "site": site, "joints": joints, "model": model},
                "location": str(location),
                "seeded": True,
            }
        )
    return out


def parse_sweep(doc: Mapping[str, Any], source: str, base: Path | None = None) -> Sweep:
    """A :class:`Sweep` from a parsed TOML document.

    Args:
        doc: the document.
        source: how messages name the file.
        base: folder that relative scene and model paths start from (default: cwd).

    Raises:
        SweepError: any bad value, naming the key and what was expected.
    """
    r = _Reader(source)
    base = Path(".") if base is None else base
    r.keys("", doc, _TOP, required=("solvers",))
    name = r.name("name", doc.get("name", Path(source).stem or "sweep"))
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise r.expect("description", _TOP["description"], description)
    seeds = _seeds(r, doc)
    configs = _solver_configs(r, doc)
    sets = _scene_sets(r, doc, base) + _target_sets(r, doc, base)
    if not sets:
        raise r.fail("scenes", "no scenes and no targets; give [[scenes]] or [[targets]]")
    jobs: list[Job] = []
    for s in sets:
        for solver, opts in configs:
            for seed in seeds if s["seeded"] else [None]:
                params = dict(s["params"])
                if s["kind"] == "scene" and seed is not None:
                    params["random_walk_seed"] = seed
                jobs.append(
                    Job(s["kind"], s["name"], solver, opts, seed, params, location=s["location"])
                )
    seen: dict[str, int] = {}
    for k, job in enumerate(jobs):
        if job.id in seen:
            raise r.fail(
                "", f"job {job.describe()} appears twice (a scene, target set or solver repeated)"
            )
        seen[job.id] = k
    return Sweep(name, tuple(jobs), description, source)


def load_sweep(path: str | os.PathLike) -> Sweep:
    """Read and validate a sweep file and expand its grid into jobs.

    Raises:
        SweepError: the file is missing or not TOML, or any value is wrong; the message
            names the file, the key and what was expected.
    """
    from humanoid_ik.config.scene import display_path, read_toml

    p = Path(path)
    source = display_path(p)
    return parse_sweep(read_toml(p, source, SweepError), source, p.parent)


# ----------------------------------------------------------------------------- one job
def _nan_max(values: Sequence[float]) -> float | None:
    arr = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    return float(arr.max()) if arr.size else None


def _nan_median(values: Sequence[float]) -> float | None:
    arr = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    return float(np.median(arr)) if arr.size else None


def _run_targets(job: Job) -> dict[str, Any]:
    from humanoid_ik.core.chain import Chain
    from humanoid_ik.experiments.bench import make_targets, not_reaching, run_trials
    from humanoid_ik.solvers import make_solver

    p = job.param
    chain = Chain(job.location, p["site"], p["joints"])
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
    from humanoid_ik.config.scene import SolverSpec, load_scene
    from humanoid_ik.motion.trajectories import RandomWalk
    from humanoid_ik.run.runner import run_scene

    p = job.param
    scene = load_scene(job.location)
    sha = hashlib.sha256(Path(job.location).read_bytes()).hexdigest()[:16]
    if sha != p["scene_sha256"]:
        raise SweepError(
            job.location, "", "the scene file changed after the sweep was loaded; load it again"
        )
    scene = scene.with_overrides(solver=SolverSpec(job.solver, job.options_dict))
    if job.seed is not None:
        tracks = tuple(
            replace(t, motion=replace(t.motion, seed=job.seed))
            if isinstance(t.motion, RandomWalk)
            else t
            for t in scene.targets
        )
        scene = replace(scene, targets=tracks)
    metrics = run_scene(scene, p["frames"])
    rows = metrics.rows()
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


def _record(job: Job) -> dict[str, Any]:
    """A record (keys :data:`COLUMNS`) holding the job's parameters, results empty."""
    record: dict[str, Any] = dict.fromkeys(COLUMNS)
    record.update(
        id=job.id,
        kind=job.kind,
        name=job.name,
        solver=job.solver,
        config=job.config,
        options=job.options_dict,
        seed=job.seed,
    )
    return record


def run_job(job: Job) -> dict[str, Any]:
    """Run one job and return its record (keys :data:`COLUMNS`). Never raises: an
    exception becomes ``status = "failed"`` with ``error = "Type: message"`` and the
    traceback under ``traceback``."""
    record = _record(job)
    t0 = time.perf_counter()
    try:
        record.update(_run_scene(job) if job.kind == "scene" else _run_targets(job))
    except Exception as exc:  # noqa: BLE001 - a failed job is data, not a crash
        record.update(status="failed", error=f"{type(exc).__name__}: {exc}")
        record["traceback"] = traceback.format_exc()
    record["wall_s"] = time.perf_counter() - t0
    return record


def _failed(job: Job, exc: BaseException) -> dict[str, Any]:
    """The record of a job whose worker died (the exception came from the executor)."""
    record = _record(job)
    record.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    return record


# ----------------------------------------------------------------------------- executors
def _local(jobs: Sequence[Job], workers: int, on_done: Callable[[Job, dict], None]) -> None:
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(
        ["humanoid_ik.experiments.sweep", "humanoid_ik.run.runner", "humanoid_ik.experiments.bench"]
    )
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        pending = {pool.submit(run_job, job): job for job in jobs}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    job = pending.pop(fut)
                    try:
                        rec = fut.result()
                    except Exception as exc:  # noqa: BLE001 - a dead worker
                        rec = _failed(job, exc)
                    on_done(job, rec)
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise


def import_ray():
    """The ``ray`` module.

    Raises:
        SweepError: Ray is not installed (the message says how to install it).
    """
    try:
        import ray
    except ImportError:
        raise SweepError(
            None, "", "Ray is not installed; install it with pip install 'humanoid-ik[ray]'"
        ) from None
    return ray


def _ray(
    jobs: Sequence[Job], workers: int | None, address: str, on_done: Callable[[Job, dict], None]
) -> None:
    ray = import_ray()
    started = False
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": False,
        }
        if address == "local":
            ray.init(num_cpus=workers or os.cpu_count(), **kwargs)
        else:
            ray.init(address=address, **kwargs)
        started = True
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(run_job)
        pending = {task.remote(job): job for job in jobs}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                job = pending.pop(ref)
                try:
                    rec = ray.get(ref)
                except Exception as exc:  # noqa: BLE001 - a dead worker or node
                    rec = _failed(job, exc)
                on_done(job, rec)
    finally:
        if started:
            ray.shutdown()


# ----------------------------------------------------------------------------- the sweep
@dataclass(frozen=True)
class SweepResult:
    """What a sweep run did.

    Attributes:
        records: every job's record, in grid order.
        executed: ids of the jobs run this time.
        cached: ids of the jobs whose result was already there.
        files: the summary CSV, the summary JSON, the plot (if any) and ``run.json``.
        wall_s: the run's wall time [s].
    """

    records: list[dict[str, Any]]
    executed: list[str]
    cached: list[str]
    files: list[Path]
    wall_s: float

    def counts(self) -> dict[str, int]:
        """Jobs by status (``ok``, ``failed``, ``skipped``)."""
        out = {"ok": 0, "failed": 0, "skipped": 0}
        for r in self.records:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out


def _result_path(out: Path, job: Job) -> Path:
    return out / _RESULTS / f"{job.id}.json"


def _read_record(path: Path) -> dict[str, Any] | None:
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return rec if isinstance(rec, dict) and "status" in rec else None


def read_records(out: str | os.PathLike, jobs: Sequence[Job]) -> dict[str, dict[str, Any]]:
    """The finished records under ``out`` of the given jobs, by id (``ok`` and ``skipped``;
    a failed job is run again)."""
    found = {}
    for job in jobs:
        rec = _read_record(_result_path(Path(out), job))
        if rec is not None and rec["status"] in ("ok", "skipped"):
            found[job.id] = rec
    return found


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

    Each finished job's record goes to ``out/jobs/<id>.json`` (atomically, written by
    this process as results come back, so a Ray cluster needs no shared file system).
    A failed job is recorded with its error and does not stop the others; it runs again
    on the next call.

    Args:
        sweep: the sweep (:func:`load_sweep`).
        out: output folder (created).
        workers: local processes (default ``os.cpu_count()``), or Ray CPUs for a local
            Ray instance.
        ray_address: run on Ray: ``"local"`` starts a local instance, anything else is
            passed to ``ray.init(address=...)`` (e.g. ``"auto"``, ``"ray://host:10001"``).
            A Ray already initialised in this process is used as it is.
        progress: called ``(done, total, record)`` after each job run now.
        plot: also write ``summary.png``.

    Returns:
        The :class:`SweepResult`.

    Raises:
        SweepError: ``workers < 1``, Ray missing, or ``out`` not writable.
    """
    if workers is not None and workers < 1:
        raise SweepError(None, "", f"workers must be >= 1, got {workers}")
    out = Path(out)
    try:
        (out / _RESULTS).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SweepError(None, "", f"cannot write '{out}': {exc.strerror or exc}") from None
    if ray_address is not None:
        import_ray()
    t0 = time.perf_counter()
    records = read_records(out, sweep.jobs)
    cached = [j.id for j in sweep.jobs if j.id in records]
    todo = [j for j in sweep.jobs if j.id not in records]
    executed: list[str] = []

    def on_done(job: Job, rec: dict[str, Any]) -> None:
        write_json(_result_path(out, job), rec)
        records[job.id] = rec
        executed.append(job.id)
        if progress is not None:
            progress(len(executed), len(todo), rec)

    if todo:
        n_workers = workers or os.cpu_count() or 1
        if ray_address is None:
            _local(todo, min(n_workers, len(todo)), on_done)
        else:
            _ray(todo, workers, ray_address, on_done)
    wall = time.perf_counter() - t0
    ordered = [records[j.id] for j in sweep.jobs]
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
    write_json(out / "run.json", run_doc)
    files.append(out / "run.json")
    return SweepResult(ordered, executed, cached, files, wall)


# ----------------------------------------------------------------------------- summary
def summary_rows(records: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The records as summary rows (keys :data:`COLUMNS`), sorted by kind, name,
    configuration and seed, so the order never depends on the executor."""
    rows = [{k: rec.get(k) for k in COLUMNS} for rec in records]
    rows.sort(
        key=lambda r: (
            r["kind"],
            r["name"],
            r["config"],
            -1 if r["seed"] is None else r["seed"],
            r["id"],
        )
    )
    return rows


def _cell(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, dict):
        return json.dumps(value, sort_keys=True)
    if isinstance(value, float):
        return repr(value)
    return value


def write_summary(
    sweep: Sweep, records: Sequence[Mapping[str, Any]], out: str | os.PathLike
) -> list[Path]:
    """Write ``summary.csv`` (one row per job) and ``summary.json`` (the sweep, counts
    by status and the same rows) into ``out`` atomically; returns both paths."""

    out = Path(out)
    rows = summary_rows(records)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _cell(v) for k, v in row.items()})
    with atomic_path(out / "summary.csv") as tmp:
        tmp.write_text(buf.getvalue())
    counts: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    doc = {
        "sweep": sweep.name,
        "description": sweep.description,
        "source": sweep.source,
        "jobs": len(rows),
        "counts": counts,
        "timing_columns": list(TIMING_COLUMNS),
        "rows": rows,
    }
    write_json(out / "summary.json", doc)
    return [out / "summary.csv", out / "summary.json"]


def plot_summary(
    records: Sequence[Mapping[str, Any]], path: str | os.PathLike, title: str = ""
) -> Path:
    """Three panels comparing solver configurations on every scene and target set:
    success rate, median time per solve [ms] and worst error [m] (means over seeds;
    failed and skipped jobs are left out). Written atomically as PNG; returns the path."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    rows = [r for r in summary_rows(records) if r["status"] == "ok"]
    sets = sorted({(r["kind"], r["name"]) for r in rows})
    configs = sorted({r["config"] for r in rows})
    panels = (
        ("success_rate", "success rate", False),
        ("median_solve_ms", "median time per solve [ms]", True),
        ("max_error_m", "worst error [m]", True),
    )
    fig = Figure(figsize=(max(7.0, 1.2 + 0.9 * len(sets) * max(1, len(configs)) / 2), 9.5))
    axes = fig.subplots(3, 1, sharex=True)
    width = 0.8 / max(1, len(configs))
    xs = np.arange(len(sets))
    for ax, (col, label, log) in zip(axes, panels, strict=True):
        for k, cfg in enumerate(configs):
            vals = []
            for s in sets:
                v = [
                    r[col]
                    for r in rows
                    if (r["kind"], r["name"]) == s and r["config"] == cfg and r[col] is not None
                ]
                vals.append(float(np.mean(v)) if v else math.nan)
            arr = np.asarray(vals)
            if log:  # an exact zero would vanish from a log axis
                arr = np.where(np.isfinite(arr) & (arr <= 0), 1e-16, arr)
            ax.bar(xs - 0.4 + (k + 0.5) * width, arr, width, label=cfg)
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
        else:
            ax.set_ylim(0, 1.05)
        ax.grid(axis="y", alpha=0.3)
    axes[-1].set_xticks(xs, [f"{k}: {n}" for k, n in sets], rotation=20, ha="right")
    fig.legend(
        *axes[0].get_legend_handles_labels(),
        fontsize=8,
        ncols=min(3, max(1, len(configs))),
        loc="upper center",
    )
    if title:
        fig.suptitle(title, y=0.995, fontsize=10, x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    return path
