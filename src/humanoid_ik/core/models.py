"""The model layer: where the bundled files live, loading MJCF, and the ``home`` keyframe.

Every other module asks here for a model, the bundled folders and the home pose, so the
rule for each is written once.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

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
    "compile_spec",
    "model_cameras",
    "model_file",
    "model_spec",
    "needs_stage",
    "reset_to_home",
    "staged_cameras",
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
    path = model_file(model)
    if _is_urdf(path):
        return compile_spec(model_spec(path), path)
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        raise ModelError(f"model '{path}' does not compile: {_one_line(exc)}") from exc


URDF_MIN_MASS = 1e-6
"""Mass [kg] a URDF link gets when it has neither ``<inertial>`` nor geometry (MuJoCo
rejects massless moving bodies; inverse kinematics never uses masses)."""
URDF_MIN_INERTIA = 1e-9
"""Inertia [kg m^2] such a link gets, for the same reason."""


def model_file(model: str | os.PathLike | None) -> Path:
    """The model file's path (the bundled humanoid's for ``None``).

    Raises:
        ModelError: there is no such file.
    """
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
    path = model_file(model)
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


def compile_spec(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    """``spec`` (of the model file ``path``) compiled, a failure told in one line with
    its fix.

    Raises:
        ModelError: MuJoCo cannot compile it.
    """
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
