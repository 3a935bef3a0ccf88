"""The model layer: where the bundled files live, loading MJCF, and the ``home`` keyframe.

Every other module asks here for a model, the bundled folders and the home pose, so the
rule for each is written once.
"""

from __future__ import annotations

import math
import os
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.errors import ModelError

__all__ = [
    "BUNDLED_KINDS",
    "HOME_KEY",
    "bundled_dir",
    "bundled_model_path",
    "home_qpos",
    "STAGE_CAMERAS",
    "URDF_MIN_INERTIA",
    "URDF_MIN_MASS",
    "load_model",
    "model_cameras",
    "model_spec",
    "needs_stage",
    "reset_to_home",
    "staged_model",
    "staged_spec",
]

HOME_KEY = "home"
"""Name of the keyframe every run, solve and reset starts from (``qpos0`` without it)."""

_BUNDLED_PACKAGE = "humanoid_ik"
_BUNDLED_FOLDER = "_bundled"
_CHECKOUT_ROOT = Path(__file__).resolve().parents[3]
BUNDLED_KINDS = ("models", "scenes", "sweeps")
"""The bundled folders: the repository's top-level ``models/``, ``scenes/`` and
``sweeps/``, shipped in a wheel as ``humanoid_ik/_bundled/<kind>/`` (``setup.py``)."""


def _bundled_root() -> Path:
    """The folder holding the bundled ``models``/``scenes``/``sweeps``: the installed
    package's ``_bundled`` (through ``importlib.resources``), else the checkout's top
    level (an editable install).

    Raises:
        ModelError: the package is not installed as plain files (e.g. zipped), so MuJoCo
            could not open the models.
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
    """The folder of bundled ``models``, ``scenes`` or ``sweeps``.

    ``HUMANOID_IK_MODELS`` / ``HUMANOID_IK_SCENES`` / ``HUMANOID_IK_SWEEPS`` override it.

    Raises:
        ModelError: ``kind`` is not one of :data:`BUNDLED_KINDS`.
    """
    if kind not in BUNDLED_KINDS:
        raise ModelError(f"bundled folder '{kind}' unknown; folders: {', '.join(BUNDLED_KINDS)}")
    root = os.environ.get(f"HUMANOID_IK_{kind.upper()}")
    return Path(root) if root else _bundled_root() / kind


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


def load_model(model: mujoco.MjModel | str | os.PathLike | None) -> mujoco.MjModel:
    """An ``MjModel`` from a model, an MJCF or URDF path, or ``None`` for the bundled
    humanoid.

    A URDF (``.urdf``) is compiled by MuJoCo through :func:`model_spec`, which keeps
    links on fixed joints as bodies (a tool link can be the end effector), gives a link
    without mass a nominal one, and finds ``package://`` meshes beside the file.

    Raises:
        ModelError: the path does not exist, or MuJoCo cannot compile it (MuJoCo's
            message is kept, with the fix for the URDF mistakes it names).
    """
    if isinstance(model, mujoco.MjModel):
        return model
    path = _existing(model)
    if _is_urdf(path):
        return _compile(model_spec(path), path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc


URDF_MIN_MASS = 1e-6
"""Mass [kg] a URDF link gets when it has neither ``<inertial>`` nor geometry (MuJoCo
rejects massless moving bodies; inverse kinematics never uses masses)."""
URDF_MIN_INERTIA = 1e-9
"""Inertia [kg m^2] such a link gets, for the same reason."""


def _existing(model: str | os.PathLike | None) -> Path:
    path = bundled_model_path() if model is None else Path(model)
    if not path.is_file():
        raise ModelError(f"model file '{path}' does not exist")
    return path


def _is_urdf(path: Path) -> bool:
    return path.suffix.lower() == ".urdf"


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def model_spec(model: str | os.PathLike | None) -> mujoco.MjSpec:
    """The editable ``MjSpec`` of an MJCF or URDF file (``None``: the bundled humanoid).

    For a URDF, three things MuJoCo's URDF reader does by default are changed so a robot
    exported from ROS works as it is: links on fixed joints stay bodies
    (``fusestatic`` off: a ``tool_link`` stays nameable with ``--body``); a link with no
    ``<inertial>`` and no geometry gets :data:`URDF_MIN_MASS` (``boundmass``); a
    ``package://PKG/path`` mesh is looked up beside the URDF and one folder up.

    Raises:
        ModelError: the file does not exist or cannot be parsed.
    """
    path = _existing(model)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc
    if _is_urdf(path):
        spec.compiler.fusestatic = False
        spec.compiler.discardvisual = False  # else a stage's floor (no contacts) is dropped
        spec.compiler.boundmass = URDF_MIN_MASS
        spec.compiler.boundinertia = URDF_MIN_INERTIA
        for mesh in spec.meshes:
            mesh.file = _package_file(mesh.file, path.parent)
    return spec


def _package_file(name: str, folder: Path) -> str:
    """A ``package://PKG/rest`` (or ``package:/``) mesh name as a file beside the URDF or
    one folder up, when one exists; other names unchanged."""
    if not name.startswith("package:"):
        return name
    rest = name.split(":", 1)[1].lstrip("/").split("/", 1)[-1]
    for base in (folder, folder.parent):
        for candidate in (base / rest, base / Path(rest).name):
            if candidate.is_file():
                return str(candidate.resolve())
    return name


def _compile(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    """``spec`` compiled, a failure told in one line with its fix."""
    try:
        return spec.compile()
    except ValueError as exc:
        msg = _one_line(exc)
        hint = ""
        if "Error opening file" in msg or "resource not found" in msg.lower():
            hint = (
                "; put the mesh files beside the model (a package:// path is looked up "
                "beside it and one folder up), or set <compiler meshdir=...> (in a URDF: "
                '<mujoco><compiler meshdir="..."/></mujoco> inside <robot>)'
            )
        raise ModelError(f"model '{path}' does not compile: {msg}{hint}") from exc


# ----------------------------------------------------------------------------- stage
STAGE_CAMERAS = {
    "front": (0.0, -15.0),
    "side": (-90.0, -15.0),
    "three_quarter": (-45.0, -25.0),
    "top": (0.0, -88.0),
}
"""The cameras a stage adds, by the names the bundled scenes use: (azimuth, elevation)
[deg] around the framed box; azimuth 0 looks from +x, -90 from -y; elevation < 0 looks
down."""
_STAGE = "stage_"
_FOVY = 45.0


def needs_stage(model: mujoco.MjModel) -> bool:
    """True when ``model`` lacks a light, a floor (a plane geom) or any of the
    :data:`STAGE_CAMERAS`: what :func:`staged_model` would add."""
    has_floor = bool(np.any(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE))
    cams = set(model_cameras(model))
    return model.nlight == 0 or not has_floor or not set(STAGE_CAMERAS) <= cams


def staged_model(
    model: str | os.PathLike | None, points: ArrayLike | None = None
) -> mujoco.MjModel:
    """The model at ``model`` (MJCF or URDF) placed in a default stage where it lacks one.

    The rule: a model with a light, a floor and the cameras :data:`STAGE_CAMERAS` is
    returned as :func:`load_model` compiles it. Otherwise what is missing is added, and
    nothing else changes (no joint, so ``qpos`` and every chain are the same):

    - no light: a key light (directional, from the front right, casting shadows) and a
      fill light from the back left;
    - no plane geom: a checker floor under the lowest geom (no contacts), and a gradient
      skybox when the model has none;
    - each missing camera of :data:`STAGE_CAMERAS`: a camera looking at the centre of
      the box around the geoms at the ``home`` pose (and ``points``, e.g. a scene's
      targets), far enough for the box to fill the frame (``fovy`` 45 deg).

    Args:
        model: an MJCF or URDF path, ``None`` for the bundled humanoid.
        points: world points ``(k, 3)`` [m] the cameras must also frame.

    Raises:
        ModelError: as :func:`load_model`.
    """
    base = load_model(model)
    if not needs_stage(base):
        return base
    return _compile(staged_spec(model, points, base), _existing(model))


def staged_spec(
    model: str | os.PathLike | None,
    points: ArrayLike | None = None,
    compiled: mujoco.MjModel | None = None,
) -> mujoco.MjSpec:
    """The ``MjSpec`` of :func:`staged_model`, to edit further before compiling (e.g. to
    add mocap bodies); what the stage adds follows the same rule.

    Args:
        model, points: as :func:`staged_model`.
        compiled: the model already compiled from ``model`` (compiled here when ``None``).

    Raises:
        ModelError: as :func:`load_model`.
    """
    base = load_model(model) if compiled is None else compiled
    spec = model_spec(model)
    if not needs_stage(base):
        return spec
    lo, hi = _framed_box(base, points)
    world = spec.worldbody
    if base.nlight == 0:
        _add_lights(world, lo, hi)
    if not np.any(base.geom_type == mujoco.mjtGeom.mjGEOM_PLANE):
        _add_floor(spec, base, lo, hi)
    have = set(model_cameras(base))
    for name, (azimuth, elevation) in STAGE_CAMERAS.items():
        if name not in have:
            _add_camera(world, name, lo, hi, azimuth, elevation)
    return spec


def _framed_box(
    model: mujoco.MjModel, points: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Corners of the world box around every non-plane geom at the ``home`` pose, and
    ``points``."""
    data = mujoco.MjData(model)
    reset_to_home(model, data)
    mujoco.mj_kinematics(model, data)
    corners = [np.zeros((0, 3))]
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    for g in range(model.ngeom):
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = center + signs * half  # (8, 3) in the geom frame
        R = data.geom_xmat[g].reshape(3, 3)
        corners.append(data.geom_xpos[g] + local @ R.T)
    if points is not None:
        corners.append(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    allpts = np.concatenate(corners)
    if not len(allpts):
        allpts = np.zeros((1, 3))
    return allpts.min(axis=0), allpts.max(axis=0)


def _add_lights(world: mujoco.MjsBody, lo: NDArray, hi: NDArray) -> None:
    center, size = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)), 0.5)
    key = world.add_light(name=f"{_STAGE}key", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    key.pos = center + size * np.array([1.0, -0.8, 1.5])
    key.dir = np.array([-0.5, 0.4, -1.0])
    key.diffuse = [0.7, 0.7, 0.7]
    key.specular = [0.2, 0.2, 0.2]
    key.castshadow = True
    fill = world.add_light(name=f"{_STAGE}fill", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    fill.pos = center + size * np.array([-1.0, 1.2, 1.2])
    fill.dir = np.array([0.5, -0.6, -0.8])
    fill.diffuse = [0.3, 0.3, 0.3]
    fill.specular = [0.0, 0.0, 0.0]
    fill.castshadow = False


def _add_floor(spec: mujoco.MjSpec, model: mujoco.MjModel, lo: NDArray, hi: NDArray) -> None:
    has_skybox = any(
        int(t) == int(mujoco.mjtTexture.mjTEXTURE_SKYBOX) for t in model.tex_type[: model.ntex]
    )
    if not has_skybox:
        spec.add_texture(
            name=f"{_STAGE}sky",
            type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
            rgb1=[0.35, 0.45, 0.6],
            rgb2=[0.05, 0.05, 0.1],
            width=256,
            height=1536,
        )
    spec.add_texture(
        name=f"{_STAGE}floor",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        mark=mujoco.mjtMark.mjMARK_EDGE,
        rgb1=[0.22, 0.26, 0.3],
        rgb2=[0.12, 0.15, 0.18],
        markrgb=[0.8, 0.8, 0.8],
        width=300,
        height=300,
    )
    mat = spec.add_material(name=f"{_STAGE}floor", texuniform=True, texrepeat=[5, 5])
    mat.reflectance = 0.1
    mat.textures[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = f"{_STAGE}floor"
    center = (lo + hi) / 2
    spec.worldbody.add_geom(
        name=f"{_STAGE}floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0, 0, 0.05],
        pos=[center[0], center[1], lo[2]],
        material=f"{_STAGE}floor",
        contype=0,
        conaffinity=0,
    )


def _add_camera(
    world: mujoco.MjsBody,
    name: str,
    lo: NDArray,
    hi: NDArray,
    azimuth: float,
    elevation: float,
) -> None:
    """A camera at ``(azimuth, elevation)`` from the box's centre, at the distance where
    the box's bounding sphere fills the vertical field of view."""
    center = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 0.05)
    distance = 1.05 * radius / math.sin(math.radians(_FOVY / 2))
    az, el = math.radians(azimuth), math.radians(elevation)
    # from the centre to the camera (azimuth 0: on +x, -90: on -y; counterclockwise)
    back = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)])
    x_axis = np.array([-math.sin(az), math.cos(az), 0.0])  # right in the image
    y_axis = np.cross(back, x_axis)  # up in the image
    world.add_camera(
        name=name,
        pos=center + distance * back,
        xyaxes=[*x_axis, *(y_axis / np.linalg.norm(y_axis))],
        fovy=_FOVY,
    )


def home_qpos(model: mujoco.MjModel) -> NDArray[np.float64]:
    """A copy of the ``home`` keyframe's ``qpos`` ``(nq,)``, else of ``qpos0``."""
    kid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    return np.array(model.key_qpos[kid] if kid >= 0 else model.qpos0, dtype=np.float64)


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
