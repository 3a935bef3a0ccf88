"""Headless rendering of a scene run: MuJoCo's ``Renderer`` off-screen, markers and
trails drawn into its scene, an MP4 encoded in a background thread, and the outputs
(video, GIF, PNG frames, contact sheet, metrics CSV/JSON and plot) written atomically.

OpenGL backend: when the user set ``MUJOCO_GL`` (``egl``, ``osmesa``, ``glfw``...) that
backend is used. Otherwise EGL is tried (Mesa's EGL renders on the CPU without a GPU
or a display), in a short child process first because a failed EGL attempt would spoil
OSMesa in this process; when EGL does not work, OSMesa is used with a note, and when
neither works :class:`~humanoid_ik.errors.RenderError` says what to install.
"""

from __future__ import annotations

import math
import os
import queue
import subprocess
import sys
import threading
import time
import warnings
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.config.scene import Scene
from humanoid_ik.core.models import model_cameras
from humanoid_ik.errors import RenderError
from humanoid_ik.outputs.atomic import atomic_path, write_json, write_text
from humanoid_ik.run.metrics import FrameRecord, Metrics
from humanoid_ik.run.runner import SceneRunner

__all__ = [
    "COLORS",
    "Backend",
    "FrameRenderer",
    "RenderOutputs",
    "VideoWriter",
    "camera_id",
    "check_output_dir",
    "plot_metrics",
    "project",
    "render_scene",
    "select_backend",
]

INSTALL_HINT = (
    "install Mesa's EGL (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 "
    "libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6), or set MUJOCO_GL to a "
    "backend that works here"
)

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
"""Target marker radius [m] (an opaque core)..."""
HALO_RADIUS = 0.04
"""... inside a translucent halo [m], which shows around a hand that covers the core."""
TRAIL_WIDTH = 3.0
"""Trail width [px] at 480 rows (scaled with the frame height)."""


# ----------------------------------------------------------------------------- backend
@dataclass(frozen=True)
class Backend:
    """The OpenGL backend in use.

    Attributes:
        name: ``egl``, ``osmesa``, ``glfw``...
        chosen_by: ``MUJOCO_GL`` (the user's choice) or ``default``.
        note: why a fallback was taken, or ``""``.
    """

    name: str
    chosen_by: str
    note: str = ""


_BACKEND: Backend | None = None
_DISABLED = ("disable", "disabled", "off", "false", "0")
_EGL_PROBE = """
import mujoco
from mujoco.egl import GLContext
c = GLContext(16, 16)
c.make_current()
ctx = mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"), 150)
print("ok")
"""


def _gl_module():
    """The module whose ``GLContext`` attribute ``mujoco.Renderer`` instantiates."""
    mod = sys.modules[mujoco.Renderer.__module__]
    return getattr(mod, "gl_context", mod)


def _context_class(name: str):
    """Import the ``GLContext`` class of backend ``name``."""
    if name == "egl":
        from mujoco.egl import GLContext
    elif name == "osmesa":
        from mujoco.osmesa import GLContext
    elif name in ("glfw", "glx", "enable", "enabled", "on", "true", "1", ""):
        from mujoco.glfw import GLContext
    else:
        raise RenderError(f"MUJOCO_GL={name!r} is not a backend; expected one of egl, osmesa, glfw")
    return GLContext


def _probe_egl() -> str | None:
    """``None`` when EGL renders in a fresh process, else the reason it does not."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYOPENGL_PLATFORM",)}
    env["MUJOCO_GL"] = "egl"
    try:
        proc = subprocess.run(
            [sys.executable, "-c", _EGL_PROBE],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"the EGL check could not run ({exc})"
    if proc.returncode == 0 and "ok" in proc.stdout:
        return None
    lines = [ln for ln in proc.stderr.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else f"exit status {proc.returncode}"


def select_backend() -> Backend:
    """Choose the OpenGL backend for this process (once) and install its context class.

    ``MUJOCO_GL`` set by the user wins. Otherwise EGL when it works (checked in a child
    process), else OSMesa with a note; the choice is written to ``MUJOCO_GL``.

    Raises:
        RenderError: ``MUJOCO_GL`` turns rendering off or names no backend.
    """
    global _BACKEND
    if _BACKEND is not None:
        return _BACKEND
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen in _DISABLED:
        raise RenderError(
            f"MUJOCO_GL={os.environ['MUJOCO_GL']!r} turns rendering off; unset it or set "
            "MUJOCO_GL=egl"
        )
    if chosen:
        backend = Backend(chosen, "MUJOCO_GL")
    else:
        why = _probe_egl()
        if why is None:
            backend = Backend("egl", "default")
        else:
            backend = Backend(
                "osmesa", "default", f"EGL does not work here ({why}); rendering with OSMesa"
            )
        os.environ["MUJOCO_GL"] = backend.name
    gl = _gl_module()
    if getattr(gl, "_MUJOCO_GL", None) != backend.name or not hasattr(gl, "GLContext"):
        try:
            if backend.name == "osmesa":
                os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
            gl.GLContext = _context_class(backend.name)
        except RenderError:
            raise
        except Exception as exc:  # ImportError, OSError... from the GL bindings
            raise RenderError(
                f"OpenGL backend '{backend.name}' cannot be loaded ({exc}); {INSTALL_HINT}"
            ) from exc
    _BACKEND = backend
    return backend


def _renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    backend = select_backend()
    try:
        with warnings.catch_warnings():  # glfw warns before it raises; the error says it all
            warnings.simplefilter("ignore")
            return mujoco.Renderer(model, height, width)
    except Exception as exc:  # the GL bindings raise many types
        note = f" ({backend.note})" if backend.note else ""
        raise RenderError(
            f"cannot create an off-screen OpenGL context with MUJOCO_GL={backend.name}{note}: "
            f"{type(exc).__name__}: {' '.join(str(exc).split())}; {INSTALL_HINT}"
        ) from exc


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


# ----------------------------------------------------------------------------- drawing
class FrameRenderer:
    """Renders frames of a scene run with targets, trails and cues drawn in.

    Per effector: the target as a sphere (green on target, orange while tracking, red
    while out of reach), a pose target's axes, the recent path of the end effector (or
    of the gaze point) as a fading trail, a red line from the effector to a target out
    of reach, and the gaze ray of a ``look_at`` effector.

    Args:
        model: the scene's model.
        width, height: frame size [px].
        camera: a named camera.
        trail: how many past positions each trail keeps.

    Raises:
        RenderError: unknown camera, or no working OpenGL backend.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, camera: str, trail: int):
        self.model = model
        self.camera = camera
        self.camera_id = camera_id(model, camera)
        self.width, self.height = width, height
        self.renderer = _renderer(model, width, height)
        self.trail = max(0, int(trail))
        self._trails: list[deque[NDArray[np.float64]]] = []
        self._mat = np.eye(3).reshape(9)
        self._sites: dict[str, int] = {}

    def close(self) -> None:
        """Free the OpenGL context."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None  # type: ignore[assignment]

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
        record: FrameRecord,
        quats: Sequence[NDArray[np.float64] | None] = (),
    ) -> None:
        """Add the markers, trails and cues of ``record`` to ``scene`` (``quats``: each
        effector's target orientation, wxyz, or ``None``)."""
        while len(self._trails) < len(record.samples):
            self._trails.append(deque(maxlen=max(1, self.trail)))
        # a target a hand reaches for is drawn (and trailed) once, for the hand
        reached = {s.target_name for s in record.samples if s.task == "reach"}
        drawn: set[str] = set()
        for k, s in enumerate(record.samples):
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
                self._sphere(scene, s.target, MARKER_RADIUS, color)
                self._sphere(scene, s.target, HALO_RADIUS, (*color[:3], 0.3))
            site = data.site_xpos[self._site_id(s.effector)]
            if s.task == "look_at":
                self._segment(scene, site, s.achieved, 2.0, COLORS["gaze"])
            elif not s.reachable:
                self._segment(scene, site, s.target, 2.5, COLORS["gap"])
        # pose targets: their axes (x red, y green, z blue), 9 cm long
        for k, s in enumerate(record.samples):
            quat = quats[k] if k < len(quats) else None
            if quat is None:
                continue
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, quat)
            R = R.reshape(3, 3)
            for axis, rgb in enumerate(((0.9, 0.3, 0.3), (0.3, 0.9, 0.3), (0.3, 0.4, 1.0))):
                end = s.target + 0.09 * R[:, axis]
                self._segment(scene, s.target, end, 3.0, (*rgb, 1.0))

    def _site_id(self, name: str) -> int:
        sid = self._sites.get(name)
        if sid is None:
            sid = self._sites[name] = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, name)
        return sid

    def render(
        self,
        data: mujoco.MjData,
        record: FrameRecord,
        quats: Sequence[NDArray[np.float64] | None] = (),
    ) -> NDArray[np.uint8]:
        """One frame ``(height, width, 3)`` of ``data`` with ``record`` drawn in.

        Args:
            data: the scene's data after ``mj_forward``.
            record: the frame's metrics (targets, achieved positions, flags).
            quats: each effector's target orientation (wxyz) or ``None``.
        """
        r = self.renderer
        r.update_scene(data, camera=self.camera_id)
        self.decorate(r.scene, data, record, quats)
        return r.render()


# ----------------------------------------------------------------------------- video
class VideoWriter:
    """An MP4 (H.264, yuv420p) written by ``ffmpeg`` from frames queued by the caller and
    piped by a background thread, so encoding overlaps rendering.

    The file appears under its name only when :meth:`close` succeeds (it is written to a
    temporary name beside it first).

    Args:
        path: the ``.mp4`` to write.
        width, height: frame size [px], even.
        fps: frame rate [1/s].
    """

    def __init__(self, path: str | os.PathLike, width: int, height: int, fps: float):
        import imageio_ffmpeg

        self.path = Path(path)
        self.frames = 0
        self._ctx = atomic_path(self.path, suffix=".mp4")
        self._tmp = self._ctx.__enter__()
        self._queue: queue.Queue[bytes | None] = queue.Queue(maxsize=16)
        self._error: BaseException | None = None
        self._writer = imageio_ffmpeg.write_frames(
            str(self._tmp),
            (width, height),
            fps=fps,
            codec="libx264",
            pix_fmt_out="yuv420p",
            macro_block_size=2,
            quality=7,
            ffmpeg_log_level="error",
            output_params=["-preset", "veryfast", "-threads", "1"],
        )
        self._thread = threading.Thread(target=self._pump, name="mp4-encoder", daemon=True)
        self._thread.start()

    def _pump(self) -> None:
        drained = False
        try:
            self._writer.send(None)
            while True:
                item = self._queue.get()
                if item is None:
                    drained = True
                    break
                self._writer.send(item)
            self._writer.close()
        except BaseException as exc:  # reported by close()
            self._error = exc
            while not drained and self._queue.get() is not None:  # let the producer finish
                pass

    def _failure(self) -> RenderError:
        """The encoder's error in one line (ffmpeg prints its own reason on stderr)."""
        lines = [ln.strip() for ln in str(self._error).splitlines() if ln.strip()]
        why = lines[0] if lines else repr(self._error)
        return RenderError(f"video encoding to '{self.path}' failed (ffmpeg): {why}")

    def write(self, frame: NDArray[np.uint8]) -> None:
        """Queue one ``(height, width, 3)`` uint8 frame.

        Raises:
            RenderError: the encoder has failed (e.g. ffmpeg cannot write the file).
        """
        if self._error is not None:
            raise self._failure()
        self._queue.put(np.ascontiguousarray(frame).tobytes())
        self.frames += 1

    def close(self, abort: bool = False) -> Path | None:
        """Finish the file; returns its path, or ``None`` when no frame was written or
        ``abort`` is true (the run failed: the temporary file is removed, nothing is
        renamed into place).

        Raises:
            RenderError: ffmpeg failed (not raised when aborting).
        """
        self._queue.put(None)
        self._thread.join()
        if abort or self._error is not None or self.frames == 0:
            self._ctx.__exit__(RenderError, RenderError("aborted"), None)
            if self._error is not None and not abort:
                raise self._failure() from self._error
            return None
        self._ctx.__exit__(None, None, None)
        return self.path


# ----------------------------------------------------------------------------- outputs
@dataclass(frozen=True)
class RenderOutputs:
    """What a render wrote.

    Attributes:
        folder: the output folder.
        frames: frames rendered.
        interrupted: Ctrl-C stopped the run early (the outputs hold the frames so far).
        video, gif, contact_sheet, csv, json, plot: the files (``None`` when not written).
        snapshots: the PNG frames.
        backend: the OpenGL backend.
        frame_times: wall time of each frame in the render loop [s] (solve, draw,
            render, hand-off to the encoder).
        total_time: wall time of the whole render including set-up and writing [s].
        metrics: the run's metrics.
    """

    folder: Path
    frames: int
    interrupted: bool
    video: Path | None
    gif: Path | None
    snapshots: tuple[Path, ...]
    contact_sheet: Path | None
    csv: Path
    json: Path
    plot: Path | None
    backend: Backend
    frame_times: tuple[float, ...] = field(repr=False)
    total_time: float
    metrics: Metrics = field(repr=False, compare=False)

    def files(self) -> list[Path]:
        """Every file written."""
        out = [self.video, self.gif, *self.snapshots, self.contact_sheet, self.csv, self.json]
        out.append(self.plot)
        return [p for p in out if p is not None]


def check_output_dir(folder: str | os.PathLike) -> Path:
    """Create ``folder`` if needed and check a file can be written there.

    Raises:
        RenderError: it cannot be created or written.
    """
    import tempfile

    p = Path(folder)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RenderError(f"cannot create output folder '{p}': {exc.strerror or exc}") from None
    try:
        fd, name = tempfile.mkstemp(prefix=".write-check.", dir=p)
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise RenderError(f"output folder '{p}' is not writable: {exc.strerror or exc}") from None
    return p


def _png(path: Path, image: NDArray[np.uint8]) -> Path:
    from PIL import Image

    with atomic_path(path) as tmp:
        Image.fromarray(image).save(tmp, format="PNG")
    return path


def _contact_sheet(
    path: Path, tiles: Sequence[tuple[int, float, NDArray[np.uint8]]], max_tile_width: int = 320
) -> Path:
    """A grid of frames, each labelled with its index and time."""
    from PIL import Image, ImageDraw

    n = len(tiles)
    cols = min(4, n)
    rows = math.ceil(n / cols)
    h0, w0 = tiles[0][2].shape[:2]
    scale = min(1.0, max_tile_width / w0)
    tw, th = max(1, round(w0 * scale)), max(1, round(h0 * scale))
    pad = 4
    sheet = Image.new("RGB", (cols * (tw + pad) + pad, rows * (th + pad) + pad), (20, 20, 24))
    draw = ImageDraw.Draw(sheet)
    for k, (idx, t, img) in enumerate(tiles):
        tile = Image.fromarray(img)
        if scale != 1.0:
            tile = tile.resize((tw, th), Image.Resampling.BILINEAR)
        x = pad + (k % cols) * (tw + pad)
        y = pad + (k // cols) * (th + pad)
        sheet.paste(tile, (x, y))
        draw.text((x + 3, y + 2), f"#{idx}  {t:.2f} s", fill=(255, 255, 255))
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def _gif(path: Path, frames: Sequence[NDArray[np.uint8]], frame_ms: int) -> Path:
    """An animated GIF with one palette for every frame (taken from a few frames spread
    over the run, no dithering), so that Pillow stores only what changed between frames."""
    from PIL import Image

    picks = [frames[k] for k in np.linspace(0, len(frames) - 1, min(6, len(frames))).astype(int)]
    # the marker and trail colours get palette entries of their own
    swatch = np.array(
        [[255 * np.array(c[:3]) for c in (*COLORS.values(), *TRAIL_COLORS)]], dtype=np.uint8
    )
    width = picks[0].shape[1]
    swatch = np.repeat(np.repeat(swatch, 8, axis=0), -(-width // swatch.shape[1]), axis=1)
    picks.append(swatch[:, :width])
    palette = Image.fromarray(np.concatenate(picks, axis=0)).quantize(
        colors=255, method=Image.Quantize.MEDIANCUT
    )
    imgs = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    with atomic_path(path) as tmp:
        imgs[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=imgs[1:],
            duration=frame_ms,
            loop=0,
            optimize=False,
        )
    return path


def plot_metrics(metrics: Metrics, path: str | os.PathLike) -> Path:
    """Plot position error [mm] (log scale) and solve time [ms] over time, per effector,
    with the frames where a target is out of reach shaded; written atomically as PNG."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    fig = Figure(figsize=(8, 5), dpi=100)
    ax_e, ax_t = fig.subplots(2, 1, sharex=True)
    times = np.array([f.time for f in metrics.frames])
    for k, eff in enumerate(metrics.scene.effectors):
        label = f"{eff.site} ({metrics.solvers[k]})"
        rgb = TRAIL_COLORS[k % len(TRAIL_COLORS)]
        err = np.maximum(metrics.series(k, "position_error") * 1e3, 1e-6)
        ax_e.plot(times, err, color=rgb, label=label, lw=1.4)
        ax_t.plot(times, metrics.series(k, "solve_time") * 1e3, color=rgb, label=label, lw=1.2)
        out = ~metrics.series(k, "reachable").astype(bool)
        if out.any() and times.size > 1:
            dt = float(times[1] - times[0])
            for i in np.flatnonzero(out):
                ax_e.axvspan(times[i] - dt / 2, times[i] + dt / 2, color="red", alpha=0.08, lw=0)
    ax_e.axhline(1.0, color="gray", ls="--", lw=0.8)
    ax_e.set_yscale("log")
    ax_e.set_ylabel("position error [mm]")
    ax_e.set_title(f"{metrics.scene.name}: error and solve time (red: target out of reach)")
    ax_e.legend(fontsize=7, loc="upper right")
    ax_t.set_ylabel("solve time [ms]")
    ax_t.set_xlabel("time [s]")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return Path(path)


def _snapshot_indices(scene: Scene, n: int) -> list[int]:
    if scene.render.snapshots:
        idx = {min(n - 1, round(t * scene.fps)) for t in scene.render.snapshots}
    else:
        idx = {round(k * (n - 1) / 3) for k in range(4)} if n > 1 else {0}
    return sorted(idx)


def _sheet_indices(count: int, n: int) -> list[int]:
    if count <= 0:
        return []
    if count >= n:
        return list(range(n))
    return sorted({round(k * (n - 1) / (count - 1)) for k in range(count)} if count > 1 else {0})


def render_scene(
    scene: Scene,
    out_dir: str | os.PathLike | None = None,
    *,
    video: bool = True,
    plot: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> RenderOutputs:
    """Run a scene and film it.

    Writes into ``out_dir`` (default ``renders/<scene name>``): ``<name>.mp4``,
    ``<name>.gif`` (when ``scene.render.gif``), ``frame_NNNN.png`` snapshots,
    ``contact_sheet.png``, ``metrics.csv``, ``metrics.json`` and ``metrics.png``. Every
    file is written under a temporary name and renamed when complete. Ctrl-C stops the
    run early and the outputs are written for the frames rendered so far
    (``interrupted`` is then set).

    Args:
        scene: the scene (apply command-line choices with :meth:`Scene.with_overrides`).
        out_dir: the output folder.
        video: write the MP4.
        plot: write the metrics plot.
        progress: called with ``(frames done, frames total)`` after each frame.

    Raises:
        SceneError: the scene does not fit its model.
        RenderError: the folder cannot be written, the camera does not exist, or no
            OpenGL backend works.
    """
    t_start = time.perf_counter()
    folder = check_output_dir(Path("renders") / scene.name if out_dir is None else out_dir)
    runner = SceneRunner(scene)
    n = runner.n_frames
    rs = scene.render
    trail = round(rs.trail * scene.fps)
    snaps = set(_snapshot_indices(scene, n))
    sheet = set(_sheet_indices(rs.contact_sheet, n))
    gif_step = max(1, math.ceil(scene.fps / 25.0))
    kept: dict[int, tuple[float, NDArray[np.uint8]]] = {}
    gif_frames: list[NDArray[np.uint8]] = []
    frame_times: list[float] = []
    metrics = Metrics(scene, runner.solver_labels())
    interrupted = False
    name = scene.name
    with FrameRenderer(runner.model, rs.width, rs.height, rs.camera, trail) as fr:
        backend = select_backend()
        writer = (
            VideoWriter(folder / f"{name}.mp4", rs.width, rs.height, scene.fps) if video else None
        )
        video_path = None
        try:
            runner.reset()
            for i in range(n):
                t0 = time.perf_counter()
                rec = runner.step(i)
                quats = [
                    None if trk.orientation is None else trk.orientation.quat_at(rec.time)
                    for trk in runner.targets
                ]
                img = fr.render(runner.data, rec, quats)
                if writer is not None:
                    writer.write(img)
                if i in snaps or i in sheet:
                    kept[i] = (rec.time, img)
                if rs.gif and i % gif_step == 0:
                    gif_frames.append(img)
                metrics.append(rec)
                frame_times.append(time.perf_counter() - t0)
                if progress is not None:
                    progress(i + 1, n)
        except KeyboardInterrupt:  # keep what was rendered: a valid, shorter video
            interrupted = True
            metrics.interrupted = True
        except BaseException:  # a failed run leaves no video under the final name
            if writer is not None:
                writer.close(abort=True)
                writer = None
            raise
        finally:
            if writer is not None:
                video_path = writer.close()
    done = len(metrics)
    snapshots = tuple(
        _png(folder / f"frame_{i:04d}.png", kept[i][1]) for i in sorted(snaps) if i in kept
    )
    tiles = [(i, kept[i][0], kept[i][1]) for i in sorted(sheet) if i in kept]
    sheet_path = _contact_sheet(folder / "contact_sheet.png", tiles) if tiles else None
    gif_path = None
    if rs.gif and gif_frames:
        gif_path = _gif(folder / f"{name}.gif", gif_frames, round(1000 * gif_step / scene.fps))
    csv_path = write_text(folder / "metrics.csv", metrics.csv_text())
    json_path = write_json(folder / "metrics.json", metrics.to_dict())
    plot_path = plot_metrics(metrics, folder / "metrics.png") if plot and done else None
    return RenderOutputs(
        folder=folder,
        frames=done,
        interrupted=interrupted,
        video=video_path,
        gif=gif_path,
        snapshots=snapshots,
        contact_sheet=sheet_path,
        csv=csv_path,
        json=json_path,
        plot=plot_path,
        backend=backend,
        frame_times=tuple(frame_times),
        total_time=time.perf_counter() - t_start,
        metrics=metrics,
    )
