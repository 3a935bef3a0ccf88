"""The default stage: lights, a floor and cameras for filming a model that lacks them.

A URDF or a bare MJCF arm has no light, no floor and no camera; a film of it gets a
stage here. The stage is the rendering layer's alone: the solvers and the runner work
on the model as the user gave it, and the renderer films a staged copy whose ``qpos``
is the run's (the stage adds no joint, so ``qpos`` and every chain are the same).

The cameras face the robot and frame what the film shows:

- **Facing.** The robot's forward direction is :func:`facing`: the limb profile's
  (:attr:`~humanoid_ik.core.limbs.Profile.forward`, the one scene placements use) when
  it found one (from the two arms' sides, or a profile file), else a cue from the
  chains filmed: the side toward which they reach (the mean of their sampled
  end-effector positions, :meth:`~humanoid_ik.core.chain.Chain.reach_mean`), else the
  side their effectors are on at home, else the side of the targets, else +x. The azimuths of
  :data:`~humanoid_ik.core.models.STAGE_CAMERAS` are measured from it: ``front`` looks
  at the robot's front, ``side`` at its right, ``three_quarter`` from front right.
- **Framing.** Each camera keeps its direction and is placed as close as it can be with
  every framed point inside the middle :data:`FILL` of the frame's width and height
  (a closed-form fit of the pinhole frustum): points on the surface of every drawn geom
  (its extreme points along 64 directions: a mesh's vertices, a primitive's exact
  shape; not the corners of its bounding box, which stick far out of a rotated or
  rounded shape) at each pose of a run (at the home pose without a run: the home pose
  is not filmed, frame 0 is already solved), and the given points (every frame's
  targets and effectors). :func:`trajectory_stage` takes all of them from a run. The
  robot and its targets then span :data:`FILL` of the frame over the run (G1, Talos,
  iCub 89-90 % of the height in every frame); an arm that folds and unfolds fills less
  in its folded frames.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.config.placement import effector_chain
from humanoid_ik.config.specs import EffectorSpec
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.limbs import Profile, profile_for
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
from humanoid_ik.core.robot import Robot
from humanoid_ik.run.trajectory import Trajectory

__all__ = [
    "FACING_MIN",
    "FILL",
    "facing",
    "staged_model",
    "staged_spec",
    "trajectory_chains",
    "trajectory_stage",
]

_STAGE = "stage_"
_FOVY = 45.0
FILL = 0.9
"""The framed points fill at most this fraction of a stage camera's width and height."""
FACING_MIN = 0.05
"""A facing cue counts when it is at least this fraction of the chains' reach."""
_MAX_POSES = 300  # a longer run's poses are thinned to this many, evenly spread
_SIDES = 64  # directions whose extreme points outline a geom (:func:`_outline`)


def staged_model(
    model: str | os.PathLike | None,
    points: ArrayLike | None = None,
    *,
    poses: ArrayLike | None = None,
    chains: Sequence[Chain] = (),
    aspect: float = 4 / 3,
    packages: Mapping[str, Path] | None = None,
) -> mujoco.MjModel:
    """The model at ``model`` (MJCF or URDF) placed in a default stage where it lacks one.

    The rule: a model with a light, a floor and the cameras :data:`STAGE_CAMERAS` is
    returned as :func:`load_model` compiles it. Otherwise what is missing is added, and
    nothing else changes (no joint, so ``qpos`` and every chain are the same):

    - no light: a key light (directional, from the robot's front right, casting
      shadows) and a fill light from its back left;
    - no plane geom: a checker floor under the lowest framed point (no contacts), and
      a gradient skybox when the model has none;
    - each missing camera of :data:`STAGE_CAMERAS`: facing the robot (:func:`facing`
      of ``chains`` and ``points``) and framing the drawn geoms at each of ``poses``
      (at the ``home`` pose without any), and ``points`` (``fovy`` 45 deg, see the
      module's rules).

    Args:
        model: an MJCF or URDF path, ``None`` for the bundled humanoid.
        points: world points ``(k, 3)`` [m] the cameras must also frame (targets...).
        poses: full ``qpos`` vectors ``(F, nq)`` whose geoms the cameras frame (a run's
            frames; ``None``: the ``home`` pose).
        chains: the chains filmed (on this model), for the robot's facing.
        aspect: the frame's width / height.
        packages: ROS package folders for a URDF's ``package://`` paths (as
            :func:`load_model`).

    Raises:
        ModelError: as :func:`load_model`.
    """
    base = load_model(model, packages=packages)
    if not needs_stage(base):
        return base
    spec = staged_spec(
        model, points, base, poses=poses, chains=chains, aspect=aspect, packages=packages
    )
    return compile_spec(spec, model_file(model))


def staged_spec(
    model: str | os.PathLike | None,
    points: ArrayLike | None = None,
    compiled: mujoco.MjModel | None = None,
    *,
    poses: ArrayLike | None = None,
    chains: Sequence[Chain] = (),
    aspect: float = 4 / 3,
    packages: Mapping[str, Path] | None = None,
) -> mujoco.MjSpec:
    """The ``MjSpec`` of :func:`staged_model`, to edit further before compiling (e.g. to
    add mocap bodies); what the stage adds follows the same rule.

    Args:
        model, points, poses, chains, aspect, packages: as :func:`staged_model`.
        compiled: the model already compiled from ``model`` (compiled here when ``None``).

    Raises:
        ModelError: as :func:`load_model`.
    """
    base = load_model(model, packages=packages) if compiled is None else compiled
    spec = model_spec(model, packages=packages)
    if not needs_stage(base):
        return spec
    pts = _framed_points(base, points, poses)
    lo, hi = pts.min(axis=1), pts.max(axis=1)
    forward = facing(chains, points, profile_for(base, model_file(model)))
    world = spec.worldbody
    if base.nlight == 0:
        _add_lights(world, lo, hi, forward)
    if not np.any(base.geom_type == mujoco.mjtGeom.mjGEOM_PLANE):
        _add_floor(spec, base, lo, hi)
    have = set(model_cameras(base))
    heading = math.degrees(math.atan2(forward[1], forward[0]))
    for name, (azimuth, elevation) in STAGE_CAMERAS.items():
        if name not in have:
            pos, xyaxes = _camera_pose(pts, heading + azimuth, elevation, aspect)
            world.add_camera(name=name, pos=pos, xyaxes=xyaxes, fovy=_FOVY)
    return spec


def trajectory_stage(
    model: str | os.PathLike,
    trajectory: Trajectory,
    aspect: float = 4 / 3,
    compiled: mujoco.MjModel | None = None,
    packages: Mapping[str, Path] | None = None,
) -> mujoco.MjModel:
    """The staged model to film ``trajectory`` (a run's, or one read from a file): facing
    the robot its effectors' chains belong to, framing every frame's pose, target and
    effector position and the trajectory's ``stage_points`` (:func:`staged_model`).

    Args:
        model: the model file the trajectory was recorded on.
        trajectory: the frames to film.
        aspect: the frame's width / height.
        compiled: the model already compiled from ``model`` (compiled here when ``None``).
        packages: as :func:`staged_model`.

    Raises:
        ModelError: as :func:`load_model`.
        NameNotFoundError, ChainError: an effector does not fit the model.
    """
    base = load_model(model, packages=packages) if compiled is None else compiled
    if not needs_stage(base):
        return base
    chains = trajectory_chains(base, trajectory)
    points = [trajectory.stage_points] + [e.target for e in trajectory.effectors]
    points += [e.achieved for e in trajectory.effectors if e.task == "reach"]
    pts = np.concatenate([np.asarray(p, dtype=np.float64).reshape(-1, 3) for p in points])
    spec = staged_spec(
        model, pts, base, poses=trajectory.qpos, chains=chains, aspect=aspect, packages=packages
    )

    return compile_spec(spec, model_file(model))


def trajectory_chains(
    model: mujoco.MjModel, trajectory: Trajectory, task: str | None = None
) -> list[Chain]:
    """The chains of ``trajectory``'s effectors on ``model`` (one robot state), those of
    ``task`` only when it is given (``reach``, ``look_at``).

    Raises:
        NameNotFoundError, ChainError: an effector does not fit the model.
    """
    robot = Robot(model)
    out = []
    for e in trajectory.effectors:
        if task is not None and e.task != task:
            continue
        # a file from before effectors kept their kind says "site" for a body too
        site = e.kind == "site" and mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, e.site) >= 0
        spec = EffectorSpec(
            e.site if site else None,
            e.target_name,
            e.task,
            e.joints,
            body=None if site else e.site,
        )
        out.append(effector_chain(robot, spec))
    return out


def facing(
    chains: Sequence[Chain] = (),
    points: ArrayLike | None = None,
    profile: Profile | None = None,
) -> NDArray[np.float64]:
    """The robot's forward direction: a horizontal unit vector ``(3,)``.

    ``profile``'s :attr:`~humanoid_ik.core.limbs.Profile.forward` when it found one
    (``forward_from``: the arms' sides or a profile file), as scene placements take it.
    Else the first cue at least :data:`FACING_MIN` of the chains' summed reach long, in
    the horizontal plane, gives it:

    1. the side toward which the chains reach: the sum of their
       :meth:`~humanoid_ik.core.chain.Chain.reach_mean` (an arm's elbow and shoulder
       reach forward more than back; a turntable base or a yawing waist reaches all
       round and gives no cue);
    2. the side their end effectors are on at home: the sum of effector minus base;
    3. the side ``points`` (a scene's targets) are on, from the chains' mean base (the
       origin without chains).

    Without any, +x (the forward axis of a ROS robot's base).

    Args:
        chains: the chains filmed; each is left as it was.
        points: world points ``(k, 3)`` [m].
        profile: the model's limbs (:func:`~humanoid_ik.core.limbs.profile_for`).
    """
    if profile is not None and profile.forward_from:
        flat = np.array([profile.forward[0], profile.forward[1], 0.0])
        if float(np.linalg.norm(flat)) > 0:
            return flat / np.linalg.norm(flat)
    scale = sum(c.reach()[1] for c in chains) or 1.0
    cues = [sum((c.reach_mean() for c in chains), np.zeros(3))]
    home = np.zeros(3)
    for c in chains:
        keep = c.q
        p, _ = c.fk(c.q_home)
        home += p - c.base
        c.set_q(keep)
    cues.append(home)
    if points is not None and len(np.asarray(points).reshape(-1, 3)):
        origin = np.mean([c.base for c in chains], axis=0) if chains else np.zeros(3)
        cues.append(np.asarray(points, dtype=np.float64).reshape(-1, 3).mean(axis=0) - origin)
    for cue in cues:
        flat = np.array([cue[0], cue[1], 0.0])
        length = float(np.linalg.norm(flat))
        if length >= FACING_MIN * scale:
            return flat / length
    return np.array([1.0, 0.0, 0.0])


def _framed_points(
    model: mujoco.MjModel, points: ArrayLike | None, poses: ArrayLike | None
) -> NDArray[np.float64]:
    """The outline points of every drawn non-plane geom (:func:`_outline`) at each of
    ``poses`` (at the ``home`` pose without any), and ``points``: ``(3, k)``, one row per
    axis (a reduction along the long axis of a ``(k, 3)`` array is slow)."""
    data = mujoco.MjData(model)
    reset_to_home(model, data)
    drawn = np.flatnonzero(
        (model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
        & (model.geom_group < 3)  # the groups a film draws
        & (model.geom_rgba[:, 3] > 0)
    )
    local = _outline(model, drawn)
    qs = [data.qpos.copy()]
    arr = np.zeros((0, model.nq)) if poses is None else np.asarray(poses, dtype=np.float64)
    arr = arr.reshape(-1, model.nq) if model.nq else np.zeros((len(arr), 0))
    if len(arr):  # the poses filmed (the home pose is not one of them: frame 0 is solved)
        step = max(1, math.ceil(len(arr) / _MAX_POSES))
        qs = list(arr[::step]) + [arr[-1]]
    out = [np.zeros((0, 3))]
    for q in qs:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        R = data.geom_xmat[drawn].reshape(-1, 3, 3)
        out.append((data.geom_xpos[drawn, None] + local @ R.transpose(0, 2, 1)).reshape(-1, 3))
    if points is not None:
        out.append(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    pts = np.concatenate(out)
    return np.ascontiguousarray(pts.T) if len(pts) else np.zeros((3, 1))


def _outline(model: mujoco.MjModel, geoms: NDArray[np.intp]) -> NDArray[np.float64]:
    """Points ``(len(geoms), _SIDES, 3)`` on each geom's surface, in its frame: its
    extreme point along each of :data:`_SIDES` directions spread over the sphere (a
    mesh's farthest vertex, a primitive's exact support point; a box's corners).

    They outline the geom as it is drawn: the corners of its bounding box stick out far
    beyond a rotated or rounded shape (a robot framed on them fills much less of the
    frame than it could), and the directions are close enough (about 25 degrees apart)
    that the outline misses little of what a camera sees."""
    k = np.arange(_SIDES) + 0.5  # a Fibonacci sphere
    z = 1 - 2 * k / _SIDES
    phi = math.pi * (3 - math.sqrt(5)) * k
    u = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    ez = np.array([0.0, 0.0, 1.0])
    flat = u * [1.0, 1.0, 0.0]
    flat /= np.maximum(np.linalg.norm(flat, axis=1, keepdims=True), 1e-12)
    G = mujoco.mjtGeom
    out = np.zeros((len(geoms), _SIDES, 3))
    for i, g in enumerate(geoms):
        t, size = int(model.geom_type[g]), model.geom_size[g]
        if t == G.mjGEOM_MESH and int(model.geom_dataid[g]) >= 0:
            m = int(model.geom_dataid[g])
            adr, n = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
            vert = model.mesh_vert[adr : adr + n].astype(np.float64)
            out[i] = vert[np.argmax(vert @ u.T, axis=0)]
        elif t == G.mjGEOM_SPHERE:
            out[i] = size[0] * u
        elif t == G.mjGEOM_CAPSULE:
            out[i] = size[0] * u + np.sign(u[:, 2:]) * size[1] * ez
        elif t == G.mjGEOM_CYLINDER:
            out[i] = size[0] * flat + np.sign(u[:, 2:]) * size[1] * ez
        elif t == G.mjGEOM_ELLIPSOID:
            out[i] = size**2 * u / np.linalg.norm(size * u, axis=1, keepdims=True)
        else:  # a box (its corners), a height field, an SDF: the box around it
            box = model.geom_aabb[g]
            out[i] = box[:3] + np.sign(u) * box[3:]
    return out


def _camera_pose(
    pts: NDArray[np.float64], azimuth: float, elevation: float, aspect: float
) -> tuple[NDArray[np.float64], list[float]]:
    """Position and ``xyaxes`` of a camera looking from ``(azimuth, elevation)`` [deg]
    (azimuth 0 on +x, counterclockwise; elevation < 0 looks down) as close as it can be
    with every point of ``pts`` ``(3, k)`` inside the middle :data:`FILL` of its frame.

    With the camera's right ``r``, up ``u`` and backward ``b`` axes, a point at offset
    ``x, y`` (along ``r``, ``u``) and depth offset ``d = -b . (p - c0)`` from the
    centre ``c0`` is at depth ``D + d`` from a camera at ``c0 + s_x r + s_y u + D b``,
    and in the frame when ``|x - s_x| <= a (D + d)`` (``a = FILL tan(fovy / 2)``, times
    ``aspect`` across). The closest such camera has ``D = (max(x - a d) - min(x + a d))
    / 2a`` (the larger of the two axes') and ``s_x = (max(x - a d) + min(x + a d)) / 2``.
    """
    az, el = math.radians(azimuth), math.radians(elevation)
    back = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)])
    right = np.array([-math.sin(az), math.cos(az), 0.0])
    up = np.cross(back, right)
    up /= np.linalg.norm(up)
    lo, hi = pts.min(axis=1), pts.max(axis=1)
    c0 = (lo + hi) / 2
    d = c0 @ back - back @ pts
    half = math.tan(math.radians(_FOVY / 2)) * FILL
    shifts, dist = [], 0.0
    for axis, a in ((right, half * aspect), (up, half)):
        x = axis @ pts - c0 @ axis
        far, near = float(np.max(x - a * d)), float(np.min(x + a * d))
        shifts.append((far + near) / 2)
        dist = max(dist, (far - near) / (2 * a))
    size = float(np.linalg.norm(hi - lo))
    dist = max(dist, float(-d.min()) + 0.05 * max(size, 0.1))  # never inside the points
    pos = c0 + shifts[0] * right + shifts[1] * up + dist * back
    return pos, [*right, *up]


def _add_lights(world: mujoco.MjsBody, lo: NDArray, hi: NDArray, forward: NDArray) -> None:
    """A key light from the robot's front right and a fill light from its back left."""
    center, size = (lo + hi) / 2, max(float(np.linalg.norm(hi - lo)), 0.5)
    left = np.cross([0.0, 0.0, 1.0], forward)
    frame = np.array([forward, left, [0.0, 0.0, 1.0]]).T  # robot (front, left, up) -> world
    key = world.add_light(name=f"{_STAGE}key", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    key.pos = center + size * frame @ np.array([1.0, -0.8, 1.5])
    key.dir = frame @ np.array([-0.5, 0.4, -1.0])
    key.diffuse = [0.7, 0.7, 0.7]
    key.specular = [0.2, 0.2, 0.2]
    key.castshadow = True
    fill = world.add_light(name=f"{_STAGE}fill", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    fill.pos = center + size * frame @ np.array([-1.0, 1.2, 1.2])
    fill.dir = frame @ np.array([0.5, -0.6, -0.8])
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
