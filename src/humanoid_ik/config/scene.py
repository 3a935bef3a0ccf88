"""Scene files: which end effectors track which moving targets, with which solver, and
how the run is filmed.

A scene is a TOML file (read with ``tomllib``)::

    name = "circle"                    # optional, default: the file name
    description = "Right hand traces a circle."
    model = "../models/humanoid/scene.xml"   # optional, relative to the scene file
    # package_path = { my_robot = "../my_robot" }   # ROS packages of a URDF's package://
    duration = 6.0                     # [s]
    fps = 30                           # frames per second

    [solver]                           # the default solver of every effector
    name = "dls"
    options = { restarts = 0 }

    [render]                           # all optional
    width = 640
    height = 480
    camera = "front"
    trail = 1.5                        # [s] of the end effector's path drawn
    gif = false
    snapshots = [0.0, 3.0]             # times [s] saved as PNG
    contact_sheet = 12                 # thumbnails in the contact sheet (0: none)

    [[targets]]
    name = "ball"
    motion = { kind = "circle", center = [0.40, -0.22, 1.22], radius = 0.12 }
    # orientation = { quat = [0.7071, 0, -0.7071, 0] }   # makes it a pose target

    [[effectors]]
    site = "right_palm_site"           # or body = "tool_link" (a URDF link, an MJCF body)
    target = "ball"
    # task = "look_at"                 # aim the site's x axis at the target (gaze)
    # joints = [...]                   # default: the hinges from the site to the root
    # solver = { name = "ccd" }        # this effector's own solver

The values live in :mod:`humanoid_ik.config.specs` (re-exported here), the TOML reader
in :mod:`humanoid_ik.config.toml`. Every mistake raises
:class:`~humanoid_ik.errors.SceneError` with one message naming
the file, the key and what was expected, e.g.
``scenes/x.toml: targets[0].motion.radius: expected a number > 0, got 'big'``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from humanoid_ik.config.scene_check import (
    RENDER_EXPECTED,
    check_collision_pairs,
    check_duration,
    check_scene,
    frame_size_ok,
    scene_model,
    takes_collision_pairs,
)
from humanoid_ik.config.specs import (
    MAX_CONTACT_SHEET,
    MAX_FPS,
    MAX_FRAMES,
    MAX_SNAPSHOTS,
    MAX_TRAIL,
    MIN_FPS,
    TASKS,
    EffectorSpec,
    RenderSpec,
    Scene,
    SolverSpec,
)
from humanoid_ik.config.toml import (
    NAME,
    TomlReader,
    display_path,
    join_key,
    quote_key,
    read_toml,
)
from humanoid_ik.core.checks import check_bool, check_choice, check_int, check_number
from humanoid_ik.core.models import (
    bundled_dir,
    bundled_model_path,
)
from humanoid_ik.core.robot_files import PackagePaths
from humanoid_ik.errors import HumanoidIKError, SceneError
from humanoid_ik.motion import MOTIONS, Motion, Orientation, TargetTrack
from humanoid_ik.solvers import SOLVERS, make_solver
from humanoid_ik.solvers.mink.options import collision_pairs_problem

__all__ = [
    "TASKS",
    "EffectorSpec",
    "RenderSpec",
    "Scene",
    "SolverSpec",
    "bundled_scenes",
    "bundled_scenes_dir",
    "check_collision_pairs",
    "check_scene",
    "display_path",
    "find_scene",
    "frames_limit",
    "load_scene",
    "parse_scene",
    "scene_model",
]


# ----------------------------------------------------------------------------- paths
def bundled_scenes_dir() -> Path:
    """The folder of the bundled scenes (``scenes/``; ``HUMANOID_IK_SCENES`` overrides)."""
    return bundled_dir("scenes")


def bundled_scenes() -> list[Path]:
    """The bundled scene files, sorted by name."""
    folder = bundled_scenes_dir()
    return sorted(folder.glob("*.toml")) if folder.is_dir() else []


def find_scene(name_or_path: str | os.PathLike) -> Path:
    """A scene file from a path, or from the name of a bundled scene (``circle``).

    Raises:
        SceneError: neither a file nor a bundled scene (the bundled names are listed).
    """
    p = Path(name_or_path)
    if p.is_file():
        return p
    if p.suffix == "" and p.parent == Path("."):
        candidate = bundled_scenes_dir() / f"{p.name}.toml"
        if candidate.is_file():
            return candidate
    names = ", ".join(s.stem for s in bundled_scenes()) or "(none)"
    raise SceneError(
        str(name_or_path), "", f"no such scene file; expected a path or a bundled scene: {names}"
    )


# ----------------------------------------------------------------------------- parsing
_TOP = {
    "name": NAME,
    "description": "a string",
    "model": "an MJCF, URDF or xacro path (relative to the scene file)",
    "package_path": 'a table of ROS package folders, NAME = "DIR" (relative to the file)',
    "duration": "a number > 0 (seconds)",
    "fps": f"a number >= {MIN_FPS:g} and <= {MAX_FPS:g} (frames per second)",
    "solver": "a table with name (and options)",
    "render": "a table",
    "targets": "an array of tables [[targets]] with name and motion",
    "effectors": "an array of tables [[effectors]] with site (or body) and target",
}
_SOLVER = {"name": "a solver name", "options": "a table of solver options"}
_TARGET = {
    "name": "a target name",
    "motion": "a table with kind",
    "orientation": "a table with quat",
}
_EFFECTOR = {
    "site": "a site name",
    "body": "a body name",
    "target": "a target name",
    "task": f"one of {', '.join(repr(t) for t in TASKS)}",
    "joints": "a list of joint names",
    "solver": "a table with name (and options)",
}


def _solver_spec(r: TomlReader, key: str, value: Any) -> SolverSpec:
    """A solver table (or a bare name) at ``key``, its options tried on the solver."""
    if isinstance(value, str):
        value = {"name": value}
    tbl = r.table(key, value)
    r.keys(key, tbl, _SOLVER, required=("name",))
    name = tbl["name"]
    if not isinstance(name, str) or name not in SOLVERS:
        raise r.expect(f"{key}.name", f"one of {', '.join(SOLVERS)}", name)
    options = r.table(f"{key}.options", tbl.get("options", {}))
    if "collision_pairs" in options and takes_collision_pairs(name):
        problem = collision_pairs_problem(options["collision_pairs"])
        if problem is not None:
            where, expected, got = problem
            raise r.expect(f"{key}.options.collision_pairs{where}", expected, got)
    try:
        make_solver(name, **options)
    except HumanoidIKError as exc:
        raise r.fail(f"{key}.options", str(exc)) from None
    return SolverSpec(name, options)


def _motion(r: TomlReader, key: str, value: Any) -> Motion:
    """The motion table at ``key``: a registered ``kind`` and that kind's parameters."""
    tbl = r.table(key, value)
    kind = tbl.get("kind")
    if kind is None:
        raise r.fail(f"{key}.kind", f"missing; expected one of {', '.join(MOTIONS)}")
    if not isinstance(kind, str) or kind not in MOTIONS:
        raise r.expect(f"{key}.kind", f"one of {', '.join(MOTIONS)}", kind)
    cls = MOTIONS[kind]
    params = {k: v for k, v in tbl.items() if k != "kind"}
    allowed = {p: "a parameter" for p in cls.parameters()} | {"kind": "a motion kind"}
    for k in params:
        if k not in allowed:
            raise r.fail(
                join_key(key, quote_key(k)),
                f"unknown key for motion '{kind}'; expected one of {', '.join(sorted(allowed))}",
            )
    for k in cls.required():
        if k not in params:
            raise r.fail(
                join_key(key, k), f"missing; motion '{kind}' needs {', '.join(cls.required())}"
            )
    return r.call(key, cls, **params)


def _orientation(r: TomlReader, key: str, value: Any) -> Orientation:
    """The orientation table at ``key`` (``quat`` required)."""
    tbl = r.table(key, value)
    allowed = {p: "a parameter" for p in Orientation.parameters()}
    r.keys(key, tbl, allowed)
    if "quat" not in tbl:
        raise r.fail(f"{key}.quat", "missing; expected a unit quaternion [w, x, y, z]")
    return r.call(key, Orientation, **tbl)


def _render_spec(r: TomlReader, value: Any) -> RenderSpec:
    """The ``[render]`` table (every key optional)."""
    tbl = r.table("render", value)
    r.keys("render", tbl, RENDER_EXPECTED)
    kw: dict[str, Any] = {}
    for k in ("width", "height"):
        if k in tbl:
            v = tbl[k]
            if isinstance(v, bool) or not isinstance(v, int) or not frame_size_ok(v):
                raise r.expect(f"render.{k}", RENDER_EXPECTED[k], v)
            kw[k] = v
    if "camera" in tbl:
        kw["camera"] = r.string("render.camera", tbl["camera"], "a camera name")
    if "trail" in tbl:
        kw["trail"] = r.call("render", check_number, "trail", tbl["trail"], low=0.0, high=MAX_TRAIL)
    if "gif" in tbl:
        kw["gif"] = r.call("render", check_bool, "gif", tbl["gif"])
    if "snapshots" in tbl:
        snaps = tbl["snapshots"]
        if not isinstance(snaps, list):
            raise r.expect("render.snapshots", RENDER_EXPECTED["snapshots"], snaps)
        if len(snaps) > MAX_SNAPSHOTS:
            raise r.expect("render.snapshots", f"at most {MAX_SNAPSHOTS} times", len(snaps))
        kw["snapshots"] = tuple(
            r.call("render", check_number, f"snapshots[{i}]", s, low=0.0)
            for i, s in enumerate(snaps)
        )
    if "contact_sheet" in tbl:
        kw["contact_sheet"] = r.call(
            "render",
            check_int,
            "contact_sheet",
            tbl["contact_sheet"],
            low=0,
            high=MAX_CONTACT_SHEET,
        )
    return RenderSpec(**kw)


def _array_of_tables(r: TomlReader, doc: Mapping[str, Any], key: str) -> list[dict[str, Any]]:
    """``doc[key]``: a required, non-empty array of tables."""
    items = doc.get(key)
    if items is None:
        raise r.fail(key, f"missing; expected {_TOP[key]}")
    if not isinstance(items, list) or not items:
        raise r.expect(key, _TOP[key], items)
    for i, item in enumerate(items):
        r.table(f"{key}[{i}]", item)
    return items


def _targets(r: TomlReader, doc: Mapping[str, Any]) -> list[TargetTrack]:
    """The ``[[targets]]``, with distinct names."""
    targets: list[TargetTrack] = []
    for i, tbl in enumerate(_array_of_tables(r, doc, "targets")):
        key = f"targets[{i}]"
        r.keys(key, tbl, _TARGET, required=("name", "motion"))
        tname = r.string(f"{key}.name", tbl["name"], _TARGET["name"])
        if any(t.name == tname for t in targets):
            raise r.fail(
                f"{key}.name", f"expected a name not used by another target, got {tname!r}"
            )
        motion = _motion(r, f"{key}.motion", tbl["motion"])
        orient = (
            _orientation(r, f"{key}.orientation", tbl["orientation"])
            if "orientation" in tbl
            else None
        )
        targets.append(TargetTrack(tname, motion, orient))
    return targets


def _effectors(
    r: TomlReader, doc: Mapping[str, Any], targets: list[TargetTrack]
) -> list[EffectorSpec]:
    """The ``[[effectors]]``: distinct sites or bodies, each tracking one of ``targets``."""
    names = [t.name for t in targets]
    effectors: list[EffectorSpec] = []
    for i, tbl in enumerate(_array_of_tables(r, doc, "effectors")):
        key = f"effectors[{i}]"
        r.keys(key, tbl, _EFFECTOR, required=("target",))
        site, body = _end_effector(r, key, tbl)
        for kind, name in (("site", site), ("body", body)):
            if name is not None and any(getattr(e, kind) == name for e in effectors):
                raise r.fail(
                    f"{key}.{kind}", f"expected a {kind} no other effector uses, got {name!r}"
                )
        target = tbl["target"]
        if target not in names:
            raise r.expect(f"{key}.target", f"one of {', '.join(map(repr, names))}", target)
        task = r.call(key, check_choice, "task", tbl.get("task", "reach"), TASKS)
        joints = None
        if "joints" in tbl:
            js = tbl["joints"]
            if not isinstance(js, list) or not js or not all(isinstance(j, str) for j in js):
                raise r.expect(f"{key}.joints", _EFFECTOR["joints"], js)
            joints = tuple(js)
        own = _solver_spec(r, f"{key}.solver", tbl["solver"]) if "solver" in tbl else None
        if task == "look_at" and targets[names.index(target)].is_pose:
            raise r.fail(
                f"{key}.task",
                f"expected 'reach' for pose target {target!r} (look_at aims at a point)",
            )
        effectors.append(EffectorSpec(site, target, task, joints, own, body))
    return effectors


def _end_effector(r: TomlReader, key: str, tbl: Mapping[str, Any]) -> tuple[str | None, str | None]:
    """An effector table's ``site`` or ``body`` (exactly one)."""
    if ("site" in tbl) == ("body" in tbl):
        got = "both" if "site" in tbl else "neither"
        raise r.fail(f"{key}.site", f"expected a site or a body (one of them), got {got}")
    if "site" in tbl:
        return r.string(f"{key}.site", tbl["site"], _EFFECTOR["site"]), None
    return None, r.string(f"{key}.body", tbl["body"], _EFFECTOR["body"])


def _model_path(r: TomlReader, doc: Mapping[str, Any], base: Path | None) -> Path:
    """The MJCF file: ``model`` relative to ``base``, or the bundled humanoid."""
    if "model" not in doc:
        return bundled_model_path()
    rel = Path(r.string("model", doc["model"], _TOP["model"]))
    model = rel if rel.is_absolute() else (base or Path(".")) / rel
    if not model.is_file():
        raise r.fail("model", f"expected an MJCF or URDF file, got {doc['model']!r} (not found)")
    return model


def frames_limit(scene: Scene) -> int:
    """The most frames ``scene`` may run: :data:`MAX_FRAMES`, and no frame later than its
    motions reach (a ``random_walk`` covers :data:`MAX_KNOTS` knots; see
    :attr:`~humanoid_ik.motion.Motion.horizon`)."""
    limit = MAX_FRAMES
    for track in scene.targets:
        horizon = track.motion.horizon
        if math.isfinite(horizon):
            limit = min(limit, int(horizon * scene.fps) + 1)
    return max(1, limit)


def parse_scene(
    doc: Mapping[str, Any],
    source: str,
    base: Path | None = None,
    *,
    packages: PackagePaths | None = None,
) -> Scene:
    """A :class:`Scene` from a parsed TOML document (names are not checked against the
    model; :func:`load_scene` does that).

    Args:
        doc: the document, as ``tomllib`` returns it.
        source: the file for messages.
        base: the folder relative model and package paths start from (default: the
            working folder).
        packages: ROS package folders that take precedence over the document's
            ``package_path`` table (``--package-path``, a sweep file's table).

    Raises:
        SceneError: an unknown key, a missing one, a wrong type or a bad value.
    """
    r = TomlReader(source, SceneError)
    r.keys("", doc, _TOP, required=("duration", "targets", "effectors"))
    is_file = bool(source) and not source.startswith("<")
    name = r.name(
        "name", doc.get("name", Path(source).stem if is_file else "scene"), first_alphanumeric=True
    )
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise r.expect("description", "a string", description)
    model = _model_path(r, doc, base)
    table = r.package_paths("package_path", doc.get("package_path", {}), base)
    duration = r.call("", check_number, "duration", doc["duration"], low=0.0, strict=True)
    fps = r.call("", check_number, "fps", doc.get("fps", 30), low=MIN_FPS, high=MAX_FPS)
    check_duration(r, duration, fps)
    solver = _solver_spec(r, "solver", doc.get("solver", {"name": "auto"}))
    render = _render_spec(r, doc.get("render", {}))
    targets = _targets(r, doc)
    effectors = _effectors(r, doc, targets)
    return Scene(
        name=name,
        duration=duration,
        fps=fps,
        solver=solver,
        targets=tuple(targets),
        effectors=tuple(effectors),
        render=render,
        model=model,
        description=description,
        path=Path(source) if is_file else None,
        packages={**table, **(packages or {})},
    )


# ----------------------------------------------------------------------------- model checks
def load_scene(path: str | os.PathLike, *, packages: PackagePaths | None = None) -> Scene:
    """Read, validate and check a scene file (or a bundled scene's name) against its model.

    Args:
        path: the file, or a bundled scene's name.
        packages: ROS package folders ``{NAME: DIR}``, over the file's ``package_path``.

    Raises:
        SceneError: the file is missing or not TOML, or any value is wrong; the message
            names the file, the key and what was expected.
    """
    p = find_scene(path)
    source = display_path(p)
    scene = parse_scene(read_toml(p, source, SceneError), source, p.parent, packages=packages)
    check_scene(scene)
    return scene
