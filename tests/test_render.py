"""Headless rendering with MuJoCo's Renderer on Mesa's EGL: every bundled scene is filmed
for a few small frames; the video decodes, frames change, the markers sit where the
targets project (painted over the robot where it hides them), and the outputs are
complete."""

from __future__ import annotations

import fcntl
import json
import math
import os
import pty
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from dataclasses import replace
from pathlib import Path

import imageio_ffmpeg
import mujoco
import numpy as np
import pytest
from PIL import Image

from humanoid_ik.cli import main
from humanoid_ik.config.scene import bundled_scenes, load_scene
from humanoid_ik.errors import RenderError
from humanoid_ik.outputs.atomic import MANIFEST, published
from humanoid_ik.outputs.render import (
    MARKER_RADIUS,
    FrameRenderer,
    VideoWriter,
    check_output_dir,
    project,
    render_scene,
    select_backend,
)
from humanoid_ik.outputs.render import backend as backend_mod
from humanoid_ik.run.runner import SceneRunner, run_scene

W, H, N = 160, 120, 6
REPO = Path(__file__).resolve().parents[1]


def short(name: str, frames: int = N, width: int = W, height: int = H):
    """A bundled scene cut to `frames` frames spread over its whole duration, with every
    frame saved as PNG."""
    sc = load_scene(name)
    fps = frames / sc.duration
    sc = sc.with_overrides(fps=fps, frames=frames, width=width, height=height)
    times = tuple(i / fps for i in range(frames))
    return replace(sc, render=replace(sc.render, snapshots=times))


def decode(path: Path) -> list[np.ndarray]:
    """Every frame of a video, decoded by ffmpeg, ``(height, width, 3)`` uint8 each."""
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    return [np.frombuffer(f, dtype=np.uint8).reshape(h, w, 3) for f in gen]


def colour_class(px: np.ndarray) -> str:
    """'green', 'red', 'orange' or 'other' for an RGB pixel."""
    r, g, b = (int(v) for v in px)
    if g >= 150 and g - r >= 50 and g - b >= 50:
        return "green"
    if r >= 150 and r - g >= 80 and r - b >= 80:
        return "red"
    if r >= 150 and r - b >= 80 and g - b >= 30 and r - g >= 30:
        return "orange"
    return "other"


def expected_class(sample) -> str:
    """The marker colour a sample's state calls for."""
    if sample.on_target:
        return "green"
    return "orange" if sample.reachable else "red"


def visible(model, data, cam: int, point: np.ndarray) -> bool:
    """No visible model geom lies between the camera and the marker's front surface."""
    c = data.cam_xpos[cam]
    v = point - c
    dist = float(np.linalg.norm(v))
    gid = np.array([-1], dtype=np.int32)
    hit = mujoco.mj_ray(
        model, data, c, v / dist, np.array([1, 1, 1, 0, 0, 0], np.uint8), 1, -1, gid
    )
    return hit < 0 or hit > dist - MARKER_RADIUS


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """Every bundled scene, 6 frames at 160x120 spread over its duration, MP4 + PNGs."""
    root = tmp_path_factory.mktemp("renders")
    out = {}
    for p in bundled_scenes():
        sc = short(p.stem)
        out[p.stem] = (sc, render_scene(sc, root / p.stem, plot=False))
    return out


SCENES = [p.stem for p in bundled_scenes()]


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_video_decodes_to_the_frame_count(renders, name):
    """The MP4 decodes to exactly the frames rendered, at the rendered size."""
    sc, out = renders[name]
    assert out.frames == N and not out.interrupted
    frames = decode(out.video)
    assert len(frames) == N
    assert frames[0].shape == (H, W, 3)
    n, _ = imageio_ffmpeg.count_frames_and_secs(str(out.video))
    assert n == N


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_frames_change_where_the_arm_moves(renders, name):
    """Frames change as the arm and the target move, in the video and in the PNGs.

    Some decoded frame differs from the first by a mean of more than 1 grey level, most
    consecutive frames differ, and the PNGs differ likewise."""
    sc, out = renders[name]
    frames = [f.astype(int) for f in decode(out.video)]
    far = max(np.abs(f - frames[0]).mean() for f in frames[1:])
    assert far > 1.0, far
    steps = [np.abs(b - a).mean() for a, b in zip(frames, frames[1:], strict=False)]
    assert sum(d > 0.2 for d in steps) >= len(steps) // 2 + 1, steps
    pngs = [np.array(Image.open(p)).astype(int) for p in out.snapshots]
    assert max(np.abs(p - pngs[0]).mean() for p in pngs[1:]) > 1.0


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_marker_shows_where_the_target_projects(renders, name):
    """Each target's marker shows, in its state's colour, where the target projects.

    In every saved frame, where no body part hides it, the pixels around the projection
    of each target (camera pose and fovy) have the marker's colour for its state: green on
    target, orange tracking, red out of reach."""
    sc, out = renders[name]
    run = SceneRunner(sc)
    cam = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_CAMERA, sc.render.camera)
    checked = 0
    for i, png in enumerate(out.snapshots):
        img = np.array(Image.open(png))
        assert img.shape == (H, W, 3)
        rec = run.step(i)
        assert png.name == f"frame_{i:04d}.png"
        drawn = set()  # a shared target is drawn once, in the state of its first effector
        for s in rec.samples:
            if s.target_name in drawn:
                continue
            drawn.add(s.target_name)
            u, v, depth = project(run.model, run.data, sc.render.camera, s.target, W, H)
            col, row = int(math.floor(u)), int(math.floor(v))
            if not (1 <= col < W - 1 and 1 <= row < H - 1) or depth <= 0:
                continue
            if not visible(run.model, run.data, cam, s.target):
                continue
            window = img[row - 1 : row + 2, col - 1 : col + 2].reshape(-1, 3)
            classes = [colour_class(px) for px in window]
            want = expected_class(s)
            assert classes.count(want) >= 3, (name, i, s.effector, want, window.tolist())
            checked += 1
    if name in ("gaze", "out_of_reach"):
        assert checked >= N - 1  # these targets are never behind the humanoid


@pytest.mark.slow
@pytest.mark.parametrize("name", SCENES)
def test_metrics_put_the_hand_on_reachable_targets(renders, name):
    """The rendered run reaches every reachable target within 1 mm once converged.

    Converged: from the first frame on target; a velocity-limited solver that is still
    catching up must be closing in on every frame."""
    sc, out = renders[name]
    m = out.metrics
    assert len(m) == N
    for k in range(len(sc.effectors)):
        reach = m.series(k, "reachable").astype(bool)
        on = m.series(k, "on_target").astype(bool)
        if not on.any():  # a velocity-limited solver still catching up: closing in
            assert sc.solver.options.get("dt", 0.0) > 0.0, (name, k)
            err = m.series(k, "position_error")
            assert np.all(np.diff(err) < 0.0), (name, k, err)
            continue
        reach[: int(np.argmax(on))] = False
        err = m.series(k, "position_error")
        assert err[reach].max() < 1e-3, (name, k, err[reach].max())


@pytest.mark.slow
def test_outputs_are_complete_and_atomic(renders):
    """The folder holds the MP4, the PNGs, contact sheet, metrics CSV/JSON, the trajectory,
    the manifest that lists exactly those (and the publishing lock), and no temporary.

    Also: the contact sheet's grid, the EGL backend, and one loop time per frame within
    the whole render's time."""
    sc, out = renders["circle"]
    names = sorted(p.name for p in out.folder.iterdir())
    expected = sorted(
        ["circle.mp4", "contact_sheet.png", "metrics.csv", "metrics.json"]
        + ["trajectory.csv", "trajectory.npz"]
        + [f"frame_{i:04d}.png" for i in range(N)]
    )
    assert names == sorted([*expected, MANIFEST, ".humanoid-ik-outputs.lock"])
    assert published(out.folder) == expected
    assert all(p.exists() for p in out.files())
    sheet = Image.open(out.contact_sheet)
    assert sheet.size == (4 * (W + 4) + 4, 2 * (H + 4) + 4)  # 6 tiles: 4 columns, 2 rows
    assert out.backend.name == "egl"
    assert len(out.frame_times) == N and out.total_time >= sum(out.frame_times)


def test_project_matches_the_pinhole_model():
    """project() follows the pinhole model of the camera's pose and fovy.

    A point on the camera's axis projects to the image centre; one offset by d along the
    camera's x at depth z lands f d / z pixels to the right, f = (H/2) / tan(fovy/2)."""
    m = mujoco.MjModel.from_xml_path(str(REPO / "models" / "humanoid" / "scene.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "front")
    c, R = d.cam_xpos[cid], d.cam_xmat[cid].reshape(3, 3)
    u, v, depth = project(m, d, "front", c - 2.0 * R[:, 2], 640, 480)
    assert (u, v, depth) == pytest.approx((320.0, 240.0, 2.0))
    f = 240.0 / math.tan(math.radians(m.cam_fovy[cid]) / 2)
    u, v, _ = project(m, d, "front", c - 2.0 * R[:, 2] + 0.1 * R[:, 0] + 0.05 * R[:, 1], 640, 480)
    assert u == pytest.approx(320.0 + f * 0.1 / 2.0) and v == pytest.approx(240 - f * 0.05 / 2)
    with pytest.raises(RenderError, match=r"camera 'left' not in model; cameras: front, side"):
        project(m, d, "left", c, 640, 480)


def test_a_hidden_marker_is_painted_over_the_robot():
    """A target inside the humanoid's torso is hidden from the front camera (a ray from
    the camera meets the torso first, and MuJoCo's picture shows the torso there); its
    marker is painted over the picture, green around the target's projection."""
    from humanoid_ik.run.metrics import EffectorSample, FrameSamples

    m = mujoco.MjModel.from_xml_path(str(REPO / "models" / "humanoid" / "scene.xml"))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    target = d.site("torso_site").xpos.copy()
    sample = EffectorSample(
        effector="right_palm_site",
        target_name="inside",
        task="reach",
        target=target,
        achieved=d.site("right_palm_site").xpos.copy(),
        position_error=0.0,
        orientation_error=None,
        iterations=1,
        solve_time=0.0,
        limit_margin=1.0,
        reachable=True,
        on_target=True,
        status="converged",
    )
    cam = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, "front")
    assert not visible(m, d, cam, target)
    u, v, _ = project(m, d, "front", target, W, H)
    col, row = int(u), int(v)
    with FrameRenderer(m, W, H, "front", 0) as fr:
        fr.renderer.update_scene(d, camera=cam)
        plain = fr.renderer.render()
        drawn = fr.render(d, FrameSamples(0, 0.0, (sample,)))
    before = [colour_class(px) for px in plain[row - 1 : row + 2, col - 1 : col + 2].reshape(-1, 3)]
    after = [colour_class(px) for px in drawn[row - 1 : row + 2, col - 1 : col + 2].reshape(-1, 3)]
    assert before.count("green") == 0 and after.count("green") >= 4, (before, after)


def test_video_writer_failure_is_one_line(tmp_path):
    """ffmpeg unable to write the file: a one-line RenderError naming it, nothing left.

    The error comes from whichever call meets the encoder's failure first: a ``write``
    (once the encoder thread has failed) or at the latest ``close`` (which waits for the
    encoder thread), so no waiting is needed; a second ``close`` says the same."""
    w = VideoWriter(tmp_path / "gone" / "a.mp4", 64, 48, 10)
    with pytest.raises(RenderError) as info:
        for _ in range(50):
            w.write(np.zeros((48, 64, 3), np.uint8))
        w.close()
    msg = str(info.value)
    assert msg.startswith(f"video encoding to '{tmp_path / 'gone' / 'a.mp4'}' failed (ffmpeg): ")
    assert "\n" not in msg
    with pytest.raises(RenderError, match=r"video encoding to .* failed"):
        w.close()
    assert list(tmp_path.iterdir()) == []


def test_unknown_camera_in_frame_renderer():
    """FrameRenderer names the valid cameras for an unknown one."""
    m = mujoco.MjModel.from_xml_path(str(REPO / "models" / "humanoid" / "scene.xml"))
    with pytest.raises(RenderError, match=r"cameras: front, side, top, three_quarter"):
        FrameRenderer(m, 64, 48, "behind", 0)


@pytest.mark.slow
def test_gif_plot_and_interrupt(tmp_path):
    """The GIF has every frame, the plot is 800x500, Ctrl-C keeps a valid shorter video.

    Ctrl-C (KeyboardInterrupt from the progress callback) after frame 3 keeps a valid
    3-frame video, 3 frames of metrics and no temporary file."""
    sc = short("both_hands", frames=4, width=64, height=48)
    sc = replace(sc, render=replace(sc.render, gif=True))
    out = render_scene(sc, tmp_path / "a")
    gif = Image.open(out.gif)
    assert gif.n_frames == 4 and gif.size == (64, 48)
    assert Image.open(out.plot).size == (800, 500)

    def stop(done, total):
        if done == 3:
            raise KeyboardInterrupt

    cut = render_scene(
        load_scene("circle").with_overrides(width=64, height=48),
        tmp_path / "b",
        plot=False,
        progress=stop,
    )
    assert cut.interrupted and cut.frames == 3 and len(cut.metrics) == 3
    assert len(decode(cut.video)) == 3
    assert sum(1 for _ in open(cut.csv)) == 1 + 3
    assert not [p for p in cut.folder.iterdir() if ".tmp" in p.name]


@pytest.mark.slow
def test_failed_render_leaves_no_video(tmp_path, monkeypatch):
    """A run failing at frame 3 (not Ctrl-C) raises and leaves no new MP4 and no temporary.

    An earlier video under the final name is kept as it was."""
    from humanoid_ik.errors import SolverError
    from humanoid_ik.outputs.atomic import MANIFEST, write_json
    from humanoid_ik.run.runner import SceneRunner

    folder = tmp_path / "c"
    folder.mkdir()
    (folder / "circle.mp4").write_bytes(b"earlier video")
    write_json(folder / MANIFEST, {"files": ["circle.mp4"]})  # an earlier run's
    step = SceneRunner.step

    def failing(self, index):
        if index == 3:
            raise SolverError("solver failed at frame 3")
        return step(self, index)

    monkeypatch.setattr(SceneRunner, "step", failing)
    with pytest.raises(SolverError, match="frame 3"):
        render_scene(load_scene("circle").with_overrides(width=64, height=48), folder, plot=False)
    assert (folder / "circle.mp4").read_bytes() == b"earlier video"
    assert not [p for p in folder.iterdir() if ".tmp" in p.name]


# ----------------------------------------------------------------------------- CLI
@pytest.mark.slow
def test_render_command(tmp_path, capsys):
    """`humanoid-ik render` writes the outputs and prints a summary and the files."""
    out = tmp_path / "o"
    code = main(
        [
            "render",
            "gaze",
            "--out",
            str(out),
            "--frames",
            "3",
            "--width",
            "64",
            "--height",
            "48",
            "--camera",
            "side",
            "--solver",
            "dls",
            "--gif",
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert text.startswith("gaze: 3 frame(s) 64x48 camera side")
    assert "gaze_site -> fly (look_at): reachable 3/3" in text
    for name in ("gaze.mp4", "gaze.gif", "metrics.csv", "metrics.json", "metrics.png"):
        assert (out / name).is_file() and f"wrote {out / name}" in text
    assert len(decode(out / "gaze.mp4")) == 3


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--camera", "left"], "--camera 'left' not in model; cameras: front, side, top"),
        (["--solver", "magic"], "--solver 'magic' unknown; solvers: "),
        (["--width", "63"], "argument --width: expected an even integer >= 16, got '63'"),
        (["--height", "x"], "argument --height: expected an even integer >= 16, got 'x'"),
        (["--frames", "0"], "argument --frames: expected an integer >= 1, got '0'"),
        (["--frames", "two"], "argument --frames: expected an integer >= 1, got 'two'"),
        (["--fps", "-3"], "argument --fps: expected a number >= 0.01 and <= 1000, got '-3'"),
        (["--fps", "fast"], "argument --fps: expected a number >= 0.01 and <= 1000, got 'fast'"),
        (["--width", "4000"], "render.width: expected at most 1920"),
        (["--until", "7"], "--until 7 is after the end of scene 'circle' (4 s)"),
        (["--until", "-1"], "argument --until: expected a number of seconds > 0, got '-1'"),
        (["--frames", "10", "--fps", "5"], "--frames 10 sets the frame rate"),
    ],
)
def test_render_command_bad_input(tmp_path, capsys, args, message):
    """Bad input: exit 2, one stderr line naming the value and the choices, nothing rendered."""
    out = tmp_path / "o"
    assert main(["render", "circle", "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not out.exists() or not any(out.iterdir())


def test_render_command_unknown_scene(capsys):
    """An unknown scene lists the bundled ones."""
    assert main(["render", "nowhere"]) == 2
    assert "nowhere: no such scene file; expected a path or a bundled scene: both_hands" in (
        capsys.readouterr().err
    )


def test_output_folder_that_cannot_be_created(tmp_path, capsys):
    """An output folder under a file fails before rendering, in one line."""
    (tmp_path / "file").write_text("x")
    assert main(["render", "circle", "--out", str(tmp_path / "file" / "sub")]) == 2
    assert "cannot create output folder" in capsys.readouterr().err
    with pytest.raises(RenderError, match=r"cannot create output folder"):
        check_output_dir(tmp_path / "file")


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_output_folder_not_writable():
    """A folder that exists but takes no files (here /proc/self) is refused before rendering."""
    with pytest.raises(RenderError, match=r"output folder '/proc/self' is not writable"):
        check_output_dir("/proc/self")


# ----------------------------------------------------------------------------- backends
def test_backend_from_mujoco_gl(monkeypatch):
    """MUJOCO_GL chosen by the user is used; 'disable' and unknown names are errors."""
    assert select_backend().name == "egl"  # the tests set MUJOCO_GL=egl (conftest)
    monkeypatch.setattr(backend_mod, "_BACKEND", None)
    monkeypatch.setenv("MUJOCO_GL", "disable")
    with pytest.raises(RenderError, match=r"MUJOCO_GL='disable' turns rendering off"):
        select_backend()
    monkeypatch.setenv("MUJOCO_GL", "vulkan")
    with pytest.raises(
        RenderError,
        match=r"MUJOCO_GL='vulkan' is not an OpenGL backend; expected one of egl, osmesa",
    ):
        select_backend()


def _cli(tmp_path: Path, env_update: dict[str, str], unset=("MUJOCO_GL",)):
    """Run a 2-frame ``humanoid-ik render circle`` in a child process with ``env_update``
    and without the ``unset`` variables; returns the finished process."""
    env = {k: v for k, v in os.environ.items() if k not in (*unset, "PYOPENGL_PLATFORM")}
    env.update(env_update)
    out = tmp_path / "o"
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "humanoid_ik",
            "render",
            "circle",
            "--frames",
            "2",
            "--width",
            "32",
            "--height",
            "24",
            "--no-video",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )


@pytest.mark.slow
def test_default_backend_is_egl(tmp_path):
    """Without MUJOCO_GL the command renders with EGL (no GPU, no display needed)."""
    proc = _cli(tmp_path, {}, unset=("MUJOCO_GL", "DISPLAY"))
    assert proc.returncode == 0, proc.stderr
    assert "frames/s (egl)" in proc.stdout and "note" not in proc.stderr


@pytest.mark.slow
def test_broken_egl_falls_back_or_says_what_to_install(tmp_path):
    """Broken EGL: the command falls back to OSMesa with a note, or says what to install.

    EGL is broken by pointing it at no vendor library; when OSMesa is missing too the
    command fails in one line naming the packages to install."""
    proc = _cli(tmp_path, {"__EGL_VENDOR_LIBRARY_FILENAMES": str(tmp_path / "none.json")})
    if proc.returncode == 0:
        assert "frames/s (osmesa)" in proc.stdout
        assert "note: EGL does not work here" in proc.stderr
        assert "rendering with OSMesa" in proc.stderr
    else:
        assert proc.returncode == 2
        assert proc.stderr.count("\n") == 1
        assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in proc.stderr
        assert "libosmesa6" in proc.stderr


@pytest.mark.slow
def test_backend_without_display_fails_in_one_line(tmp_path):
    """MUJOCO_GL=glfw on a machine without a display fails in one line with the hint."""
    proc = _cli(tmp_path, {"MUJOCO_GL": "glfw"}, unset=("MUJOCO_GL", "DISPLAY", "WAYLAND_DISPLAY"))
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1
    assert "MUJOCO_GL=glfw" in proc.stderr and "libegl1" in proc.stderr


def _read_terminal(fd: int, until: bytes | None, timeout: float) -> bytes:
    """What a child process writes to a pseudo-terminal: read until the regular expression
    ``until`` matches (``None``: until the child closes it), failing after ``timeout`` [s]."""
    out = b""
    deadline = time.monotonic() + timeout
    while until is None or not re.search(until, out):
        left = deadline - time.monotonic()
        assert left > 0, f"no {until!r} within {timeout} s; the terminal showed {out!r}"
        ready, _, _ = select.select([fd], [], [], left)
        if not ready:
            continue
        try:
            chunk = os.read(fd, 65536)
        except OSError:  # EIO: every writer has closed the terminal
            chunk = b""
        if not chunk:
            assert until is None, f"closed before {until!r}; the terminal showed {out!r}"
            break
        out += chunk
    return out


@pytest.mark.slow
def test_ctrl_c_keeps_a_valid_shorter_video(tmp_path):
    """SIGINT mid-render: exit 130, a valid MP4 and metrics of the frames rendered so far.

    The command's stderr is a pseudo-terminal, so it shows its progress bar; the test
    sends SIGINT once the bar counts a finished frame (no fixed wait), then checks that the
    video, the CSV and the summary all hold the count the command reports."""
    out = tmp_path / "o"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    term, child_end = pty.openpty()
    # a terminal of 80 columns: with no size the bar would be drawn 0 columns wide
    fcntl.ioctl(child_end, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 80, 0, 0))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "humanoid_ik",
            "render",
            "circle",
            "--frames",
            "3000",
            "--width",
            "32",
            "--height",
            "24",
            "--out",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=child_end,
        env=env,
    )
    os.close(child_end)
    try:
        _read_terminal(term, rb"\b[1-9]\d*/3000\b", timeout=120)  # a frame is done
        proc.send_signal(signal.SIGINT)
        stderr = _read_terminal(term, None, timeout=120).decode(errors="replace")
        stdout = proc.communicate(timeout=120)[0].decode()
    finally:
        os.close(term)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, stderr
    n = int(re.search(r"interrupted after (\d+) frame", stderr).group(1))
    assert 0 < n < 3000
    assert len(decode(out / "circle.mp4")) == n
    assert sum(1 for _ in open(out / "metrics.csv")) == 1 + n
    assert f"circle: {n} frame(s)" in stdout
    assert not list(out.glob(".*tmp*"))


@pytest.mark.slow
def test_render_is_a_sink_of_the_runner(renders):
    """render_scene measures exactly what run_scene does: one frame loop, rendering beside it."""
    sc, out = renders["both_hands"]
    plain = run_scene(sc)
    assert len(plain) == len(out.metrics) == N
    for k in range(len(sc.effectors)):
        for attribute in ("position_error", "iterations", "reachable", "on_target"):
            np.testing.assert_array_equal(
                out.metrics.series(k, attribute), plain.series(k, attribute), attribute
            )
    assert len(out.metrics.frame_times) == N


@pytest.mark.slow
def test_backend_choice_lists_what_it_changed(tmp_path):
    """Without MUJOCO_GL, select_backend picks EGL and lists each process change it made."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    code = (
        "import os\n"
        "from humanoid_ik.outputs.render import select_backend\n"
        "b = select_backend()\n"
        "assert select_backend() is b\n"
        "print(b.name, b.chosen_by, os.environ['MUJOCO_GL'])\n"
        "print('\\n'.join(b.changes))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0] == "egl default egl"
    assert "os.environ['MUJOCO_GL'] = 'egl'" in lines[1:]
    assert any(ln.endswith(".GLContext = mujoco.egl.GLContext") for ln in lines[1:]), lines


@pytest.mark.slow
def test_frames_preview_the_whole_scene(tmp_path, capsys):
    """`--frames 48` on out_of_reach spreads 48 frames over its 6 s: the target leaves
    reach and comes back, and each of the four snapshot times gets its own PNG, no note."""
    out = tmp_path / "o"
    args = ["render", "out_of_reach", "--frames", "48", "--out", str(out)]
    assert main([*args, "--width", "32", "--height", "24", "--no-video"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.startswith("out_of_reach: 48 frame(s)")
    assert "reachable 25/48" in captured.out
    m = json.loads((out / "metrics.json").read_text())
    times = [s["time_s"] for s in m["samples"]]
    assert len(times) == 48 and times[-1] == pytest.approx(5.875)
    reach = [s["reachable"] for s in m["samples"]]
    assert reach[0] and not all(reach) and reach[-1]  # away in the middle, back at the end
    snaps = sorted(p.name for p in out.glob("frame_*.png"))
    assert snaps == ["frame_0004.png", "frame_0020.png", "frame_0024.png", "frame_0044.png"]


def test_until_cuts_and_says_which_snapshots_fall_after(tmp_path, capsys):
    """`--until 2 --frames 10`: 10 frames over the first 2 s; the three snapshot times
    after 1.8 s are named in one note line and the last frame is saved for them."""
    out = tmp_path / "o"
    args = ["render", "out_of_reach", "--until", "2", "--frames", "10", "--out", str(out)]
    assert main([*args, "--width", "32", "--height", "24", "--no-video"]) == 0
    captured = capsys.readouterr()
    assert captured.err == (
        "humanoid-ik: note: snapshot(s) at 2.5 s, 3 s, 5.5 s after the last rendered frame "
        "#9 (1.80 s); that frame is saved for them\n"
    )
    m = json.loads((out / "metrics.json").read_text())
    assert [s["time_s"] for s in m["samples"]][-1] == pytest.approx(1.8)
    snaps = sorted(p.name for p in out.glob("frame_*.png"))
    assert snaps == ["frame_0002.png", "frame_0009.png"]


def test_snapshot_times_on_one_frame_are_named():
    """Two snapshot times on the same frame give one PNG and a note naming both."""
    from humanoid_ik.outputs.render.stills import snapshot_plan

    idx, notes = snapshot_plan([0.5, 0.55, 1.0], fps=4.0, n=8)
    assert idx == [2, 4]
    assert notes == [
        "snapshots at 0.5 s, 0.55 s fall on the same frame #2 (0.50 s at 4 frames/s); one PNG"
    ]
    assert snapshot_plan([], fps=4.0, n=8) == ([0, 2, 5, 7], [])
