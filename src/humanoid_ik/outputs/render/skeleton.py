"""A film of a retargeted motion: the robot replaying its trajectory with the human it
copies drawn beside it, a skeleton of capsules from each BVH joint to its children and
spheres at the joints, in the same film pipeline as any replay (video, PNG snapshots,
contact sheet, GIF).

The human is placed as the retargeting maps it (:func:`human_skeleton`): scaled by the
ratio of the arm lengths about the midpoint of its shoulders, that midpoint put on the
robot's, turned each frame so that its heading (from its thighs or shoulders) is the
robot's forward. :func:`beside_robot` then moves it sideways, to the robot's right, by
the least distance that keeps every frame's skeleton clear of every frame's robot (and
a gap): side by side, both are seen whole and move together, facing the same way, as a
dancer and a mirror. Overlaid at the robot's shoulders (the skeleton as
:func:`human_skeleton` returns it) the capsules pass through the robot's geoms and hide
each other where the proportions differ (G1's arm is two thirds of the human's, its
torso narrower): the pose is harder to read than beside it.

Only plain arrays come in (the skeleton's world positions ``(F, J, 3)`` and parents
``(J,)``): the retargeting that computed them is in ``experiments/``, above this layer.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.models import needs_stage, reset_to_home
from humanoid_ik.core.names import check_name
from humanoid_ik.errors import MotionError, TrajectoryFileError
from humanoid_ik.outputs.render.drawing import (
    FrameRenderer,
    camera_id,
    project,
)
from humanoid_ik.outputs.render.pipeline import FilmOutputs, film_trajectory
from humanoid_ik.outputs.stage import FILL, trajectory_stage
from humanoid_ik.run.metrics import FrameSamples
from humanoid_ik.run.trajectory import Trajectory

__all__ = [
    "BONE_RADIUS",
    "SKELETON_RGBA",
    "SkeletonRenderer",
    "beside_robot",
    "bone_radius",
    "chain_length",
    "film_with_skeleton",
    "human_skeleton",
]

SKELETON_RGBA = (0.6, 0.3, 1.0, 1.0)
"""The skeleton's colour (violet: no robot, floor, sky, marker or trail of a film has it)."""
BONE_RADIUS = 0.012
"""A bone's radius as a fraction of the skeleton's height (2 cm for a 1.7 m human); the
joints' spheres are 1.6 times as wide."""
_JOINT = 1.6
_UP = np.array([0.0, 0.0, 1.0])
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
_MAX_POSES = 100  # the poses whose geoms bound the robot (a longer run is thinned)


def chain_length(points: ArrayLike, nodes: Sequence[int]) -> float:
    """The length [m] of the polyline through ``points[nodes]`` (``points`` ``(J, 3)``):
    an arm's length as shoulder, elbow, wrist, hand point."""
    p = np.asarray(points, dtype=np.float64)[list(nodes)]
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _frame(forward: ArrayLike) -> NDArray[np.float64]:
    """``(3, 3)``: columns forward (made horizontal, unit), left, up."""
    f = np.asarray(forward, dtype=np.float64).reshape(3).copy()
    f[2] = 0.0
    if float(np.linalg.norm(f)) < 1e-9:
        raise MotionError("forward", "a direction with a horizontal part", forward)
    f = _unit(f)
    return np.stack([f, np.cross(_UP, f), _UP], axis=1)


def human_skeleton(
    positions: ArrayLike,
    *,
    shoulders: Sequence[int],
    human_arm: float,
    robot_shoulders: ArrayLike,
    robot_arm: float,
    forward: ArrayLike,
    heading_pair: tuple[int, int] | None = None,
) -> NDArray[np.float64]:
    """The human's joints placed on the robot as the retargeting maps them, ``(F, J, 3)``.

    Per frame ``f``: ``X_f = A + s M_f (P_f - S_f)``, with ``P_f`` every joint's world
    position, ``S_f`` the midpoint of the shoulders, ``s = robot_arm / human_arm``,
    ``A`` the robot's shoulders' midpoint, and ``M_f`` the turn about the vertical that
    takes the human's heading (forward = left x up, left along the horizontal line from
    the right to the left node of ``heading_pair``) to the robot's ``forward``. The
    human's steps and turns are so taken out, as the retargeting takes them out of the
    hands' targets: the skeleton stays at the robot's shoulders, facing its way.

    Args:
        positions: the human's joints ``(F, J, 3)`` [m, Z up] (``BVHClip.positions``).
        shoulders: the shoulder nodes (the upper arms' joints) of the mapped arms: left
            and right, or the one of a one-armed mapping.
        human_arm: the human's arm length [m] (shoulder, elbow, wrist, hand point:
            :func:`chain_length` at rest).
        robot_shoulders: the robot's shoulder points ``(k, 3)`` [m] (the same arms'); their
            mean is ``A``.
        robot_arm: the robot's arm length [m].
        forward: the robot's forward direction ``(3,)`` (made horizontal).
        heading_pair: the left and right nodes whose line gives the human's heading
            (its thighs; default the two shoulders).

    Raises:
        MotionError: a bad shape, length or node index (named, with what was given).
    """
    P = np.asarray(positions, dtype=np.float64)
    if P.ndim != 3 or P.shape[2] != 3 or P.shape[0] < 1:
        raise MotionError("positions", "an array (frames, joints, 3)", f"shape {P.shape}")
    J = P.shape[1]
    shoulders = tuple(int(i) for i in shoulders)
    if not (1 <= len(set(shoulders)) == len(shoulders) <= 2 and all(0 <= i < J for i in shoulders)):
        raise MotionError(
            "shoulders", f"one or two different node indices from 0 to {J - 1}", shoulders
        )
    pair = shoulders if heading_pair is None else heading_pair
    if len(pair) != 2 or not all(0 <= int(i) < J for i in pair) or pair[0] == pair[1]:
        raise MotionError("heading_pair", f"two different node indices from 0 to {J - 1}", pair)
    for what, v in (("human_arm", human_arm), ("robot_arm", robot_arm)):
        if not (math.isfinite(float(v)) and float(v) > 0):
            raise MotionError(what, "a length > 0 [m]", v)
    anchor = np.asarray(robot_shoulders, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    left = P[:, pair[0]] - P[:, pair[1]]
    left[:, 2] = 0.0
    left = _unit(left)
    up = np.broadcast_to(_UP, left.shape)
    human = np.stack([np.cross(left, up), left, up], axis=2)  # (F, 3, 3) forward, left, up
    M = _frame(forward)[None] @ np.transpose(human, (0, 2, 1))
    mid = P[:, list(shoulders)].mean(axis=1)
    s = float(robot_arm) / float(human_arm)
    return anchor + s * np.einsum("fij,fkj->fki", M, P - mid[:, None])


def _robot_points(model: mujoco.MjModel, qpos: NDArray[np.float64]) -> NDArray[np.float64]:
    """The corners ``(k, 3)`` of every drawn non-plane geom's box at (up to
    :data:`_MAX_POSES` of) the poses ``qpos`` ``(F, nq)``."""
    data = mujoco.MjData(model)
    reset_to_home(model, data)
    drawn = np.flatnonzero(
        (model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
        & (model.geom_group < 3)
        & (model.geom_rgba[:, 3] > 0)
        & (model.geom_bodyid > 0)  # not the world's stand, walls or table
    )
    local = model.geom_aabb[drawn, None, :3] + _CORNERS * model.geom_aabb[drawn, None, 3:]
    step = max(1, math.ceil(len(qpos) / _MAX_POSES))
    out = [np.zeros((0, 3))]
    for q in [*qpos[::step], qpos[-1]]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        R = data.geom_xmat[drawn].reshape(-1, 3, 3)
        out.append((data.geom_xpos[drawn, None] + local @ R.transpose(0, 2, 1)).reshape(-1, 3))
    return np.concatenate(out)


def bone_radius(skeleton: ArrayLike) -> float:
    """A bone's radius [m]: :data:`BONE_RADIUS` of the skeleton's height in its first
    frame (its extent along z)."""
    z = np.asarray(skeleton, dtype=np.float64)[0, :, 2]
    return BONE_RADIUS * max(float(np.ptp(z)), 0.1)


def beside_robot(
    skeleton: ArrayLike,
    model: mujoco.MjModel,
    qpos: ArrayLike,
    forward: ArrayLike,
    gap: float | None = None,
) -> NDArray[np.float64]:
    """``skeleton`` ``(F, J, 3)`` moved to the robot's right (along ``-left``) by the least
    distance that keeps it, in every frame, ``gap`` clear of the robot in every frame.

    The robot is the box corners of its drawn geoms (not the world's: a stand or a
    table) at the poses ``qpos`` ``(F, nq)``; the skeleton's extent includes its joints'
    spheres. The distance is one for the whole film, so the skeleton does not jump.

    Args:
        skeleton: world positions, e.g. from :func:`human_skeleton`.
        model: the robot's model.
        qpos: its poses.
        forward: the robot's forward direction.
        gap: the space left between them [m] (default: a tenth of the robot's height).
    """
    X = np.asarray(skeleton, dtype=np.float64)
    left = _frame(forward)[:, 1]
    robot = _robot_points(model, np.asarray(qpos, dtype=np.float64).reshape(-1, model.nq))
    if gap is None:
        gap = 0.1 * max(float(np.ptp(robot[:, 2])) if len(robot) else 0.0, 0.5)
    nearest = float((robot @ left).min()) if len(robot) else float((X @ left).min())
    reach = float((X @ left).max()) + _JOINT * bone_radius(X)
    return X + (nearest - gap - reach) * left


class SkeletonRenderer(FrameRenderer):
    """A :class:`~humanoid_ik.outputs.render.drawing.FrameRenderer` that also draws the
    human skeleton of each frame: a capsule from every joint to each child (bones of
    zero length left out), a sphere at every joint.

    Args:
        model, width, height, camera, trail, marker: as ``FrameRenderer``.
        skeleton: world positions ``(F, J, 3)`` [m]; frame ``frame.index`` is drawn.
        parents: each joint's parent ``(J,)`` (``-1`` for the root).
        radius: a bone's radius [m].
        rgba: its colour.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        camera: str,
        trail: int,
        marker: float,
        skeleton: NDArray[np.float64],
        parents: Sequence[int],
        radius: float,
        rgba: tuple[float, float, float, float] = SKELETON_RGBA,
    ):
        super().__init__(model, width, height, camera, trail, marker)
        self.skeleton = skeleton
        self.bones = [(int(p), j) for j, p in enumerate(parents) if p >= 0]
        self.radius = float(radius)
        self.rgba = np.asarray(rgba, dtype=np.float32)

    def decorate(
        self,
        scene: mujoco.MjvScene,
        data: mujoco.MjData,
        frame: FrameSamples,
        quats: Sequence[NDArray[np.float64] | None] = (),
    ) -> None:
        """The markers, trails and cues, then the skeleton of frame ``frame.index``."""
        super().decorate(scene, data, frame, quats)
        X = self.skeleton[min(frame.index, len(self.skeleton) - 1)]
        eye = np.eye(3).reshape(9)
        r = self.radius
        for a, b in self.bones:
            if float(np.linalg.norm(X[b] - X[a])) > 1e-6:
                g = _new_geom(scene)
                if g is None:
                    return
                mujoco.mjv_initGeom(
                    g, mujoco.mjtGeom.mjGEOM_CAPSULE, np.array([r, r, r]), X[a], eye, self.rgba
                )
                mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_CAPSULE, r, X[a], X[b])
                g.castshadow = 0
        for p in X:
            g = _new_geom(scene)
            if g is None:
                return
            size = np.full(3, _JOINT * r)
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_SPHERE, size, p, eye, self.rgba)
            g.castshadow = 0


def _new_geom(scene: mujoco.MjvScene) -> mujoco.MjvGeom | None:
    """The scene's next free geom (counted), or ``None`` when it is full."""
    if scene.ngeom >= scene.maxgeom:
        return None
    scene.ngeom += 1
    return scene.geoms[scene.ngeom - 1]


def _check(trajectory: Trajectory, skeleton: NDArray, parents: Sequence[int]) -> None:
    """One line for a skeleton that does not fit the trajectory or its own parents."""
    F = trajectory.n_frames
    if skeleton.ndim != 3 or skeleton.shape[2] != 3 or skeleton.shape[0] != F:
        raise TrajectoryFileError(
            f"skeleton: expected world positions ({F} frames, joints, 3) for the "
            f"trajectory's {F} frames, got shape {skeleton.shape}"
        )
    J = skeleton.shape[1]
    bad = [p for j, p in enumerate(parents) if not -1 <= int(p) < J or int(p) == j]
    if len(parents) != J or bad or not np.all(np.isfinite(skeleton)):
        raise TrajectoryFileError(
            f"skeleton: expected {J} parents, each -1 or another joint's index from 0 to "
            f"{J - 1}, and finite positions; got {len(parents)} parents"
            + (f", bad parent {bad[0]}" if bad else "")
        )


def film_with_skeleton(
    trajectory: Trajectory,
    model: mujoco.MjModel,
    skeleton: ArrayLike,
    parents: Sequence[int],
    folder: str | Path,
    *,
    render: RenderSpec | None = None,
    name: str | None = None,
    video: bool = True,
    packages: dict[str, Path] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FilmOutputs:
    """Film ``trajectory`` on ``model`` with the human ``skeleton`` drawn in each frame.

    Writes into ``folder`` (it must exist; a caller's staging folder: nothing is
    published here): ``<name>.mp4``, ``frame_NNNN.png`` snapshots, ``contact_sheet.png``
    and ``<name>.gif`` with ``render.gif``, as a replay does. A model without its own
    stage is filmed in the default stage framing every frame's robot, targets and
    skeleton (:func:`~humanoid_ik.outputs.stage.trajectory_stage`); a model with its own
    cameras is filmed by them, the filming one moved back (in a copy of the model) when
    the skeleton does not fit, and a note says when it still leaves the picture (a
    camera on a moving body is not moved).

    Args:
        trajectory: the robot's motion.
        model: the model it was recorded on (compiled from ``trajectory.model_file``).
        skeleton: the human's joints ``(F, J, 3)`` [m, world], one frame per trajectory
            frame (:func:`human_skeleton`, :func:`beside_robot`).
        parents: each joint's parent ``(J,)``, ``-1`` for the root (``BVHSkeleton.parents``).
        folder: where the files go.
        render: size, camera, snapshots, contact sheet (default: the trajectory's).
        name: the video's name (default: the trajectory's scene).
        video: write the MP4.
        packages: ROS package folders for a URDF's ``package://`` paths (the stage).
        progress: called with ``(frames done, frames total)`` after each frame.

    Raises:
        TrajectoryFileError: the skeleton does not fit the trajectory, the name is not a
            :data:`~humanoid_ik.core.names.NAME`, or the trajectory does not fit the model.
        RenderError: the camera does not exist, the frame is larger than the model's
            off-screen buffer, or no OpenGL backend works.
    """
    X = np.asarray(skeleton, dtype=np.float64)
    _check(trajectory, X, parents)
    try:
        name = check_name("film", trajectory.scene if name is None else name)
    except MotionError as exc:
        raise TrajectoryFileError(str(exc)) from None
    rs = trajectory.render if render is None else render
    folder = Path(folder)
    radius = bone_radius(X)
    film_model = model
    if needs_stage(model):  # frame the skeleton too: its points join the stage's
        step = max(1, math.ceil(len(X) / 300))
        reach = np.array([[0, 0, 1], [0, 0, -1]]) * _JOINT * radius
        pts = (X[::step, :, None] + reach).reshape(-1, 3)
        framed = dataclasses.replace(
            trajectory, stage_points=np.concatenate([trajectory.stage_points, pts])
        )
        aspect = rs.width / rs.height
        film_model = trajectory_stage(
            trajectory.model_file, framed, aspect, model, packages=packages
        )
    else:  # the model's own cameras: the one filming is moved back to frame the skeleton
        film_model = _framing(model, rs, X, trajectory)
    notes = _out_of_frame(film_model, rs, X, trajectory.qpos)
    renderer = functools.partial(SkeletonRenderer, skeleton=X, parents=parents, radius=radius)
    filmed = film_trajectory(
        trajectory,
        film_model,
        folder,
        render=rs,
        name=name,
        video=video,
        progress=progress,
        renderer=renderer,
    )
    return dataclasses.replace(filmed, notes=filmed.notes + tuple(notes))


def _framing(
    model: mujoco.MjModel, rs: RenderSpec, X: NDArray[np.float64], trajectory: Trajectory
) -> mujoco.MjModel:
    """``model``, or a copy of it whose filming camera is moved (along its own axes, its
    direction kept) just far enough to frame every frame's robot, targets and skeleton
    inside the middle :data:`~humanoid_ik.outputs.stage.FILL` of the picture, when they
    do not fit as it stands. Only a fixed camera of the world body is moved.

    With the camera's right ``r``, up ``u`` and backward ``b`` axes, a point at ``x``
    along an axis and depth ``d`` is in the picture from the camera moved by ``s`` along
    that axis and ``D`` back when ``|x - s| <= a (d + D)`` (``a``: the half-angle's
    tangent times FILL, times the aspect across): ``D = (max(x - a d) - min(x + a d)) /
    2a``, the larger of the two axes', ``s`` the middle (as the stage places its cameras).
    """
    cid = camera_id(model, rs.camera)
    if model.cam_bodyid[cid] != 0 or model.cam_mode[cid] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED:
        return model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    c, R = data.cam_xpos[cid].copy(), data.cam_xmat[cid].reshape(3, 3)
    points = [X.reshape(-1, 3), _robot_points(model, trajectory.qpos), trajectory.stage_points]
    points += [e.target for e in trajectory.effectors if e.task == "reach"]
    rel = np.concatenate(points) - c
    depth = -(rel @ R[:, 2])
    half = math.tan(math.radians(float(model.cam_fovy[cid])) / 2) * FILL
    axes = ((R[:, 0], half * rs.width / rs.height), (R[:, 1], half))
    if np.all(depth > 0) and all(np.all(np.abs(rel @ e) <= a * depth) for e, a in axes):
        return model  # all in the picture as the camera stands
    shifts, back = [], 0.0
    for e, a in axes:
        x = rel @ e
        far, near = float(np.max(x - a * depth)), float(np.min(x + a * depth))
        shifts.append((far + near) / 2)
        back = max(back, (far - near) / (2 * a))
    size = float(np.ptp(rel, axis=0).max())
    back = max(back, float(-depth.min()) + 0.05 * max(size, 0.1))  # never among the points
    moved = copy.copy(model)
    moved.cam_pos[cid] = c + shifts[0] * R[:, 0] + shifts[1] * R[:, 1] + back * R[:, 2]
    return moved


def _out_of_frame(
    model: mujoco.MjModel, rs: RenderSpec, X: NDArray[np.float64], qpos: NDArray[np.float64]
) -> list[str]:
    """A note when some frame's skeleton is outside the picture of the film's camera (a
    model with its own cameras; the stage's frame it), checked on up to 50 frames."""
    data = mujoco.MjData(model)
    step = max(1, math.ceil(len(X) / 50))
    worst = 0
    for f in range(0, len(X), step):
        data.qpos[:] = qpos[f]
        mujoco.mj_forward(model, data)  # where the cameras are (one may follow the robot)
        out = 0
        for p in X[f]:
            u, v, depth = project(model, data, rs.camera, p, rs.width, rs.height)
            out += not (depth > 0 and 0 <= u < rs.width and 0 <= v < rs.height)
        worst = max(worst, out)
    if not worst:
        return []
    return [
        f"the skeleton is partly outside camera '{rs.camera}' ({worst} of {X.shape[1]} "
        "joints in some frame): the model's own camera does not frame it"
    ]
