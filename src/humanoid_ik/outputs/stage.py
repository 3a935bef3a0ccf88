"""The default stage: lights, a floor and cameras for filming a model that lacks them.

A URDF or a bare MJCF arm has no light, no floor and no camera; a film of it gets a
stage here. The stage is the rendering layer's alone: the solvers and the runner work
on the model as the user gave it, and the renderer films a staged copy whose ``qpos``
is the run's (the stage adds no joint, so ``qpos`` and every chain are the same).
"""

from __future__ import annotations

import math
import os

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.models import (
    STAGE_CAMERAS,
    compile_spec,
    load_model,
    model_cameras,
    model_file,
    model_spec,
    needs_stage,
    reset_to_home,
)

__all__ = ["staged_model", "staged_spec"]

_STAGE = "stage_"
_FOVY = 45.0


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
    return compile_spec(staged_spec(model, points, base), model_file(model))


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
