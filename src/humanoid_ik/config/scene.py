"""Scene files: which end effectors track which moving targets, with which solver, and
how the run is filmed.

A scene is a TOML file (read with ``tomllib``)::

    name = "circle"                    # optional, default: the file name
    description = "Right hand traces a circle."
    model = "../models/humanoid/scene.xml"   # optional, relative to the scene file
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
    site = "right_palm_site"
    target = "ball"
    # task = "look_at"                 # aim the site's x axis at the target (gaze)
    # joints = [...]                   # default: the hinges from the site to the root
    # solver = { name = "ccd" }        # this effector's own solver

Every mistake raises :class:`~humanoid_ik.errors.SceneError` with one message naming
the file, the key and what was expected, e.g.
``scenes/x.toml: targets[0].motion.radius: expected a number > 0, got 'big'``.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import mujoco

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import bundled_dir, bundled_model_path, load_model, model_cameras
from humanoid_ik.errors import HumanoidIKError, SceneError, TrajectoryError, show_value
from humanoid_ik.motion.trajectories import (
    MOTIONS,
    Orientation,
    TargetTrack,
    check_bool,
    check_choice,
    check_int,
    check_number,
)
from humanoid_ik.solvers import SOLVERS, make_solver

__all__ = [
    "TASKS",
    "EffectorSpec",
    "RenderSpec",
    "Scene",
    "SolverSpec",
    "bundled_scenes",
    "bundled_scenes_dir",
    "check_scene",
    "display_path",
    "find_scene",
    "load_scene",
    "parse_scene",
]

TASKS = ("reach", "look_at")
"""Effector tasks: ``reach`` puts the site on the target (and in its orientation for a
pose target); ``look_at`` aims the site's x axis at the target."""
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
_MAX_FPS = 1000.0


# ----------------------------------------------------------------------------- values
@dataclass(frozen=True)
class SolverSpec:
    """A solver by name with its options (checked against the solver's own defaults)."""

    name: str
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def make(self):
        """A fresh solver object (:func:`humanoid_ik.solvers.make_solver`)."""
        return make_solver(self.name, **dict(self.options))

    def label(self) -> str:
        """``name`` or ``name(key=value, ...)``."""
        if not self.options:
            return self.name
        opts = ", ".join(f"{k}={show_value(v)}" for k, v in self.options.items())
        return f"{self.name}({opts})"


@dataclass(frozen=True)
class EffectorSpec:
    """An end effector (a site and the joints that move it) and the target it tracks.

    Attributes:
        site: the end-effector site, e.g. ``right_palm_site``.
        target: the name of the target it tracks.
        task: ``reach`` or ``look_at`` (aim the site's x axis at the target).
        joints: the chain's joints, or ``None`` for every hinge from the site to the root.
        solver: this effector's own solver, or ``None`` for the scene's solver (a
            ``look_at`` effector then uses ``look_at``).
    """

    site: str
    target: str
    task: str = "reach"
    joints: tuple[str, ...] | None = None
    solver: SolverSpec | None = None

    def __post_init__(self) -> None:
        if self.task not in TASKS:
            raise SceneError(
                "<effector>",
                "task",
                f"expected one of {', '.join(map(repr, TASKS))}, got {show_value(self.task)}",
            )
        if self.joints is not None:
            object.__setattr__(self, "joints", tuple(self.joints))


@dataclass(frozen=True)
class RenderSpec:
    """How a run is filmed.

    Attributes:
        width, height: frame size [px], even, at least 16.
        camera: a named camera of the model.
        trail: how much of each end effector's recent path is drawn [s] (0: none).
        gif: also write an animated GIF.
        snapshots: times [s] of the frames saved as PNG (empty: four spread evenly).
        contact_sheet: thumbnails in the contact sheet (0: no sheet).
    """

    width: int = 640
    height: int = 480
    camera: str = "front"
    trail: float = 1.5
    gif: bool = False
    snapshots: tuple[float, ...] = ()
    contact_sheet: int = 12


@dataclass(frozen=True)
class Scene:
    """A validated scene. Build one with :func:`load_scene`, or directly and then
    :func:`check_scene`.

    Attributes:
        name: the scene's name (also its output folder).
        duration: [s].
        fps: frames per second [1/s].
        solver: the default solver.
        targets: the moving targets.
        effectors: which site tracks which target.
        render: how it is filmed.
        model: the MJCF path (the bundled humanoid by default).
        description: one line for ``humanoid-ik scenes``.
        path: the file it came from (for messages), or ``None``.
    """

    name: str
    duration: float
    fps: float
    solver: SolverSpec
    targets: tuple[TargetTrack, ...]
    effectors: tuple[EffectorSpec, ...]
    render: RenderSpec = field(default_factory=RenderSpec)
    model: Path = field(default_factory=bundled_model_path)
    description: str = ""
    path: Path | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "targets", tuple(self.targets))
        object.__setattr__(self, "effectors", tuple(self.effectors))
        object.__setattr__(self, "model", Path(self.model))

    @property
    def n_frames(self) -> int:
        """Frames in a full run: ``max(1, round(duration * fps))``."""
        return max(1, round(self.duration * self.fps))

    @property
    def source(self) -> str:
        """The scene's file for messages, or ``<scene 'name'>``."""
        return display_path(self.path) if self.path else f"<scene '{self.name}'>"

    def target(self, name: str) -> TargetTrack:
        """The target called ``name``.

        Raises:
            SceneError: no such target (the names are listed).
        """
        for t in self.targets:
            if t.name == name:
                return t
        names = ", ".join(repr(t.name) for t in self.targets)
        raise SceneError(self.source, "targets", f"no target {name!r}; targets: {names}")

    def solver_for(self, effector: EffectorSpec) -> SolverSpec:
        """The solver an effector uses: its own, else the scene's; a ``look_at``
        effector without its own solver uses ``look_at`` unless the scene's solver moves
        several effectors at once."""
        if effector.solver is not None:
            return effector.solver
        if effector.task == "look_at" and not _is_multi(self.solver.name):
            return SolverSpec("look_at")
        return self.solver

    def with_overrides(
        self,
        *,
        solver: str | SolverSpec | None = None,
        frames: int | None = None,
        fps: float | None = None,
        width: int | None = None,
        height: int | None = None,
        camera: str | None = None,
        gif: bool | None = None,
    ) -> Scene:
        """A copy with command-line choices applied (``None`` keeps the scene's value).

        ``solver`` replaces the scene's default solver (its options are dropped unless a
        :class:`SolverSpec` is given); ``frames`` shortens or lengthens the run to that
        many frames at the scene's (or the given) frame rate.
        """
        out = self
        if solver is not None:
            spec = solver if isinstance(solver, SolverSpec) else SolverSpec(solver)
            out = replace(out, solver=spec)
        if fps is not None:
            out = replace(out, fps=float(fps))
        if frames is not None:
            out = replace(out, duration=frames / out.fps)
        r = out.render
        r = replace(
            r,
            width=r.width if width is None else width,
            height=r.height if height is None else height,
            camera=r.camera if camera is None else camera,
            gif=r.gif if gif is None else gif,
        )
        return replace(out, render=r)


def _is_multi(solver_name: str) -> bool:
    """True for a solver that moves several effectors at once (it has ``solve_effectors``)."""
    cls = SOLVERS.get(solver_name)
    return cls is not None and callable(getattr(cls, "solve_effectors", None))


# ----------------------------------------------------------------------------- paths
def display_path(path: str | os.PathLike) -> str:
    """``path`` relative to the working folder when it lies inside it, else as given."""
    p = Path(path)
    try:
        return str(p.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(p)


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
class _Reader:
    """Typed access to a parsed TOML document, failing with file + key + expectation
    (as ``error(file, key, message)``: a :class:`SceneError` here, a ``SweepError`` for
    sweep files)."""

    error: Callable[[str, str, str], HumanoidIKError] = SceneError

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, message: str) -> HumanoidIKError:
        return type(self).error(self.source, key, message)

    def expect(self, key: str, expected: str, got: Any) -> HumanoidIKError:
        return self.fail(key, f"expected {expected}, got {show_value(got)}")

    def table(self, key: str, value: Any) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.expect(key, "a table", value)
        return value

    def keys(
        self, prefix: str, table: Any, allowed: Mapping[str, str], required=()
    ) -> dict[str, Any]:
        """``table`` once checked: a table, no unknown key, every required one present.
        ``allowed`` maps key -> expectation."""
        table = self.table(prefix, table)
        for k in table:
            if k not in allowed:
                raise self.fail(
                    _join(prefix, k), f"unknown key; expected one of {', '.join(sorted(allowed))}"
                )
        for k in required:
            if k not in table:
                raise self.fail(_join(prefix, k), f"missing; expected {allowed[k]}")
        return table

    def call(self, prefix: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """``fn(*args)``, with a :class:`TrajectoryError` turned into a SceneError."""
        try:
            return fn(*args, **kwargs)
        except TrajectoryError as exc:
            raise self.expect(_join(prefix, exc.field), exc.expected, exc.got) from None

    def string(self, key: str, value: Any, what: str = "a string") -> str:
        if not isinstance(value, str) or not value:
            raise self.expect(key, what, value)
        return value


def _join(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


_TOP = {
    "name": "a name of letters, digits, '_', '-' or '.'",
    "description": "a string",
    "model": "an MJCF path (relative to the scene file)",
    "duration": "a number > 0 (seconds)",
    "fps": "a number > 0 (frames per second)",
    "solver": "a table with name (and options)",
    "render": "a table",
    "targets": "an array of tables [[targets]] with name and motion",
    "effectors": "an array of tables [[effectors]] with site and target",
}
_SOLVER = {"name": "a solver name", "options": "a table of solver options"}
_RENDER = {
    "width": "an even integer >= 16 (pixels)",
    "height": "an even integer >= 16 (pixels)",
    "camera": "a camera name",
    "trail": "a number >= 0 (seconds)",
    "gif": "true or false",
    "snapshots": "a list of times >= 0 (seconds)",
    "contact_sheet": "an integer >= 0",
}
_TARGET = {
    "name": "a target name",
    "motion": "a table with kind",
    "orientation": "a table with quat",
}
_EFFECTOR = {
    "site": "a site name",
    "target": "a target name",
    "task": f"one of {', '.join(repr(t) for t in TASKS)}",
    "joints": "a list of joint names",
    "solver": "a table with name (and options)",
}


def _solver_spec(r: _Reader, key: str, value: Any) -> SolverSpec:
    if isinstance(value, str):
        value = {"name": value}
    tbl = r.table(key, value)
    r.keys(key, tbl, _SOLVER, required=("name",))
    name = tbl["name"]
    if not isinstance(name, str) or name not in SOLVERS:
        raise r.expect(f"{key}.name", f"one of {', '.join(SOLVERS)}", name)
    options = r.table(f"{key}.options", tbl.get("options", {}))
    try:
        make_solver(name, **options)
    except HumanoidIKError as exc:
        raise r.fail(f"{key}.options", str(exc)) from None
    return SolverSpec(name, options)


def _motion(r: _Reader, key: str, value: Any):
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
                _join(key, k),
                f"unknown key for motion '{kind}'; expected one of {', '.join(sorted(allowed))}",
            )
    for k in cls.required():
        if k not in params:
            raise r.fail(
                _join(key, k), f"missing; motion '{kind}' needs {', '.join(cls.required())}"
            )
    return r.call(key, cls, **params)


def _orientation(r: _Reader, key: str, value: Any) -> Orientation:
    tbl = r.table(key, value)
    allowed = {p: "a parameter" for p in Orientation.parameters()}
    r.keys(key, tbl, allowed)
    if "quat" not in tbl:
        raise r.fail(f"{key}.quat", "missing; expected a unit quaternion [w, x, y, z]")
    return r.call(key, Orientation, **tbl)


def _render_spec(r: _Reader, value: Any) -> RenderSpec:
    tbl = r.table("render", value)
    r.keys("render", tbl, _RENDER)
    kw: dict[str, Any] = {}
    for k in ("width", "height"):
        if k in tbl:
            v = tbl[k]
            if isinstance(v, bool) or not isinstance(v, int) or v < 16 or v % 2:
                raise r.expect(f"render.{k}", _RENDER[k], v)
            kw[k] = v
    if "camera" in tbl:
        kw["camera"] = r.string("render.camera", tbl["camera"], "a camera name")
    if "trail" in tbl:
        kw["trail"] = r.call("render", check_number, "trail", tbl["trail"], low=0.0)
    if "gif" in tbl:
        kw["gif"] = r.call("render", check_bool, "gif", tbl["gif"])
    if "snapshots" in tbl:
        snaps = tbl["snapshots"]
        if not isinstance(snaps, list):
            raise r.expect("render.snapshots", _RENDER["snapshots"], snaps)
        kw["snapshots"] = tuple(
            r.call("render", check_number, f"snapshots[{i}]", s, low=0.0)
            for i, s in enumerate(snaps)
        )
    if "contact_sheet" in tbl:
        kw["contact_sheet"] = r.call(
            "render", check_int, "contact_sheet", tbl["contact_sheet"], low=0
        )
    return RenderSpec(**kw)


def _array_of_tables(r: _Reader, doc: Mapping[str, Any], key: str) -> list[dict[str, Any]]:
    items = doc.get(key)
    if items is None:
        raise r.fail(key, f"missing; expected {_TOP[key]}")
    if not isinstance(items, list) or not items:
        raise r.expect(key, _TOP[key], items)
    for i, item in enumerate(items):
        r.table(f"{key}[{i}]", item)
    return items


def parse_scene(doc: Mapping[str, Any], source: str, base: Path | None = None) -> Scene:
    """A :class:`Scene` from a parsed TOML document (names are not checked against the
    model; :func:`load_scene` does that).

    Args:
        doc: the document, as ``tomllib`` returns it.
        source: the file for messages.
        base: the folder relative model paths start from (default: the working folder).

    Raises:
        SceneError: an unknown key, a missing one, a wrong type or a bad value.
    """
    r = _Reader(source)
    r.keys("", doc, _TOP, required=("duration", "targets", "effectors"))
    stem = Path(source).stem if source and not source.startswith("<") else "scene"
    name = doc.get("name", stem)
    if not isinstance(name, str) or not _NAME_RE.match(name):
        raise r.expect("name", _TOP["name"], name)
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise r.expect("description", "a string", description)
    model = bundled_model_path()
    if "model" in doc:
        rel = Path(r.string("model", doc["model"], _TOP["model"]))
        model = rel if rel.is_absolute() else (base or Path(".")) / rel
        if not model.is_file():
            raise r.fail("model", f"expected an MJCF file, got {doc['model']!r} (not found)")
    duration = r.call("", check_number, "duration", doc["duration"], low=0.0, strict=True)
    fps = r.call("", check_number, "fps", doc.get("fps", 30), low=0.0, strict=True)
    if fps > _MAX_FPS:
        raise r.expect("fps", f"a number > 0 and <= {_MAX_FPS:g}", doc["fps"])
    solver = _solver_spec(r, "solver", doc.get("solver", {"name": "dls"}))
    render = _render_spec(r, doc.get("render", {}))

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
    names = [t.name for t in targets]

    effectors: list[EffectorSpec] = []
    for i, tbl in enumerate(_array_of_tables(r, doc, "effectors")):
        key = f"effectors[{i}]"
        r.keys(key, tbl, _EFFECTOR, required=("site", "target"))
        site = r.string(f"{key}.site", tbl["site"], _EFFECTOR["site"])
        if any(e.site == site for e in effectors):
            raise r.fail(f"{key}.site", f"expected a site no other effector uses, got {site!r}")
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
        effectors.append(EffectorSpec(site, target, task, joints, own))

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
        path=Path(source) if source and not source.startswith("<") else None,
    )


# ----------------------------------------------------------------------------- model checks
def check_scene(scene: Scene, model: mujoco.MjModel | None = None) -> list[Chain]:
    """Check a scene against its model and return one chain per effector.

    Checks the sites and joints exist, no two effectors share a joint, the camera exists,
    the frame fits MuJoCo's off-screen buffer, and each effector's solver can solve its
    chain and task.

    Args:
        scene: the scene.
        model: its compiled model (compiled from ``scene.model`` when ``None``).

    Returns:
        The chains, in effector order, all on ``model``.

    Raises:
        SceneError: naming the scene file, the key and what was expected.
    """

    src = scene.source
    r = _Reader(src)
    if model is None:
        try:
            model = load_model(scene.model)
        except HumanoidIKError as exc:
            raise r.fail("model", str(exc)) from None
    chains: list[Chain] = []
    owner: dict[str, int] = {}
    for i, eff in enumerate(scene.effectors):
        key = f"effectors[{i}]"
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, eff.site)
        if sid < 0:
            sites = [
                mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, k) for k in range(model.nsite)
            ]
            valid = ", ".join(sorted(s for s in sites if s))
            raise r.expect(f"{key}.site", f"a site of the model ({valid})", eff.site)
        try:
            chain = Chain(model, eff.site, eff.joints)
        except HumanoidIKError as exc:
            raise r.fail(f"{key}.joints", str(exc)) from None
        for j in chain.joint_names:
            if j in owner:
                raise r.fail(
                    f"{key}.joints",
                    f"joint '{j}' is already moved by effectors[{owner[j]}]; expected "
                    "effectors with separate joints (set joints = [...])",
                )
            owner[j] = i
        spec = scene.solver_for(eff)
        target = scene.target(eff.target)
        where = f"{key}.solver.name" if eff.solver is not None else "solver.name"
        if eff.task == "reach" and spec.name == "look_at":
            raise r.fail(
                where,
                f"solver 'look_at' aims a site at a point; {key} ({eff.site}) reaches "
                "(task = 'reach'); expected a reaching solver or task = 'look_at'",
            )
        solver = spec.make()
        if eff.task == "look_at" and solver.reaches and not _is_multi(spec.name):
            raise r.fail(
                where,
                f"solver '{spec.name}' moves a site onto a point; {key} ({eff.site}) aims "
                "(task = 'look_at'); expected 'look_at' or 'mink'",
            )
        reason = None if _is_multi(spec.name) else solver.applicable(chain, target.is_pose)
        if reason is not None:
            raise r.fail(where, f"solver '{spec.name}' cannot drive {key} ({eff.site}): {reason}")
        chains.append(chain)

    cams = model_cameras(model)
    if scene.render.camera not in cams:
        raise r.expect(
            "render.camera", f"one of {', '.join(cams) or '(no cameras)'}", scene.render.camera
        )
    offw, offh = int(model.vis.global_.offwidth), int(model.vis.global_.offheight)
    for k, v, lim in (("width", scene.render.width, offw), ("height", scene.render.height, offh)):
        if v > lim:
            raise r.expect(
                f"render.{k}", f"at most {lim} (the model's off-screen buffer, visual/global)", v
            )
        if v < 16 or v % 2:
            raise r.expect(f"render.{k}", _RENDER[k], v)
    if not (math.isfinite(scene.fps) and scene.fps > 0):
        raise r.expect("fps", _TOP["fps"], scene.fps)
    return chains


def read_toml(
    path: Path, source: str, error: Callable[[str, str, str], Exception]
) -> dict[str, Any]:
    """The TOML document at ``path``; a decoding or reading failure raises
    ``error(source, "", message)`` (:class:`SceneError`, ``SweepError``)."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise error(source, "", f"not valid TOML: {exc}") from None
    except OSError as exc:
        raise error(source, "", f"cannot be read: {exc.strerror or exc}") from None


def load_scene(path: str | os.PathLike) -> Scene:
    """Read, validate and check a scene file (or a bundled scene's name) against its model.

    Raises:
        SceneError: the file is missing or not TOML, or any value is wrong; the message
            names the file, the key and what was expected.
    """
    p = find_scene(path)
    source = display_path(p)
    scene = parse_scene(read_toml(p, source, SceneError), source, p.parent)
    check_scene(scene)
    return scene
