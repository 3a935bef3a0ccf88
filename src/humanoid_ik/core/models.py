"""The model layer: where the bundled files live, loading MJCF, and the ``home`` keyframe.

Every other module asks here for a model, the bundled folders and the home pose, so the
rule for each is written once. A model file whose home pose lies outside its joint
ranges is said once, where it is loaded (:class:`HomeWarning`), so every command that
starts from home says so.
"""

from __future__ import annotations

import os
import re
import warnings
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.meshes import convert_meshes
from humanoid_ik.core.model_cache import compile_cached
from humanoid_ik.core.model_checks import LOCKED_HALF_WIDTH, check_finite, check_ranges
from humanoid_ik.core.mujoco_warnings import mujoco_warnings
from humanoid_ik.core.names import joint_name
from humanoid_ik.core.robot_files import (
    ModelWarning,
    PackageIndex,
    PackagePaths,
    is_robot_file,
    robot_text,
)
from humanoid_ik.errors import ModelError

__all__ = [
    "BUNDLED_KINDS",
    "COLLISION_GROUP",
    "HOME_KEY",
    "HomeWarning",
    "ModelWarning",
    "VISUAL_GROUP",
    "bundled_dir",
    "bundled_model_path",
    "bundled_override",
    "home_outside_ranges",
    "home_qpos",
    "check_finite",
    "home_warning",
    "STAGE_CAMERAS",
    "URDF_MIN_INERTIA",
    "URDF_MIN_MASS",
    "load_model",
    "compile_spec",
    "model_cameras",
    "model_file",
    "model_spec",
    "needs_stage",
    "reset_to_home",
    "staged_cameras",
    "urdf_geom_name",
]

HOME_KEY = "home"
"""Name of the keyframe every run, solve and reset starts from (``qpos0`` without it)."""

_BUNDLED_PACKAGE = "humanoid_ik"
_BUNDLED_FOLDER = "_bundled"
_CHECKOUT_ROOT = Path(__file__).resolve().parents[3]
BUNDLED_KINDS = ("models", "scenes", "sweeps", "motions")
"""The bundled folders: the repository's top-level ``models/``, ``scenes/``, ``sweeps/``
and ``motions/``, shipped in a wheel as ``humanoid_ik/_bundled/<kind>/`` (``setup.py``)."""


def _bundled_root() -> Path:
    """The folder holding the bundled folders: the installed package's ``_bundled``
    (``importlib.resources``), else the checkout's top level (an editable install).

    Raises:
        ModelError: the package is not installed as plain files (e.g. zipped).
    """
    res = resources.files(_BUNDLED_PACKAGE).joinpath(_BUNDLED_FOLDER)
    if res.is_dir():
        if not isinstance(res, Path):
            raise ModelError(
                f"bundled files of {_BUNDLED_PACKAGE} are not plain files ({res}); "
                "install the package unzipped (pip install)"
            )
        return res
    return _CHECKOUT_ROOT


def bundled_dir(kind: str) -> Path:
    """The folder of bundled ``models``, ``scenes``, ``sweeps`` or ``motions`` (BVH clips);
    ``HUMANOID_IK_MODELS`` / ``_SCENES`` / ``_SWEEPS`` / ``_MOTIONS`` override it
    (:func:`bundled_override`). Raises :class:`ModelError` for another ``kind``."""
    if kind not in BUNDLED_KINDS:
        raise ModelError(f"bundled folder '{kind}' unknown; folders: {', '.join(BUNDLED_KINDS)}")
    root = os.environ.get(f"HUMANOID_IK_{kind.upper()}")
    return Path(root) if root else _bundled_root() / kind


def bundled_override(kind: str, path: str | os.PathLike | None = None) -> str:
    """The end of a message about a bundled file not found: which ``HUMANOID_IK_<KIND>``
    chose its folder (when the folder holds ``path``), else ``""``."""
    root = os.environ.get(var := f"HUMANOID_IK_{kind.upper()}")
    if not root or (path is not None and not Path(path).is_relative_to(root)):
        return ""
    return f" ({var}='{root}' sets the bundled {kind} folder; unset it for the package's own)"


def bundled_model_path() -> Path:
    """Path of the bundled humanoid scene (``models/humanoid/scene.xml``)."""
    return bundled_dir("models") / "humanoid" / "scene.xml"


def display_model(model: str | os.PathLike | None) -> str:
    """How reports name a model: ``None`` is the bundled humanoid, shown relative to the
    bundled folders (``models/humanoid/scene.xml``, the same for a checkout and an
    installed wheel); a path is shown as given."""
    if model is not None:
        return str(model)
    path = bundled_model_path()
    try:
        return path.resolve().relative_to(_bundled_root().resolve()).as_posix()
    except ValueError:
        return path.name


def load_model(
    model: mujoco.MjModel | str | os.PathLike | None,
    *,
    packages: PackagePaths | None = None,
) -> mujoco.MjModel:
    """An ``MjModel`` from a model, an MJCF, URDF or xacro path, or ``None`` for the
    bundled humanoid.

    A URDF (``.urdf``, ``.urdf.xacro``) is compiled through :func:`model_spec` (its
    ``package://`` meshes found, visual and collision geoms both kept) and
    :func:`compile_spec` (a known mistake of the file fixed, with a note).

    Args:
        model: the model, a file path, or ``None``.
        packages: ROS package folders ``{NAME: DIR}`` a URDF's ``package://NAME/...``
            paths are looked up in first (``core/robot_files.py``).

    Raises:
        ModelError: the path does not exist, a mesh is not found, MuJoCo cannot
            compile it (MuJoCo's message is kept, with the fix for the mistakes it names),
            or a number of its geometry, axes or ranges is not finite
            (:func:`check_finite`).

    Warns:
        HomeWarning: the file's home pose has joints outside their ranges (once per
            model and process: :func:`home_warning`).
    """
    if isinstance(model, mujoco.MjModel):
        check_finite(model, "the model")
        return model
    path = model_file(model)
    if is_robot_file(path):
        compiled = compile_spec(model_spec(path, packages=packages), path)
    else:
        try:
            with mujoco_warnings():
                compiled = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as exc:
            raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc
        check_ranges(compiled, path)
    check_finite(compiled, f"model '{path}'")
    home = home_warning(compiled)
    if home is not None:  # stacklevel 1: one place, so Python says each model once
        warnings.warn(f"model '{path}': {home}", HomeWarning, 1)
    return compiled


class HomeWarning(ModelWarning):
    """A model file whose home pose (the ``home`` keyframe, else ``qpos0``) has joints
    outside their ranges: every solve, run and render starts from it moved inside
    (:func:`home_warning` says which joints and where). Raised by :func:`load_model`;
    the command line prints it as one ``humanoid-ik: note: ...`` line (``inspect`` and
    ``solve``, which report it themselves, silence it)."""


URDF_MIN_MASS = 1e-6
"""Mass [kg] a URDF link gets when it has neither ``<inertial>`` nor geometry (MuJoCo
rejects massless moving bodies; inverse kinematics never uses masses)."""
URDF_MIN_INERTIA = 1e-9
"""Inertia [kg m^2] such a link gets, for the same reason."""
VISUAL_GROUP = 2
"""The geom group of a URDF's ``<visual>`` geoms: drawn (MuJoCo shows groups 0-2 by
default), colliding with nothing."""
COLLISION_GROUP = 3
"""The geom group of a URDF's ``<collision>`` geoms: colliding, hidden in renders and in
the viewer (toggle group 3 there to see them)."""


def model_file(model: str | os.PathLike | None) -> Path:
    """The model file's path (the bundled humanoid's for ``None``).

    Raises:
        ModelError: there is no such file.
    """
    path = bundled_model_path() if model is None else Path(model)
    if not path.is_file():
        raise ModelError(f"model file '{path}' does not exist{bundled_override('models', path)}")
    return path


def _urdf_joint_rules(spec: mujoco.MjSpec, text: str, path: Path) -> None:
    """What a URDF's joint limits and mimics mean, which MuJoCo's reader loses: a joint
    whose ``lower`` and ``upper`` are given and equal is locked there (kept in a range of
    :data:`LOCKED_HALF_WIDTH`); ``lower > upper`` is refused. Said in one note each:
    the locked joints, the limits without ``lower``/``upper`` (the URDF's default of 0
    would lock them; they are taken as unlimited, as their authors mean), and the
    ``<mimic>`` joints (equality constraints in MuJoCo, which the IK solvers do not
    apply)."""
    import xml.etree.ElementTree as ET

    joints = {j.name: j for j in spec.joints}
    locked: list[str] = []
    open_ended: list[str] = []
    mimics: list[str] = []
    for element in ET.fromstring(text).iter("joint"):
        name, kind = element.get("name", ""), element.get("type", "")
        limit, mimic = element.find("limit"), element.find("mimic")
        if mimic is not None:
            mimics.append(f"'{name}' mimics '{mimic.get('joint')}'")
        if limit is None or kind not in ("revolute", "prismatic") or name not in joints:
            continue
        if limit.get("lower") is None or limit.get("upper") is None:
            open_ended.append(f"'{name}'")
            continue
        try:
            lower, upper = float(limit.get("lower", 0)), float(limit.get("upper", 0))
        except ValueError:
            continue  # MuJoCo's reader has said what it makes of it
        if lower > upper:
            raise ModelError(
                f"model '{path}': joint '{name}' has lower limit {lower:g} > upper {upper:g}; "
                "swap them in the URDF"
            )
        if lower == upper:
            joints[name].limited = mujoco.mjtLimited.mjLIMITED_TRUE
            joints[name].range = [lower - LOCKED_HALF_WIDTH, upper + LOCKED_HALF_WIDTH]
            locked.append(f"'{name}' at {lower:g}")
    for found, what in (
        (locked, "locked (lower = upper in the URDF; give a range to let them move)"),
        (open_ended, "without lower/upper limits: taken as unlimited"),
        (mimics, "kept as equality constraints, which the IK solvers do not apply"),
    ):
        if found:
            shown = ", ".join(found[:3]) + (f" and {len(found) - 3} more" if len(found) > 3 else "")
            warnings.warn(f"model '{path}': {len(found)} joint(s) {what}: {shown}", ModelWarning, 3)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def model_spec(
    model: str | os.PathLike | None, *, packages: PackagePaths | None = None
) -> mujoco.MjSpec:
    """The editable ``MjSpec`` of an MJCF, URDF or xacro file (``None``: the bundled
    humanoid).

    A URDF is read as a robot exported from ROS needs:

    - a xacro file is expanded first;
    - every mesh and texture path (``package://``, ``file://``, relative) becomes the
      absolute file it names (:class:`~humanoid_ik.core.robot_files.PackageIndex`:
      ``packages``, ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, the folders above the
      file), and meshes MuJoCo cannot read (Collada, glTF) are converted;
    - ``<visual>`` and ``<collision>`` geoms are both kept: visuals in
      :data:`VISUAL_GROUP`, drawn and colliding with nothing; collisions in
      :data:`COLLISION_GROUP`, colliding and hidden. A URDF without any
      ``<collision>`` lets its visuals collide (else nothing would). Unnamed geoms are
      named after their link (``<link>_collision``, ``<link>_collision_1`` ...,
      ``<link>_visual``: :func:`urdf_geom_name`);
    - links on fixed joints stay bodies (a ``tool_link`` stays nameable with
      ``--body``), except a root link that only carries a floating base: it is fused
      into the world, so the floating joint is at the top level (MuJoCo's rule for a
      free joint);
    - a link with no ``<inertial>`` and no collision geometry gets
      :data:`URDF_MIN_MASS` (``boundmass``).

    Args:
        model: a model file path, or ``None``.
        packages: as :func:`load_model`.

    Raises:
        ModelError: the file does not exist or cannot be parsed, or a mesh or texture
            is not found (the message names every place looked in).
    """
    path = model_file(model)
    if not is_robot_file(path):
        try:
            with mujoco_warnings():
                return mujoco.MjSpec.from_file(str(path))
        except ValueError as exc:
            raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc
    index = PackageIndex(path, packages)
    text = robot_text(path, index)
    try:
        with mujoco_warnings():
            spec = mujoco.MjSpec.from_string(text)
    except ValueError as exc:
        raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc
    _urdf_joint_rules(spec, text, path)
    spec.modelfiledir = str(index.folder)
    for mesh in spec.meshes:
        if mesh.file:
            mesh.file = str(index.resolve(mesh.file, spec.compiler.meshdir))
    for texture in spec.textures:
        if texture.file:
            texture.file = str(index.resolve(texture.file, spec.compiler.texturedir, "texture"))
    spec.compiler.discardvisual = False  # else a stage's floor (no contacts) is dropped
    spec.compiler.boundmass = URDF_MIN_MASS
    spec.compiler.boundinertia = URDF_MIN_INERTIA
    spec.compiler.inertiagrouprange = [COLLISION_GROUP, COLLISION_GROUP]
    _fuse_floating_roots(spec)
    _group_geoms(spec)
    convert_meshes(spec)
    return spec


def _fuse_floating_roots(spec: mujoco.MjSpec) -> None:
    """Keep every body (``fusestatic`` per body) but a root link without joints whose
    child has a free joint (a URDF ``floating`` joint from a dummy ``base_link``): it
    is fused into the world, so the free joint is at the top level."""
    spec.compiler.fusestatic = True
    world = spec.worldbody
    for body in spec.bodies:
        if body.parent is None:  # the world
            continue
        floating_root = (
            body.parent.name == world.name
            and not body.joints
            and any(j.type == mujoco.mjtJoint.mjJNT_FREE for c in body.bodies for j in c.joints)
        )
        body.fuse = int(floating_root)


def _group_geoms(spec: mujoco.MjSpec) -> None:
    """Move the URDF's visual geoms to :data:`VISUAL_GROUP` and its collision geoms to
    :data:`COLLISION_GROUP`, and name the unnamed ones after their link.

    MuJoCo's URDF reader marks a ``<visual>`` geom by group 1 with ``contype`` and
    ``conaffinity`` 0, a ``<collision>`` geom by group 0 with both 1, and names neither.
    They are named ``<link>_visual``, ``<link>_collision``, then ``<link>_collision_1``
    ... in the file's order (:func:`urdf_geom_name`): names stable across loads and
    model edits that ``collision_pairs`` and messages can use, which geom ids are not
    (a stage's floor shifts them).
    """
    geoms = list(spec.geoms)
    visual = [g.group == 1 and g.contype == 0 and g.conaffinity == 0 for g in geoms]
    collide_visuals = all(visual)
    taken = {g.name for g in geoms if g.name}
    counts: dict[tuple[str, str], int] = {}
    for geom, is_visual in zip(geoms, visual, strict=True):
        if is_visual:
            geom.group = VISUAL_GROUP
            if collide_visuals:
                geom.contype = geom.conaffinity = 1
        else:
            geom.group = COLLISION_GROUP
        if geom.name:
            continue
        kind = "visual" if is_visual else "collision"
        link = geom.parent.name
        while True:
            k = counts.get((link, kind), 0)
            counts[link, kind] = k + 1
            name = urdf_geom_name(link, kind, k)
            if name not in taken:
                break
        geom.name = name
        taken.add(name)


def urdf_geom_name(link: str, kind: str, index: int = 0) -> str:
    """The name a URDF's unnamed geom gets: ``<link>_<kind>`` for the link's first
    ``kind`` (``visual`` or ``collision``) geom, ``<link>_<kind>_<index>`` for the
    next ones."""
    return f"{link}_{kind}" if index == 0 else f"{link}_{kind}_{index}"


def _balance_inertia(spec: mujoco.MjSpec, name: str) -> bool:
    if spec.compiler.balanceinertia:
        return False
    spec.compiler.balanceinertia = True
    return True


def _shell_inertia(spec: mujoco.MjSpec, name: str) -> bool:
    mesh = spec.mesh(name)
    if mesh is None or mesh.inertia == mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL:
        return False
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    return True


def _diagonal_inertia(spec: mujoco.MjSpec, name: str) -> bool:
    body = spec.body(name)
    if body is None or not any(body.fullinertia[3:]):
        return False
    body.fullinertia = [*body.fullinertia[:3], 0.0, 0.0, 0.0]
    return True


_KNOWN_FIXES = (
    (
        "use 'balanceinertia' to fix",
        _balance_inertia,
        "link '{name}' (and any other) has an inertia that breaks A + B >= C (not a "
        "physical body); loaded with the inertias balanced, as "
        '<mujoco><compiler balanceinertia="true"/></mujoco> inside <robot> does; fix '
        "the link's <inertia> to silence this",
    ),
    (
        "inertia must have positive eigenvalues",
        _diagonal_inertia,
        "link '{name}' has an <inertia> that is not positive definite; loaded with its "
        "diagonal (ixx, iyy, izz) alone; fix its ixy, ixz, iyz to silence this",
    ),
    (
        "mesh volume is too small",
        _shell_inertia,
        "mesh '{name}' encloses no volume (an open surface); its inertia is computed as "
        "a shell's, as MuJoCo's <mesh inertia=\"shell\"> does",
    ),
)
"""``(text of MuJoCo's error, fix(spec, element name) -> whether it changed anything,
the note)``: the mistakes of robot files that MuJoCo refuses and :func:`compile_spec`
fixes."""
_ELEMENT = re.compile(r"Element name '([^']*)'")


def compile_spec(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    """``spec`` (of the model file ``path``) compiled, a failure told in one line with
    its fix.

    The mistakes of :data:`_KNOWN_FIXES` are fixed in ``spec`` (a link's inertia that
    breaks A + B >= C is balanced, one that is not positive definite loses its
    off-diagonal terms, an open mesh gets a shell's inertia), each with a
    :class:`ModelWarning` naming the element and how to fix the file.

    Raises:
        ModelError: MuJoCo cannot compile it.
    """
    while True:
        try:
            with mujoco_warnings():
                return compile_cached(spec, path)
        except ValueError as exc:
            msg = _one_line(exc)
            found = _ELEMENT.search(msg)
            name = found.group(1) if found else ""
            fix = next((f for f in _KNOWN_FIXES if f[0] in msg), None)
            if fix is None or not fix[1](spec, name):
                hint = ""
                if "Error opening file" in msg or "resource not found" in msg.lower():
                    hint = (
                        "; put the mesh files where the model names them (an MJCF's "
                        "<compiler meshdir=...> is relative to the model's folder)"
                    )
                raise ModelError(f"model '{path}' does not compile: {msg}{hint}") from exc
            warnings.warn(f"model '{path}': {fix[2].format(name=name)}", ModelWarning, 2)


# ----------------------------------------------------------------------------- stage
STAGE_CAMERAS = {
    "front": (0.0, -15.0),
    "side": (-90.0, -15.0),
    "three_quarter": (-45.0, -25.0),
    "top": (0.0, -88.0),
}
"""The cameras a stage adds, by the names the bundled scenes use: (azimuth, elevation)
[deg] around the framed box, measured from the robot's forward direction
(``outputs/stage.py``: ``facing``): azimuth 0 looks at its front, -90 at its right side;
elevation < 0 looks down."""


def needs_stage(model: mujoco.MjModel) -> bool:
    """True when ``model`` lacks a light, a floor (a plane geom) or any of the
    :data:`STAGE_CAMERAS`: what the default stage (``outputs/stage.py``) would add."""
    has_floor = bool(np.any(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE))
    cams = set(model_cameras(model))
    return model.nlight == 0 or not has_floor or not set(STAGE_CAMERAS) <= cams


def staged_cameras(model: mujoco.MjModel) -> list[str]:
    """The cameras a film of ``model`` can use: its own, then those of
    :data:`STAGE_CAMERAS` the default stage adds (``outputs/stage.py``) where the
    model lacks one."""
    cams = model_cameras(model)
    if not needs_stage(model):
        return cams
    return cams + [c for c in STAGE_CAMERAS if c not in cams]


def home_qpos(model: mujoco.MjModel) -> NDArray[np.float64]:
    """A copy of the ``home`` keyframe's ``qpos`` ``(nq,)``, else of ``qpos0``."""
    kid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    return np.array(model.key_qpos[kid] if kid >= 0 else model.qpos0, dtype=np.float64)


def home_outside_ranges(model: mujoco.MjModel) -> list[tuple[str, float, float]]:
    """The limited hinges and slides whose home value (the ``home`` keyframe, else
    ``qpos0``) lies outside their range: ``(joint name, home value, the value moved
    inside)`` [rad or m], in model order.

    Solves, runs and renders start from the home pose moved inside the ranges
    (:meth:`Robot.reset <humanoid_ik.core.robot.Robot.reset>`, :attr:`Chain.q_home
    <humanoid_ik.core.chain.Chain.q_home>`): a start outside them is one no solver
    may return, so the nearest range end is taken.
    """
    home = home_qpos(model)
    out = []
    moving = (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in moving or not model.jnt_limited[j]:
            continue
        lo, hi = (float(v) for v in model.jnt_range[j])
        v = float(home[model.jnt_qposadr[j]])
        if not lo <= v <= hi:
            out.append((joint_name(model, j), v, min(max(v, lo), hi)))
    return out


def home_warning(model: mujoco.MjModel) -> str | None:
    """One line naming every joint whose home value lies outside its range, with the
    value and the range end every solve starts from instead (:func:`home_outside_ranges`),
    or ``None`` when the home pose is inside the ranges."""
    moved = home_outside_ranges(model)
    if not moved:
        return None
    keyed = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY) >= 0
    where = f"keyframe '{HOME_KEY}'" if keyed else "qpos0"
    each = ", ".join(f"'{n}' {v:+.4f} -> {c:+.4f}" for n, v, c in moved)
    return (
        f"the home pose ({where}) has {len(moved)} joint(s) outside their ranges; solves "
        f"start from it moved inside: {each} (rad, or m for slides)"
    )


def reset_to_home(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Reset ``data`` to the ``home`` keyframe (else to the model's defaults); no
    kinematics pass."""
    kid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    if kid >= 0:
        mujoco.mj_resetDataKeyframe(model, data, kid)
    else:
        mujoco.mj_resetData(model, data)


def model_cameras(model: mujoco.MjModel) -> list[str]:
    """Names of the model's cameras, in model order."""
    out = []
    for i in range(model.ncam):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i)
        if name:
            out.append(name)
    return out
