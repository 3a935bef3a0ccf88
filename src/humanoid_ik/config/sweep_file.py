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
    site = "right_palm_site"           # optional (or body = "tool_link", or a limb found
                                       # from the model: limb = "left_arm", torso = true);
                                       # also model (an MJCF or URDF path, relative) and
                                       # joints

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
import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import mujoco

from humanoid_ik.config.placement import effector_chain
from humanoid_ik.config.scene import Scene, find_scene, frames_limit, load_scene
from humanoid_ik.config.specs import MAX_JOBS, EffectorSpec
from humanoid_ik.config.toml import display_path, integer_problem, read_toml
from humanoid_ik.core.chain import DEFAULT_SITE, Chain
from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.model_files import model_digest, model_files
from humanoid_ik.core.models import bundled_dir, bundled_model_path, bundled_override, load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.errors import HumanoidIKError, MotionError, SweepError, show_value
from humanoid_ik.motion import RandomWalk

__all__ = [
    "KINDS",
    "MAX_JOBS",
    "Job",
    "Sweep",
    "find_sweep",
    "load_sweep",
    "model_digest",
    "model_files",
    "parse_sweep",
    "reseeded",
    "scene_digest",
    "target_set_chain",
]

KINDS = ("scene", "targets")
"""What a job solves: a scene run, or a seeded target set."""


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
            written in the sweep file) and ``model_sha256``, and ``body``, ``limb`` and
            ``torso`` when given.
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
    fail: Callable[[str, str], SweepError],
    entries: list[Any],
    base: Path,
    packages: Mapping[str, Path],
) -> list[dict[str, Any]]:
    """One set per ``[[scenes]]`` entry, its scene loaded and checked now (``packages``
    over the scene file's own ``package_path``)."""
    out = []
    for i, entry in enumerate(entries):
        key = f"scenes[{i}]"
        rel = base / entry.scene
        try:
            path = find_scene(rel if rel.is_file() else entry.scene)
            scene = load_scene(path, packages=packages)
        except HumanoidIKError as exc:
            raise fail(f"{key}.scene", str(exc)) from None
        frames = entry.frames
        what = None if frames is None else integer_problem(frames, 1, frames_limit(scene))
        if what is not None:
            raise fail(f"{key}.frames", f"expected {what}, got {show_value(frames)}")
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
    fail: Callable[[str, str], SweepError],
    entries: list[Any],
    base: Path,
    packages: Mapping[str, Path],
) -> list[dict[str, Any]]:
    """One set per ``[[targets]]`` entry, its chain built once to check it (the model
    loaded with ``packages``)."""
    out = []
    for i, t in enumerate(entries):
        key = f"targets[{i}]"
        site = DEFAULT_SITE if t.site is None and t.body is None and t.limb is None else t.site
        location = bundled_model_path() if t.model is None else (base / t.model).resolve()
        try:
            target_set_chain(
                load_model(location, packages=packages),
                location,
                {
                    "site": site,
                    "body": t.body,
                    "joints": t.joints,
                    "limb": t.limb,
                    "torso": t.torso,
                },
            )
        except MotionError as exc:
            what = f"expected {exc.expected}, got {show_value(exc.got)}"
            raise fail(f"{key}.{exc.field}", what) from None
        except HumanoidIKError as exc:
            kind = getattr(exc, "kind", "")
            sub = {"site": "site", "body": "body", "joint": "joints"}.get(
                kind, "model" if t.model else ""
            )
            raise fail(f"{key}.{sub}" if sub else key, str(exc)) from None
        out.append(
            {
                "kind": "targets",
                "name": t.name,
                "params": {
                    "task": t.task,
                    "n": t.n,
                    "site": site,
                    "joints": t.joints,
                    "model": t.model,
                    "model_sha256": model_digest(location, packages=packages),
                    # only when given, so the ids of site target sets stay as they were
                    **({} if t.body is None else {"body": t.body}),
                    **({} if t.limb is None else {"limb": t.limb}),
                    **({"torso": True} if t.torso else {}),
                },
                "location": str(location),
                "seeded": True,
            }
        )
    return out


def target_set_chain(
    model: mujoco.MjModel, location: str | os.PathLike, param: Mapping[str, Any]
) -> Chain:
    """The chain of a target set on ``model`` (its file ``location``) from its ``site``,
    ``body``, ``joints``, ``limb`` and ``torso`` (a job's :attr:`Job.param`), built by
    :func:`~humanoid_ik.config.placement.effector_chain` (a limb from the model's
    profile, ``<model>.limbs.toml`` beside it when there is one).

    Raises:
        MotionError: a limb the model lacks (field ``limb``).
        HumanoidIKError: a site, body or joint the model lacks.
    """
    joints = param.get("joints")
    spec = EffectorSpec(
        param.get("site"),
        "targets",
        joints=None if joints is None else tuple(joints),
        body=param.get("body"),
        limb=param.get("limb"),
        torso=bool(param.get("torso", False)),
    )
    profile = profile_for(model, location) if spec.kind == "limb" else None
    return effector_chain(Robot(model), spec, profile)


def parse_sweep(doc: Mapping[str, Any], source: str, base: Path | None = None) -> Sweep:
    """A :class:`Sweep` from a parsed TOML document, validated by the typed model of
    ``config/sweep_schema.py``; the scenes and models it names are loaded and checked.

    Args:
        doc: the document.
        source: how messages name the file.
        base: folder that relative scene and model paths start from (default: cwd).

    Raises:
        SweepError: any bad value, naming the key and what was expected.
    """
    from humanoid_ik.config.schema import validate
    from humanoid_ik.config.sweep_schema import SweepFile

    base = Path(".") if base is None else base
    doc = {"name": Path(source).stem or "sweep", **doc}
    f = validate(SweepFile, doc, source, SweepError, base=base)

    def fail(key: str, message: str) -> SweepError:
        return SweepError(source, key, message.replace("\r", "\\r").replace("\n", "\\n"))

    packages = f.package_path
    seeds, configs = f.seeds, f.configs
    sets = _scene_sets(fail, f.scenes, base, packages) + _target_sets(
        fail, f.targets, base, packages
    )
    count = sum(len(configs) * (len(seeds) if s["seeded"] else 1) for s in sets)
    if count > MAX_JOBS:
        raise fail(
            "", f"expected at most {MAX_JOBS} jobs (sets x configurations x seeds), got {count}"
        )
    jobs: list[Job] = []
    for s in sets:
        for spec in configs:
            for seed in seeds if s["seeded"] else [None]:
                params = dict(s["params"])
                if s["kind"] == "scene" and seed is not None:
                    params["random_walk_seed"] = seed
                job = Job(
                    s["kind"],
                    s["name"],
                    spec.name,
                    _frozen(dict(spec.options)),
                    seed,
                    _frozen(params),
                    location=s["location"],
                    packages=tuple((k, str(v)) for k, v in packages.items()),
                )
                jobs.append(job)
    seen: dict[str, int] = {}
    for k, job in enumerate(jobs):
        if job.id in seen:
            raise fail(
                "", f"job {job.describe()} appears twice (a scene, target set or solver repeated)"
            )
        seen[job.id] = k
    return Sweep(f.name, tuple(jobs), f.description, source)


def load_sweep(path: str | os.PathLike) -> Sweep:
    """Read and validate a sweep file and expand its grid into jobs.

    Raises:
        SweepError: the file is missing or not TOML, or any value is wrong; the message
            names the file, the key and what was expected.
    """
    p = find_sweep(path)
    source = display_path(p)
    return parse_sweep(read_toml(p, source, SweepError), source, p.parent)


def find_sweep(name_or_path: str | os.PathLike) -> Path:
    """A sweep file from a path, or from the name of a bundled sweep (``compare_solvers``,
    in ``sweeps/``; ``HUMANOID_IK_SWEEPS`` overrides the folder).

    Raises:
        SweepError: a bare name that is neither a file nor a bundled sweep (the bundled
            names are listed). A missing path is left to the reader's error.
    """
    p = Path(name_or_path)
    if p.is_file() or p.suffix or p.parent != Path("."):
        return p
    folder = bundled_dir("sweeps")
    candidate = folder / f"{p.name}.toml"
    if candidate.is_file():
        return candidate
    found = sorted(folder.glob("*.toml")) if folder.is_dir() else []
    names = ", ".join(f.stem for f in found) or "(none)"
    raise SweepError(
        str(name_or_path),
        "",
        f"no such sweep file; expected a path or a bundled sweep: {names}"
        + bundled_override("sweeps"),
    )
