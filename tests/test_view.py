"""The live viewer for real: MuJoCo's passive viewer in a subprocess under a virtual X
server (xvfb-run, MUJOCO_GL=glfw) follows the scene's moving targets, writes the
trajectory of the frames it showed and exits 0; without a display it says so in one
line. Dragging and pausing are checked on the viewer's own target logic and MjData."""

from __future__ import annotations

import os
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.measures import ON_TARGET_DISTANCE
from humanoid_ik.outputs.render import MARKER_RADIUS, marker_radius
from humanoid_ik.outputs.trajectory import load_trajectory
from humanoid_ik.outputs.viewer import (
    KEY_PAUSE,
    KEY_RELEASE,
    LiveTargets,
    mocap_model,
    scene_mocap_model,
)
from humanoid_ik.run.runner import SceneRunner
from tests.robots import robot_file

REPO = Path(__file__).resolve().parents[1]


def view(tmp_path: Path, *args: str) -> tuple[subprocess.CompletedProcess, Path]:
    """`humanoid-ik view ARGS --out DIR` under xvfb-run with MUJOCO_GL=glfw."""
    xvfb = shutil.which("xvfb-run")
    assert xvfb is not None, "xvfb-run is not installed (Debian: apt-get install xvfb)"
    out = tmp_path / "view"
    env = {**os.environ, "MUJOCO_GL": "glfw"}
    cmd = [xvfb, "-a", sys.executable, "-m", "humanoid_ik", "view", *args, "--out", str(out)]
    proc = subprocess.run(
        cmd, capture_output=True, text=True, env=env, timeout=180, cwd=tmp_path, check=False
    )
    return proc, out


@pytest.mark.slow
def test_view_follows_the_circle(tmp_path):
    """2 s of `circle` at 30 frames/s: 60 frames shown, the target travels round its
    circle and the palm stays on it (within the on-target distance) in every frame."""
    proc, out = view(tmp_path, "circle", "--duration", "2")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("circle: 60 frame(s) shown")
    t = load_trajectory(out / "trajectory.npz")
    assert t.n_frames == 60 and t.scene == "circle"
    e = t.effectors[0]
    assert np.ptp(e.target, axis=0).max() > 0.15  # the target moved
    assert np.ptp(e.achieved, axis=0).max() > 0.15  # and so did the hand
    assert e.position_error.max() < ON_TARGET_DISTANCE
    np.testing.assert_allclose(e.achieved, e.target, atol=ON_TARGET_DISTANCE)
    scene = load_scene("circle")
    np.testing.assert_allclose(e.target[30], scene.targets[0].at(t.time[30]).position)


@pytest.mark.slow
def test_view_tracks_both_hands_and_the_gaze_with_mink(tmp_path):
    """upper_body_mink (both hands and the gaze in one QP) tracks live: every effector
    within the on-target distance in every frame after the first few."""
    proc, out = view(tmp_path, "upper_body_mink", "--duration", "1.5")
    assert proc.returncode == 0, proc.stderr
    t = load_trajectory(out / "trajectory.csv")
    assert [e.site for e in t.effectors] == ["right_palm_site", "left_palm_site", "gaze_site"]
    assert all(e.solver.startswith("mink") for e in t.effectors)
    for e in t.effectors:
        assert e.position_error[5:].max() < ON_TARGET_DISTANCE, (e.site, e.position_error)
    assert np.ptp(t.effectors[1].target, axis=0).max() > 0.05


@pytest.mark.slow
def test_view_model_and_site(tmp_path):
    """`--site left_palm_site`: one target held at the palm's home position; the arm
    stays there."""
    proc, out = view(tmp_path, "--site", "left_palm_site", "--solver", "dls", "--duration", "0.5")
    assert proc.returncode == 0, proc.stderr
    t = load_trajectory(out / "trajectory.npz")
    e = t.effectors[0]
    assert e.site == "left_palm_site" and e.solver == "dls" and t.n_frames == 15
    assert e.position_error.max() < 1e-6
    assert np.ptp(e.target, axis=0).max() == 0.0


@pytest.mark.slow
def test_view_urdf_model_and_body(tmp_path):
    """`--model arm7.urdf --body tool_link`: a URDF arm without sites, on the default
    stage; the tool link is held at its home position."""
    urdf = Path(__file__).resolve().parents[1] / "examples" / "urdf_arm" / "arm7.urdf"
    args = ("--model", str(urdf), "--body", "tool_link", "--solver", "lm", "--duration", "0.5")
    proc, out = view(tmp_path, *args)
    assert proc.returncode == 0, proc.stderr
    t = load_trajectory(out / "trajectory.npz")
    e = t.effectors[0]
    assert e.solver == "lm" and t.n_frames == 15
    assert e.position_error.max() < 1e-6
    assert len(t.joint_names) == 7


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


@pytest.mark.slow
def test_view_sigterm_writes_the_trajectory(tmp_path):
    """SIGTERM to a running viewer (no --duration): the frames shown so far are written
    as an interrupted trajectory, the hand was on the target, and the exit status is 143."""
    xvfb = shutil.which("xvfb-run")
    assert xvfb is not None, "xvfb-run is not installed (Debian: apt-get install xvfb)"
    out = tmp_path / "view"
    cmd = [xvfb, "-a", sys.executable, "-m", "humanoid_ik", "view", "circle", "--out", str(out)]
    env = {**os.environ, "MUJOCO_GL": "glfw"}
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path
    )
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 120)
        assert ready, "the viewer did not open within 120 s"
        assert "viewer open" in proc.stderr.readline()
        time.sleep(2.0)  # some frames
        (viewer,) = [
            c
            for c in _children(proc.pid)
            if b"humanoid_ik" in Path(f"/proc/{c}/cmdline").read_bytes()
        ]
        os.kill(viewer, signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, stderr
    assert "humanoid-ik: interrupted after" in stderr and "wrote" in stdout
    t = load_trajectory(out / "trajectory.npz")
    assert t.interrupted and t.n_frames >= 2
    assert t.effectors[0].position_error.max() < ON_TARGET_DISTANCE


def test_view_without_display(monkeypatch, capsys):
    """No display: exit 2, one line saying so and pointing at `render`."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", "circle"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "view needs a display (DISPLAY is not set)" in err and "humanoid-ik render" in err


def test_view_bad_input(capsys):
    """A scene with --site, an unknown solver: exit 2, one line."""
    assert main(["view", "circle", "--site", "left_palm_site"]) == 2
    assert "give a SCENE or --model/--site/--body/--arm/--limb, not both" in capsys.readouterr().err
    assert main(["view", "circle", "--duration", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "expected a number of seconds > 0, got '0'" in err


def test_dragged_target_is_followed_and_pause_holds_time():
    """The viewer's target logic on real MjData: the mocap body follows the motion; a
    mocap body moved by the user (as MuJoCo's drag does) becomes the target and the
    solver puts the palm there; space pauses the motion; Backspace releases the drag."""
    scene = load_scene("circle")
    model, mocap = mocap_model(scene.model, [t.name for t in scene.targets])
    runner = SceneRunner(scene, model)
    live = LiveTargets(runner, mocap)
    d = runner.data
    dt = 1 / 30
    targets = live.update(d, 0.0)
    np.testing.assert_allclose(d.mocap_pos[mocap[0]], scene.targets[0].at(0.0).position)
    runner.step(0, targets, live.time)
    targets = live.update(d, dt)
    np.testing.assert_allclose(d.mocap_pos[mocap[0]], scene.targets[0].at(dt).position)
    # the user drags the target to a new point between frames
    dragged = np.array([0.40, -0.15, 1.25])
    d.mocap_pos[mocap[0]] = dragged
    for i in range(2, 40):
        rec = runner.step(i, live.update(d, dt), live.time)
    assert live.dragged == [True]
    np.testing.assert_allclose(rec.samples[0].target, dragged)
    np.testing.assert_allclose(d.site("right_palm_site").xpos, dragged, atol=ON_TARGET_DISTANCE)
    # pause: time stands still; resume: it moves again
    live.key(KEY_PAUSE)
    t0 = live.time
    live.update(d, dt)
    assert live.time == t0
    live.key(KEY_PAUSE)
    live.key(KEY_RELEASE)
    targets = live.update(d, dt)
    assert live.dragged == [False] and live.time == pytest.approx(t0 + dt)
    np.testing.assert_allclose(targets[0].position, scene.targets[0].at(live.time).position)
    np.testing.assert_allclose(d.mocap_pos[mocap[0]], targets[0].position)


def test_mocap_model_adds_one_body_per_target():
    """The viewer's model has one non-colliding mocap sphere per target and the same
    joints as the scene's model."""
    scene = load_scene("both_hands")
    model, mocap = mocap_model(scene.model, [t.name for t in scene.targets])
    base = mujoco.MjModel.from_xml_path(str(scene.model))
    assert model.nmocap == len(scene.targets) == len(mocap) and sorted(mocap) == [0, 1]
    assert model.nq == base.nq and model.njnt == base.njnt
    for t in scene.targets:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"target_{t.name}")
        g = model.body_geomadr[b]
        assert model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0


def _marker_sizes(model: mujoco.MjModel, names: list[str]) -> list[float]:
    """The radius [m] of each target's mocap sphere."""
    out = []
    for n in names:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"target_{n}")
        out.append(float(model.geom_size[model.body_geomadr[b], 0]))
    return out


def test_viewer_markers_are_sized_as_a_films(tmp_path):
    """The viewer's target spheres have a film's marker radius, from the same rule
    (marker_radius of the reaching chains): 0.02 m on the bundled humanoid, about
    0.0098 m on SO-100's 0.45 m arm (no longer a fixed 0.025 m); the viewer's model faces
    SO-100 as a film does (its front camera looks along -y, where the jaw points)."""
    both = load_scene("both_hands")
    model, _ = scene_mocap_model(both)
    names = [t.name for t in both.targets]
    assert _marker_sizes(model, names) == [pytest.approx(MARKER_RADIUS, abs=1e-12)] * 2
    urdf = robot_file("so100")
    path = tmp_path / "so100.toml"
    path.write_text(
        f'name = "so100"\nmodel = "{urdf}"\nduration = 1.0\nfps = 2\n[solver]\nname = "dls"\n'
        '[[targets]]\nname = "p"\nmotion = { kind = "points", points = [[0.0, -0.25, 0.15]], '
        "hold = 1.0, travel = 0.0 }\n"
        '[[effectors]]\nbody = "jaw"\ntarget = "p"\n'
    )
    scene = load_scene(path)
    model, mocap = scene_mocap_model(scene)
    runner = SceneRunner(scene, model)
    (radius,) = _marker_sizes(model, ["p"])
    assert radius == pytest.approx(marker_radius(runner.chains), abs=1e-12)
    assert radius == pytest.approx(0.0098, rel=0.05) and len(mocap) == 1
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    view_dir = -data.cam("front").xmat.reshape(3, 3)[:, 2]  # a camera looks along its -z
    assert view_dir[1] > 0.8 * np.linalg.norm(view_dir[:2]), view_dir  # toward +y: at the jaw
