"""Scene files: which end effectors track which moving targets, with which solver, and
how the run is filmed.

A scene is a TOML file (read with ``tomllib``)::

    name = "circle"                    # optional, default: the file name
    description = "Right hand traces a circle."
    model = "../models/humanoid/scene.xml"   # optional, relative to the scene file
    # package_path = { my_robot = "../my_robot" }   # ROS packages of a URDF's package://
    # limbs = "robot.limbs.toml"       # a limb profile (docs/limbs.md), relative
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
    # center = { limb = "right_arm", at = [0.63, -0.05, -0.28] }   # placed on the robot:
    # radius = { limb = "right_arm", reach = 0.19 }  # config/placement.py, docs/scenes.md
    # orientation = { quat = [0.7071, 0, -0.7071, 0] }   # makes it a pose target

    [[effectors]]
    site = "right_palm_site"           # or body = "tool_link" (a URDF link, an MJCF body),
    target = "ball"                    # or limb = "right_arm" (found from the model)
    # torso = true                     # with limb: the torso helps the reach
    # task = "look_at"                 # aim the site's x axis at the target (gaze)
    # joints = [...]                   # default: the hinges from the site to the root
    # solver = { name = "ccd" }        # this effector's own solver

The values live in :mod:`humanoid_ik.config.specs` (re-exported here); the file is
validated by its typed model, :class:`~humanoid_ik.config.scene_schema.SceneFile`
(pydantic, imported when the first file is parsed), and then checked against its model
by :mod:`humanoid_ik.config.scene_check`. Every mistake raises
:class:`~humanoid_ik.errors.SceneError` with one message naming the file, the key path
and what was expected, e.g.
``scenes/x.toml: targets[0].motion.radius: expected a number > 0, got 'big'``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from humanoid_ik.config.scene_check import (
    check_collision_pairs,
    check_scene,
    place_scene,
    scene_model,
)
from humanoid_ik.config.specs import (
    MAX_FRAMES,
    TASKS,
    EffectorSpec,
    RenderSpec,
    Scene,
    SolverSpec,
)
from humanoid_ik.config.toml import display_path, read_toml
from humanoid_ik.core.models import bundled_dir, bundled_override
from humanoid_ik.core.robot_files import PackagePaths
from humanoid_ik.errors import SceneError

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
    """A scene file from a path, or from the name of a bundled scene: its file name
    (``circle``) or, when they differ, the ``name`` its TOML declares (what ``scenes``
    lists). A file name wins over a declared name.

    Raises:
        SceneError: neither a file nor a bundled scene (the bundled names are listed), or
            a declared name that several bundled files share.
    """
    p = Path(name_or_path)
    if p.is_file():
        return p
    if p.suffix == "" and p.parent == Path("."):
        candidate = bundled_scenes_dir() / f"{p.name}.toml"
        if candidate.is_file():
            return candidate
        declared = [f for f in bundled_scenes() if _declared_name(f) == p.name]
        if len(declared) == 1:
            return declared[0]
        if declared:
            raise SceneError(
                p.name,
                "",
                "a scene name several bundled files declare; expected one of their file "
                f"names: {', '.join(f.stem for f in declared)}",
            )
    names = ", ".join(s.stem for s in bundled_scenes()) or "(none)"
    raise SceneError(
        str(name_or_path),
        "",
        f"no such scene file; expected a path or a bundled scene: {names}"
        + bundled_override("scenes"),
    )


def _declared_name(path: Path) -> str | None:
    """The ``name`` a bundled scene file declares (``None``: none, or unreadable; loading
    it by its file name gives the error)."""
    try:
        name = read_toml(path, display_path(path), SceneError).get("name")
    except SceneError:
        return None
    return name if isinstance(name, str) else None


# ----------------------------------------------------------------------------- parsing
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
    model: str | os.PathLike | None = None,
    limbs: str | os.PathLike | None = None,
) -> Scene:
    """A :class:`Scene` from a parsed TOML document, validated by the typed model of
    ``config/scene_schema.py``. Names are checked against the model by
    :func:`load_scene`; a scene with limb effectors or targets placed relative to a
    limb is placed on its model here (:func:`~humanoid_ik.config.scene_check.place_scene`).

    Args:
        doc: the document, as ``tomllib`` returns it.
        source: the file for messages.
        base: the folder relative model and package paths start from (default: the
            working folder).
        packages: ROS package folders that take precedence over the document's
            ``package_path`` table (``--package-path``, a sweep file's table).
        model: a model file to run the scene on instead of the document's ``model``
            (``--model``; the document's ``limbs`` profile, written for its own model,
            is then not read).
        limbs: a limb profile file over the document's ``limbs`` (``--limbs``).

    Raises:
        SceneError: an unknown key, a missing one, a wrong type or a bad value.
    """
    from humanoid_ik.config.scene_schema import SceneFile
    from humanoid_ik.config.schema import validate

    is_file = bool(source) and not source.startswith("<")
    doc = {"name": Path(source).stem if is_file else "scene", **doc}
    f = validate(SceneFile, doc, source, SceneError, base=base)
    model_path = f.model if model is None else Path(model)
    profile = Path(limbs) if limbs is not None else (f.limbs if model is None else None)
    pkgs = {**f.package_path, **(packages or {})}
    targets, effectors, notes = place_scene(
        source,
        model_path,
        pkgs,
        profile,
        [t.track for t in f.targets],
        [e.spec for e in f.effectors],
        f.solver,
    )
    return Scene(
        name=f.name,
        duration=f.duration,
        fps=f.fps,
        solver=f.solver,
        targets=targets,
        effectors=effectors,
        render=f.render.spec,
        model=model_path,
        description=f.description,
        path=Path(source) if is_file else None,
        packages=pkgs,
        limbs=profile,
        notes=notes,
    )


# ----------------------------------------------------------------------------- model checks
def load_scene(
    path: str | os.PathLike,
    *,
    packages: PackagePaths | None = None,
    model: str | os.PathLike | None = None,
    limbs: str | os.PathLike | None = None,
) -> Scene:
    """Read, validate and check a scene file (or a bundled scene's name) against its model.

    Args:
        path: the file, or a bundled scene's name.
        packages: ROS package folders ``{NAME: DIR}``, over the file's ``package_path``.
        model: a model file instead of the file's ``model`` (see :func:`parse_scene`).
        limbs: a limb profile file over the file's ``limbs``.

    Raises:
        SceneError: the file is missing or not TOML, or any value is wrong; the message
            names the file, the key and what was expected.
    """
    p = find_scene(path)
    source = display_path(p)
    doc = read_toml(p, source, SceneError)
    scene = parse_scene(doc, source, p.parent, packages=packages, model=model, limbs=limbs)
    check_scene(scene)
    return scene
