"""The model layer: where the bundled files live, loading MJCF, and the ``home`` keyframe.

Every other module asks here for a model, the bundled folders and the home pose, so the
rule for each is written once.
"""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import ModelError

__all__ = [
    "HOME_KEY",
    "bundled_dir",
    "bundled_model_path",
    "home_qpos",
    "load_model",
    "model_cameras",
    "reset_to_home",
]

HOME_KEY = "home"
"""Name of the keyframe every run, solve and reset starts from (``qpos0`` without it)."""

_PROJECT_ROOT = Path(__file__).resolve().parents[3]


def bundled_dir(kind: str) -> Path:
    """The folder of bundled ``models`` or ``scenes``.

    ``HUMANOID_IK_MODELS`` / ``HUMANOID_IK_SCENES`` override it.
    """
    root = os.environ.get(f"HUMANOID_IK_{kind.upper()}")
    return Path(root) if root else _PROJECT_ROOT / kind


def bundled_model_path() -> Path:
    """Path of the bundled humanoid scene (``models/humanoid/scene.xml``)."""
    return bundled_dir("models") / "humanoid" / "scene.xml"


def display_model(model: str | os.PathLike | None) -> str:
    """How reports name a model: ``None`` is the bundled humanoid, shown relative to the
    project (``models/humanoid/scene.xml``); a path is shown as given."""
    if model is not None:
        return str(model)
    path = bundled_model_path()
    try:
        return str(path.resolve().relative_to(_PROJECT_ROOT))
    except ValueError:
        return path.name


def load_model(model: mujoco.MjModel | str | os.PathLike | None) -> mujoco.MjModel:
    """An ``MjModel`` from a model, an MJCF path, or ``None`` for the bundled humanoid.

    Raises:
        ModelError: the path does not exist, or MuJoCo cannot compile it (MuJoCo's
            message is kept).
    """
    if isinstance(model, mujoco.MjModel):
        return model
    path = bundled_model_path() if model is None else Path(model)
    if not path.is_file():
        raise ModelError(f"model file '{path}' does not exist")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        msg = " ".join(str(exc).split())
        raise ModelError(f"model '{path}' does not compile: {msg}") from exc


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
