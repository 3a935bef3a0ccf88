"""Drawing a frame: MuJoCo's ``Renderer`` on the scene's data, with each effector's target
marker, trail and cues added to its scene, and where a world point lands in the frame.

:class:`FrameRenderer` draws; :class:`Film` is the runner's frame sink that draws each
frame and hands the picture to the image sinks (video, stills, GIF).

Target markers are sized to the robot (:func:`marker_radius`: in proportion to the arm's
reach and its hand, at least :data:`MARKER_MIN_PX` pixels) and stay
visible when the robot hides them: a marker whose centre and halo are all behind geoms
(rays from the camera, ``mj_ray``) is painted over the rendered picture as well,
translucent, so it shows through the hand that holds it.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import model_cameras
from humanoid_ik.errors import RenderError
from humanoid_ik.motion import TargetTrack
from humanoid_ik.outputs.render.backend import open_renderer
from humanoid_ik.run.metrics import FrameSamples

__all__ = [
    "COLORS",
    "HALO_RADIUS",
    "MARKER_MIN_PX",
    "MARKER_RADIUS",
    "MARKER_HAND",
    "MARKER_REACH",
    "TRAIL_COLORS",
    "TRAIL_WIDTH",
    "Film",
    "FrameRenderer",
    "ImageSink",
    "Quats",
    "camera_id",
    "marker_radius",
    "project",
    "track_quats",
]

COLORS: dict[str, tuple[float, float, float, float]] = {
    "on_target": (0.15, 0.85, 0.25, 1.0),
    "tracking": (1.0, 0.55, 0.0, 1.0),
    "unreachable": (0.95, 0.1, 0.1, 1.0),
    "gap": (0.95, 0.1, 0.1, 0.8),
    "gaze": (1.0, 0.95, 0.5, 0.6),
}
"""Marker colours (RGBA in [0, 1]): on target, tracking (reachable, not there yet),
unreachable; the line from the effector to an unreachable target; the gaze ray."""
TRAIL_COLORS = (
    (0.1, 0.6, 1.0),
    (0.85, 0.25, 0.9),
    (1.0, 0.9, 0.3),
    (0.3, 0.95, 0.9),
)
"""Trail colour of effector 0, 1, 2, 3 (then repeating)."""
MARKER_RADIUS = 0.02
"""Target marker radius [m] (an opaque core) on an arm of :data:`MARKER_REACH` (the
bundled humanoid's): :func:`marker_radius` scales it with the arm's reach..."""
HALO_RADIUS = 0.04
"""... inside a translucent halo of twice the radius [m] (here), which shows around a
hand that covers the core."""
MARKER_REACH = 0.63
"""The reach [m] of the arm whose markers have :data:`MARKER_RADIUS` (the bundled
humanoid's: shoulder to palm)..."""
MARKER_HAND = 0.121
"""... and the size of its hand [m]: the radius of the sphere around the hand's geoms."""
MARKER_MIN_PX = 1.5
"""A marker's core radius is at least this many pixels at its depth (3 across; the halo
twice)."""
_SHOWN_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)  # the geom groups a film draws
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
TRAIL_WIDTH = 3.0
"""Trail width [px] at 480 rows (scaled with the frame height)."""


# ----------------------------------------------------------------------------- camera
def camera_id(model: mujoco.MjModel, camera: str) -> int:
    """The id of a named camera.

    Raises:
        RenderError: no such camera (the valid names are listed).
    """
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    if cid < 0:
        cams = ", ".join(model_cameras(model)) or "(none)"
        raise RenderError(f"camera '{camera}' not in model; cameras: {cams}")
    return cid


def project(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: str,
    point: ArrayLike,
    width: int,
    height: int,
) -> tuple[float, float, float]:
    """Where a world point appears in a frame from a named camera.

    With the camera at ``c`` and axes ``R = cam_xmat`` (x right, y up, looking along -z),
    ``p_c = R^T (p - c)``, focal length ``f = (height / 2) / tan(fovy / 2)`` [px] and

        ``u = width / 2 + f x_c / (-z_c)``,  ``v = height / 2 - f y_c / (-z_c)``

    with ``u`` the column and ``v`` the row from the top (pixel ``(row, col)`` covers
    ``[v, v + 1) x [u, u + 1)``).

    Returns:
        ``(u, v, depth)``: column and row [px], and distance in front of the camera [m].
    """
    cid = camera_id(model, camera)
    c = data.cam_xpos[cid]
    R = data.cam_xmat[cid].reshape(3, 3)
    pc = R.T @ (np.asarray(point, dtype=np.float64) - c)
    depth = -float(pc[2])
    f = 0.5 * height / math.tan(math.radians(float(model.cam_fovy[cid])) / 2.0)
    u = 0.5 * width + f * float(pc[0]) / depth
    v = 0.5 * height - f * float(pc[1]) / depth
    return u, v, depth


def marker_radius(chains: Sequence[Chain]) -> float:
    """The core radius [m] of a film's target markers, for the reaching ``chains`` filmed:
    the marker is to the arm and the hand what it is on the bundled humanoid.

    ``MARKER_RADIUS * min(R / MARKER_REACH, h / MARKER_HAND)`` for the chain of largest
    reach ``R`` (:meth:`~humanoid_ik.core.chain.Chain.reach`), ``h`` its hand: the
    radius of the sphere around the drawn geoms of its end effector's body and the
    bodies below it (the nearest body above with geoms when they have none). Without a
    chain (a film of gazes only), :data:`MARKER_RADIUS`. The renderer keeps it at least
    :data:`MARKER_MIN_PX` pixels.
    """
    if not chains:
        return MARKER_RADIUS
    chain = max(chains, key=lambda c: c.reach()[1])
    scale = chain.reach()[1] / MARKER_REACH
    hand = _hand_radius(chain)
    return MARKER_RADIUS * (min(scale, hand / MARKER_HAND) if hand > 0 else scale)


def _hand_radius(chain: Chain) -> float:
    """Radius [m] of the sphere around the drawn geoms at the end of ``chain`` (see
    :func:`marker_radius`), at the chain's current pose; 0 when there is none."""
    m, d = chain.model, chain.data
    body = int(m.site_bodyid[chain.ee_id]) if chain.ee_kind == "site" else chain.ee_id
    drawn = (m.geom_group < 3) & (m.geom_rgba[:, 3] > 0)
    drawn &= m.geom_type != mujoco.mjtGeom.mjGEOM_PLANE
    while body > 0:
        below = {body}
        for b in range(body + 1, m.nbody):  # a child's id is above its parent's
            if int(m.body_parentid[b]) in below:
                below.add(b)
        geoms = np.flatnonzero(drawn & np.isin(m.geom_bodyid, list(below)))
        if len(geoms):
            box = m.geom_aabb[geoms, None, :3] + _CORNERS * m.geom_aabb[geoms, None, 3:]
            R = d.geom_xmat[geoms].reshape(-1, 3, 3)
            pts = (d.geom_xpos[geoms, None] + box @ R.transpose(0, 2, 1)).reshape(-1, 3)
            return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) / 2
        body = int(m.body_parentid[body])
    return 0.0


# ----------------------------------------------------------------------------- drawing
class FrameRenderer:
    """Renders frames of a scene run with targets, trails and cues drawn in.

    Per effector: the target as a sphere (green on target, orange while tracking, red
    while out of reach) of radius ``marker`` in a halo of twice that (each at least
    :data:`MARKER_MIN_PX` / twice that many pixels), painted over the picture too when
    geoms hide it all; a pose target's axes, the recent path of the end effector (or of
    the gaze point) as a fading trail, a red line from the effector to a target out of
    reach, and the gaze ray of a ``look_at`` effector.

    Args:
        model: the scene's model.
        width, height: frame size [px].
        camera: a named camera.
        trail: how many past positions each trail keeps.
        marker: the markers' core radius [m] (:func:`marker_radius`).

    Raises:
        RenderError: unknown camera, or no working OpenGL backend.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        width: int,
        height: int,
        camera: str,
        trail: int,
        marker: float = MARKER_RADIUS,
    ):
        self.model = model
        self.camera = camera
        self.camera_id = camera_id(model, camera)
        self.width, self.height = width, height
        self.renderer = open_renderer(model, width, height)
        self.trail = max(0, int(trail))
        self.marker = float(marker)
        self._trails: list[deque[NDArray[np.float64]]] = []
        self._mat = np.eye(3).reshape(9)
        self._sites: dict[str, int] = {}
        self._focal = (
            0.5 * height / math.tan(math.radians(float(model.cam_fovy[self.camera_id])) / 2)
        )
        self._hidden: list[tuple[float, float, float, tuple[float, ...]]] = []

    def close(self) -> None:
        """Free the OpenGL context."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None

    def __enter__(self) -> FrameRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def reset_trails(self) -> None:
        """Forget the trails."""
        self._trails = []

    def _geom(self, scene: mujoco.MjvScene) -> mujoco.MjvGeom | None:
        if scene.ngeom >= scene.maxgeom:
            return None
        g = scene.geoms[scene.ngeom]
        scene.ngeom += 1
        return g

    def _sphere(self, scene, pos, radius, rgba) -> None:
        g = self._geom(scene)
        if g is None:
            return
        mujoco.mjv_initGeom(
            g,
            mujoco.mjtGeom.mjGEOM_SPHERE,
            np.array([radius, 0.0, 0.0]),
            np.asarray(pos, dtype=np.float64),
            self._mat,
            np.asarray(rgba, dtype=np.float32),
        )
        g.emission = 0.6
        g.specular = 0.0
        g.castshadow = 0

    def _segment(self, scene, a, b, width, rgba) -> None:
        """A line from ``a`` to ``b``, ``width`` pixels wide at 480 rows (scaled with the
        frame height). Lines cost next to nothing to render, unlike capsules."""
        if float(np.linalg.norm(np.asarray(b) - np.asarray(a))) < 1e-6:
            return
        g = self._geom(scene)
        if g is None:
            return
        mujoco.mjv_initGeom(
            g,
            mujoco.mjtGeom.mjGEOM_LINE,
            np.zeros(3),
            np.zeros(3),
            self._mat,
            np.asarray(rgba, dtype=np.float32),
        )
        mujoco.mjv_connector(
            g,
            mujoco.mjtGeom.mjGEOM_LINE,
            max(1.0, width * self.height / 480.0),
            np.asarray(a, dtype=np.float64),
            np.asarray(b, dtype=np.float64),
        )
        g.emission = 0.5
        g.specular = 0.0
        g.castshadow = 0

    def decorate(
        self,
        scene: mujoco.MjvScene,
        data: mujoco.MjData,
        frame: FrameSamples,
        quats: Sequence[NDArray[np.float64] | None] = (),
    ) -> None:
        """Add the markers, trails and cues of ``frame`` to ``scene`` (``quats``: each
        effector's target orientation, wxyz, or ``None``)."""
        while len(self._trails) < len(frame.samples):
            self._trails.append(deque(maxlen=max(1, self.trail)))
        # a target a hand reaches for is drawn (and trailed) once, for the hand
        reached = {s.target_name for s in frame.samples if s.task == "reach"}
        drawn: set[str] = set()
        for k, s in enumerate(frame.samples):
            trail = self._trails[k]
            shared = s.task == "look_at" and s.target_name in reached
            if self.trail > 0 and not shared:
                trail.append(s.achieved.copy())
                rgb = TRAIL_COLORS[k % len(TRAIL_COLORS)]
                pts = list(trail)
                n = len(pts)
                for j in range(1, n):
                    alpha = 0.15 + 0.85 * j / max(1, n - 1)
                    self._segment(scene, pts[j - 1], pts[j], TRAIL_WIDTH, (*rgb, alpha))
            if s.on_target:
                color = COLORS["on_target"]
            elif s.reachable:
                color = COLORS["tracking"]
            else:
                color = COLORS["unreachable"]
            if s.target_name not in drawn:
                drawn.add(s.target_name)
                self._marker(scene, data, s.target, color)
            site = self._effector_xpos(data, s.effector)
            if s.task == "look_at":
                self._segment(scene, site, s.achieved, 2.0, COLORS["gaze"])
            elif not s.reachable:
                self._segment(scene, site, s.target, 2.5, COLORS["gap"])
        # pose targets: their axes (x red, y green, z blue), 9 cm long
        for k, s in enumerate(frame.samples):
            quat = quats[k] if k < len(quats) else None
            if quat is None:
                continue
            mat = np.empty(9)
            mujoco.mju_quat2Mat(mat, quat)
            R = mat.reshape(3, 3)
            for axis, rgb in enumerate(((0.9, 0.3, 0.3), (0.3, 0.9, 0.3), (0.3, 0.4, 1.0))):
                end = s.target + 0.09 * R[:, axis]
                self._segment(scene, s.target, end, 3.0, (*rgb, 1.0))

    def _marker(self, scene, data: mujoco.MjData, target: NDArray, color) -> None:
        """A target's sphere and halo, at least :data:`MARKER_MIN_PX` pixels at its depth;
        noted for :meth:`render` to paint over the picture when geoms hide it all."""
        cam, R = data.cam_xpos[self.camera_id], data.cam_xmat[self.camera_id].reshape(3, 3)
        local = R.T @ (target - cam)
        depth = -float(local[2])
        if depth <= 1e-6:  # behind the camera
            return
        radius = max(self.marker, MARKER_MIN_PX * depth / self._focal)
        self._sphere(scene, target, radius, color)
        self._sphere(scene, target, 2 * radius, (*color[:3], 0.3))
        if self._covered(data, cam, target, [R[:, 0], -R[:, 0], R[:, 1], -R[:, 1]], radius):
            u = 0.5 * self.width + self._focal * float(local[0]) / depth
            v = 0.5 * self.height - self._focal * float(local[1]) / depth
            self._hidden.append((u, v, self._focal * radius / depth, tuple(color[:3])))

    def _covered(self, data, cam: NDArray, target: NDArray, sides: list, radius: float) -> bool:
        """Whether geoms hide the whole marker: the rays from the camera to its centre and
        to its halo's edge on each side (``sides``: unit vectors across the view) all
        meet a drawn geom first (``mj_ray``)."""
        gid = np.array([-1], dtype=np.int32)
        for point, margin in [(target, radius)] + [(target + 2 * radius * e, 0.0) for e in sides]:
            ray = point - cam
            dist = float(np.linalg.norm(ray))
            hit = mujoco.mj_ray(self.model, data, cam, ray / dist, _SHOWN_GROUPS, 1, -1, gid)
            if hit < 0 or hit >= dist - margin - 1e-4:
                return False
        return True

    def _paint_hidden(self, image: NDArray[np.uint8]) -> None:
        """Paint each hidden marker's halo (alpha 0.3) and core (alpha 0.7) over ``image``."""
        h, w = image.shape[:2]
        for u, v, r, rgb in self._hidden:
            c0, c1 = max(0, int(u - 2 * r) - 1), min(w, int(u + 2 * r) + 2)
            r0, r1 = max(0, int(v - 2 * r) - 1), min(h, int(v + 2 * r) + 2)
            if c0 >= c1 or r0 >= r1:
                continue
            rows, cols = np.mgrid[r0:r1, c0:c1]
            dd = (cols + 0.5 - u) ** 2 + (rows + 0.5 - v) ** 2
            patch = image[r0:r1, c0:c1].astype(np.float32)
            colour = 255.0 * np.asarray(rgb, dtype=np.float32)
            for mask, alpha in ((dd <= 4 * r * r, 0.3), (dd <= r * r, 0.7)):
                patch[mask] = (1 - alpha) * patch[mask] + alpha * colour
            image[r0:r1, c0:c1] = np.clip(patch + 0.5, 0, 255).astype(np.uint8)
        self._hidden = []

    def _effector_xpos(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """Where the end effector ``name`` is: a site, else a body of that name."""
        sid = self._sites.get(name)
        if sid is None:
            sid = self._sites[name] = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        if sid >= 0:
            return data.site_xpos[sid]
        return data.xpos[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)]

    def render(
        self,
        data: mujoco.MjData,
        frame: FrameSamples,
        quats: Sequence[NDArray[np.float64] | None] = (),
    ) -> NDArray[np.uint8]:
        """One frame ``(height, width, 3)`` of ``data`` with ``frame`` drawn in.

        Args:
            data: the scene's data after ``mj_forward``.
            frame: the frame's samples (targets, achieved positions, flags).
            quats: each effector's target orientation (wxyz) or ``None``.
        """
        r = self.renderer
        r.update_scene(data, camera=self.camera_id)
        self._hidden = []
        self.decorate(r.scene, data, frame, quats)
        image = r.render()
        self._paint_hidden(image)
        return image


# ----------------------------------------------------------------------------- film
class ImageSink(Protocol):
    """Takes each rendered frame (the video, the stills, the GIF)."""

    def add_image(self, frame: FrameSamples, image: NDArray[np.uint8]) -> None:
        """Take ``frame``'s picture ``(height, width, 3)`` (``image`` is not reused
        by the caller; keep it as is)."""


Quats = Callable[[FrameSamples], Sequence[NDArray[np.float64] | None]]
"""Each effector's target orientation (wxyz) or ``None`` at a frame."""


def track_quats(targets: Sequence[TargetTrack]) -> Quats:
    """The target orientations of a scene's tracks at a frame's time."""

    def quats(frame: FrameSamples) -> list[NDArray[np.float64] | None]:
        return [
            None if trk.orientation is None else trk.orientation.quat_at(frame.time)
            for trk in targets
        ]

    return quats


class Film:
    """The runner's frame sink that draws each frame and hands the picture on.

    Per frame: the targets' orientations at the frame, one :meth:`FrameRenderer.render`,
    then every image sink in order.

    Args:
        renderer: draws the frames.
        quats: each effector's target orientation at a frame, for pose targets' axes
            (:func:`track_quats` of a scene's tracks, or a trajectory's).
        images: where each picture goes.
        staged: the renderer films a staged copy of the run's model
            (``outputs/stage.py``): each frame's ``qpos`` and mocap poses are copied
            into the copy's own data, and ``mj_forward`` runs there.
    """

    def __init__(
        self,
        renderer: FrameRenderer,
        quats: Quats,
        images: Sequence[ImageSink],
        staged: bool = False,
    ):
        self.renderer = renderer
        self.quats = quats
        self.images = list(images)
        self._view = mujoco.MjData(renderer.model) if staged else None
        self.needs_forward = not staged
        """A staged film runs ``mj_forward`` on its own copy; else the run's data must
        be forwarded (cameras, lights)."""

    def add_frame(self, frame: FrameSamples, data: mujoco.MjData) -> None:
        """Render ``frame`` of ``data`` and hand it to every image sink."""
        view = self._view
        if view is not None:  # the run's state in the staged model
            view.qpos[:] = data.qpos
            view.mocap_pos[:] = data.mocap_pos
            view.mocap_quat[:] = data.mocap_quat
            mujoco.mj_forward(self.renderer.model, view)
            data = view
        image = self.renderer.render(data, frame, self.quats(frame))
        for sink in self.images:
            sink.add_image(frame, image)
