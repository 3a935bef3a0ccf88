"""Sweep files: a grid of scenes or target sets x solvers (with option grids) x seeds,
expanded into independent jobs (:class:`Job`; run by :mod:`humanoid_ik.experiments.sweep`).

A sweep is a TOML file (read with ``tomllib``)::

    name = "compare_solvers"           # optional, default: the file name
    description = "..."
    seeds = [0, 1, 2]                  # default [0]
    # package_path = { my_robot = "../my_robot" }   # ROS packages of a URDF's package://

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
    site = "right_palm_site"           # optional (or body = "tool_link"); also model
                                       # (an MJCF or URDF path, relative) and joints

The grid is ``(scenes + target sets) x solver configurations x seeds``, at most
:data:`MAX_JOBS` jobs. A seed draws a target set; for a scene it replaces the seed of
every ``random_walk`` motion, and a scene without one runs once per configuration (its
``seed`` is empty). Every job has a stable id, a hash of what it computes, including
the SHA-256 of every file it reads (the scene file, and the model file with every file
it includes or loads: :func:`scene_digest`, :func:`model_digest`), so a rerun finds the
results it already has, and an edited scene or model file runs its jobs again.

Every mistake raises :class:`~humanoid_ik.errors.SweepError` naming the file, the key and
what was expected, e.g. ``sweeps/x.toml: seeds[1]: expected an integer >= 0, got -1``.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from humanoid_ik.config.scene import Scene, find_scene, frames_limit, load_scene
from humanoid_ik.config.toml import NAME, TomlReader, display_path, read_toml
from humanoid_ik.core.chain import DEFAULT_SITE, Chain
from humanoid_ik.core.checks import MAX_TARGETS
from humanoid_ik.core.model_files import model_digest, model_files
from humanoid_ik.core.models import bundled_model_path, load_model
from humanoid_ik.core.types import TARGET_KINDS
from humanoid_ik.errors import HumanoidIKError, SweepError, show_value
from humanoid_ik.motion import RandomWalk
from humanoid_ik.solvers import SOLVERS, make_solver

__all__ = [
    "KINDS",
    "MAX_JOBS",
    "Job",
    "Sweep",
    "load_sweep",
    "model_digest",
    "model_files",
    "parse_sweep",
    "reseeded",
    "scene_digest",
]

KINDS = ("scene", "targets")
"""What a job solves: a scene run, or a seeded target set."""
MAX_JOBS = 100_000
"""Most jobs in one sweep (sets x solver configurations x seeds)."""


# ----------------------------------------------------------------------------- values
def _frozen(value: Any) -> Any:
    """Lists -> tuples and dicts -> sorted item tuples, recursively (hashable)."""
    if isinstance(value, Mapping):
        return tuple(sorted((str(k), _frozen(v)) for k, v in value.items()))
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def _thawed(items: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    """Sorted ``(key, value)`` pairs back to a dict, tuple values back to lists."""
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
            ``frames``, ``scene_sha256`` (of the file) and ``model_sha256`` (of its model's
            files), for a target set ``task``, ``n``, ``site``, ``joints``, ``model`` (as
            written in the sweep file) and ``model_sha256``.
        location: the scene file or model to load (resolved); not part of the id.
        packages: the sweep file's ROS package folders as sorted ``(NAME, DIR)`` pairs,
            given to the scene or model it loads (:meth:`package_dict`); not part of the
            id (``model_sha256`` covers the files they lead to).
    """

    kind: str
    name: str
    solver: str
    options: tuple[tuple[str, Any], ...] = ()
    seed: int | None = None
    params: tuple[tuple[str, Any], ...] = ()
    location: str = field(default="", compare=False)
    packages: tuple[tuple[str, str], ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise SweepError(None, "kind", f"expected one of {', '.join(KINDS)}, got {self.kind!r}")
        object.__setattr__(self, "options", _frozen(dict(self.options)))
        object.__setattr__(self, "params", _frozen(dict(self.params)))
        pairs = sorted((str(k), str(v)) for k, v in dict(self.packages).items())
        object.__setattr__(self, "packages", tuple(pairs))

    @property
    def package_dict(self) -> dict[str, Path]:
        """``packages`` as ``{NAME: DIR}``, for ``load_model(..., packages=)``."""
        return {k: Path(v) for k, v in self.packages}

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
_TOP = {
    "name": NAME,
    "description": "a string",
    "seeds": "a non-empty list of integers >= 0",
    "solvers": "a non-empty list of solver names or tables [[solvers]] with name",
    "scenes": "a list of tables [[scenes]] with scene",
    "targets": "a list of tables [[targets]] with name and n",
    "package_path": 'a table of ROS package folders, NAME = "DIR" (relative to the file)',
}
_SOLVER = {
    "name": "a solver name",
    "options": "a table of solver options",
    "grid": "a table of option name -> non-empty list of values",
}
_SCENE = {"scene": "a bundled scene's name or a scene file", "frames": "an integer >= 1"}
_TARGETS = {
    "name": NAME,
    "task": "one of 'position', 'pose'",
    "n": "an integer >= 1",
    "site": "a site name",
    "body": "a body name (instead of site)",
    "model": "an MJCF or URDF path (relative to the sweep file)",
    "joints": "a list of joint names",
}


def _solver_configs(r: TomlReader, doc: Mapping[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """Every solver configuration ``(name, options)``: each option grid expanded, each
    combination tried on the solver's constructor."""
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
        if math.prod(len(a) for a in axes) + len(configs) > MAX_JOBS:
            raise r.fail(
                f"{key}.grid", f"expected at most {MAX_JOBS} configurations (one job each)"
            )
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


def _seeds(r: TomlReader, doc: Mapping[str, Any]) -> list[int]:
    """The seeds: distinct integers >= 0 (default ``[0]``)."""
    seeds = doc.get("seeds", [0])
    if not isinstance(seeds, list) or not seeds:
        raise r.expect("seeds", _TOP["seeds"], seeds)
    out = [r.integer(f"seeds[{i}]", s, 0) for i, s in enumerate(seeds)]
    for i, s in enumerate(out):
        if s in out[:i]:
            raise r.fail(f"seeds[{i}]", f"seed {s} given twice")
    return out


def _has_random_motion(scene: Scene) -> bool:
    """True when a seed changes the scene: it has a ``random_walk`` motion."""
    return any(isinstance(t.motion, RandomWalk) for t in scene.targets)


def reseeded(scene: Scene, seed: int) -> Scene:
    """``scene`` with every ``random_walk`` motion seeded by ``seed`` (what a sweep's seed
    means for a scene)."""
    tracks = tuple(
        replace(t, motion=replace(t.motion, seed=seed)) if isinstance(t.motion, RandomWalk) else t
        for t in scene.targets
    )
    return replace(scene, targets=tracks)


def scene_digest(path: str | os.PathLike) -> str:
    """16 hex digits of the SHA-256 of a scene file's bytes (part of a scene job's id)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def _scene_sets(
    r: TomlReader, doc: Mapping[str, Any], base: Path, packages: Mapping[str, Path]
) -> list[dict[str, Any]]:
    """One set per ``[[scenes]]`` entry, its scene loaded and checked now (``packages``
    over the scene file's own ``package_path``)."""
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
            scene = load_scene(path, packages=packages)
        except HumanoidIKError as exc:
            raise r.fail(f"{key}.scene", str(exc)) from None
        frames = tbl.get("frames")
        if frames is not None:
            frames = r.integer(f"{key}.frames", frames, 1, frames_limit(scene))
        out.append(
            {
                "kind": "scene",
                "name": scene.name,
                "params": {
                    "frames": frames or scene.n_frames,
                    "scene_sha256": scene_digest(path),
                    "model_sha256": model_digest(scene.model, packages=scene.packages),
                },
                "location": str(path.resolve()),
                "seeded": _has_random_motion(scene),
            }
        )
    return out


def _target_sets(
    r: TomlReader, doc: Mapping[str, Any], base: Path, packages: Mapping[str, Path]
) -> list[dict[str, Any]]:
    """One set per ``[[targets]]`` entry, its chain built once to check it (the model
    loaded with ``packages``)."""
    out = []
    for i, entry in enumerate(r.array("targets", doc, _TOP["targets"])):
        key = f"targets[{i}]"
        tbl = r.keys(key, entry, _TARGETS, required=("name", "n"))
        name = r.name(f"{key}.name", tbl["name"])
        n = r.integer(f"{key}.n", tbl["n"], 1, MAX_TARGETS)
        task = tbl.get("task", "pose")
        if task not in TARGET_KINDS:
            raise r.expect(f"{key}.task", _TARGETS["task"], task)
        if "site" in tbl and "body" in tbl:
            raise r.fail(f"{key}.body", "expected a site or a body, not both")
        body = tbl.get("body")
        if body is not None and (not isinstance(body, str) or not body):
            raise r.expect(f"{key}.body", _TARGETS["body"], body)
        site = tbl.get("site", DEFAULT_SITE if body is None else None)
        if body is None and (not isinstance(site, str) or not site):
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
            Chain(load_model(location, packages=packages), site, joints, body=body)
        except HumanoidIKError as exc:
            kind = getattr(exc, "kind", "")
            sub = {"site": "site", "body": "body", "joint": "joints"}.get(
                kind, "model" if model else ""
            )
            raise r.fail(f"{key}.{sub}" if sub else key, str(exc)) from None
        out.append(
            {
                "kind": "targets",
                "name": name,
                "params": {
                    "task": task,
                    "n": n,
                    "site": site,
                    "joints": joints,
                    "model": model,
                    "model_sha256": model_digest(location, packages=packages),
                    # only when given, so the ids of site target sets stay as they were
                    **({} if body is None else {"body": body}),
                },
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
    r = TomlReader(source, SweepError)
    base = Path(".") if base is None else base
    r.keys("", doc, _TOP, required=("solvers",))
    name = r.name("name", doc.get("name", Path(source).stem or "sweep"))
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise r.expect("description", _TOP["description"], description)
    seeds = _seeds(r, doc)
    packages = r.package_paths("package_path", doc.get("package_path", {}), base)
    configs = _solver_configs(r, doc)
    sets = _scene_sets(r, doc, base, packages) + _target_sets(r, doc, base, packages)
    if not sets:
        raise r.fail("scenes", "no scenes and no targets; give [[scenes]] or [[targets]]")
    count = sum(len(configs) * (len(seeds) if s["seeded"] else 1) for s in sets)
    if count > MAX_JOBS:
        raise r.fail(
            "", f"expected at most {MAX_JOBS} jobs (sets x configurations x seeds), got {count}"
        )
    jobs: list[Job] = []
    for s in sets:
        for solver, opts in configs:
            for seed in seeds if s["seeded"] else [None]:
                params = dict(s["params"])
                if s["kind"] == "scene" and seed is not None:
                    params["random_walk_seed"] = seed
                job = Job(
                    s["kind"],
                    s["name"],
                    solver,
                    _frozen(opts),
                    seed,
                    _frozen(params),
                    location=s["location"],
                    packages=tuple((k, str(v)) for k, v in packages.items()),
                )
                jobs.append(job)
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
    p = Path(path)
    source = display_path(p)
    return parse_sweep(read_toml(p, source, SweepError), source, p.parent)
