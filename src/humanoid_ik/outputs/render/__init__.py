"""Headless rendering of a scene run: MuJoCo's ``Renderer`` off-screen, markers and
trails drawn into its scene, an MP4 encoded in a background thread, and the outputs
(video, GIF, PNG frames, contact sheet, metrics CSV/JSON and plot) written atomically.

Rendering is a sink of the runner's one frame loop
(:meth:`~humanoid_ik.run.runner.SceneRunner.run`): a :class:`Film` draws each frame and
hands the picture to the video, the stills and the GIF, beside the metrics.

Modules:

- ``backend``: the OpenGL backend (EGL, OSMesa, GLFW) and the only code that changes
  process state for it (``MUJOCO_GL``, ``PYOPENGL_PLATFORM``, MuJoCo's ``GLContext``);
- ``drawing``: :class:`FrameRenderer` (markers sized by :func:`marker_radius` and shown
  through the robot when it hides them, trails, cues, :func:`project`) and the
  :class:`Film` frame sink;
- ``video``: :class:`VideoWriter`, the MP4 through ``imageio-ffmpeg``;
- ``stills``: PNG snapshots, the contact sheet and the GIF;
- ``plots``: :func:`plot_metrics`;
- ``pipeline``: :func:`render_scene`, :class:`RenderOutputs`; :func:`replay_trajectory`
  (a recorded trajectory filmed without solving), :class:`FilmOutputs`.
"""

from humanoid_ik.outputs.render.backend import INSTALL_HINT, Backend, select_backend
from humanoid_ik.outputs.render.drawing import (
    COLORS,
    HALO_RADIUS,
    MARKER_HAND,
    MARKER_MIN_PX,
    MARKER_RADIUS,
    MARKER_REACH,
    TRAIL_COLORS,
    TRAIL_WIDTH,
    Film,
    FrameRenderer,
    camera_id,
    marker_radius,
    project,
    track_quats,
)
from humanoid_ik.outputs.render.pipeline import (
    FilmOutputs,
    RenderOutputs,
    check_output_dir,
    render_scene,
    replay_trajectory,
)
from humanoid_ik.outputs.render.plots import plot_metrics
from humanoid_ik.outputs.render.video import VideoWriter

__all__ = [
    "COLORS",
    "HALO_RADIUS",
    "INSTALL_HINT",
    "MARKER_HAND",
    "MARKER_MIN_PX",
    "MARKER_RADIUS",
    "MARKER_REACH",
    "TRAIL_COLORS",
    "TRAIL_WIDTH",
    "Backend",
    "Film",
    "FilmOutputs",
    "FrameRenderer",
    "RenderOutputs",
    "VideoWriter",
    "camera_id",
    "check_output_dir",
    "marker_radius",
    "plot_metrics",
    "project",
    "render_scene",
    "replay_trajectory",
    "select_backend",
    "track_quats",
]
