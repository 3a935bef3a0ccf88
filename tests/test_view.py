"""The live viewer for real: MuJoCo's passive viewer in a subprocess under a virtual X
server of the test's own (Xvfb, MUJOCO_GL=glfw) follows the scene's moving targets, writes the
trajectory of the frames it showed and exits 0; without a display it says so in one
line. Dragging and pausing are checked on the viewer's own target logic and MjData.
Start-up under signals (issue 24, item 10): 20 SIGINT/SIGTERM at random moments of the
window's opening under an Xvfb of the test's own: no segfault, no hang, 130/143 (or 0),
nothing half written, nothing left running."""

from __future__ import annotations

import os
import random
import select
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.measures import ON_TARGET_DISTANCE
from humanoid_ik.outputs.atomic import published
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
from tests.processes import (
    MESSAGE,
    STATUS,
    ended,
    handles,
    none_left,
    signal_when,
    start,
    temporaries,
    virtual_display,
)
from tests.robots import robot_file

REPO = Path(__file__).resolve().parents[1]


def view(tmp_path: Path, *args: str) -> tuple[subprocess.CompletedProcess, Path]:
    """`humanoid-ik view ARGS --out DIR` on a virtual display of its own, MUJOCO_GL=glfw."""
    out = tmp_path / "view"
    cmd = [sys.executable, "-m", "humanoid_ik", "view", *args, "--out", str(out)]
    with virtual_display() as display:
        env = {**os.environ, "MUJOCO_GL": "glfw", "DISPLAY": display}
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


@pytest.mark.slow
def test_a_signal_while_glfw_loads_leaves_no_traceback(tmp_path):
    """Importing glfw (the viewer's display check) runs a child Python that reads the
    library's file name from a pipe: SIGTERM to the viewer the moment that child exists
    (4 times) used to leave it an EOF and a traceback on stderr. Held now: 143, the one
    line, no traceback."""
    with virtual_display() as display:
        env = {**os.environ, "MUJOCO_GL": "egl", "DISPLAY": display}  # glfw not loaded yet
        for _ in range(4):
            proc = subprocess.Popen(
                [sys.executable, "-m", "humanoid_ik", "view", "circle", "--duration", "1"],
                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                env=env, cwd=tmp_path,
            )  # fmt: skip
            children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children")
            deadline = time.monotonic() + 60
            while proc.poll() is None and time.monotonic() < deadline:
                if handles(proc, signal.SIGTERM) and children.read_text().split():
                    proc.send_signal(signal.SIGTERM)  # the child: glfw's version check
                    break
            _, err = proc.communicate(timeout=60)
            assert proc.returncode == 143, err
            assert "Traceback" not in err.decode() and err.decode().count("\n") == 1, err


@pytest.mark.slow
def test_view_sigterm_writes_the_trajectory(tmp_path):
    """SIGTERM to a running viewer (no --duration): the frames shown so far are written
    as an interrupted trajectory, the hand was on the target, and the exit status is 143."""
    out = tmp_path / "view"
    cmd = [sys.executable, "-m", "humanoid_ik", "view", "circle", "--out", str(out)]
    with virtual_display() as display:
        env = {**os.environ, "MUJOCO_GL": "glfw", "DISPLAY": display}
        proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path
        )
        try:
            ready, _, _ = select.select([proc.stderr], [], [], 120)
            assert ready, "the viewer did not open within 120 s"
            assert "viewer open" in proc.stderr.readline()
            time.sleep(2.0)  # some frames
            proc.send_signal(signal.SIGTERM)
            stdout, stderr = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
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
    assert err.count("\n") == 1 and "expected a finite number of seconds > 0, got '0'" in err


@pytest.mark.parametrize(
    ("duration", "expected"),
    [
        ("inf", "expected a finite number of seconds > 0, got 'inf'"),
        ("nan", "expected a finite number of seconds > 0, got 'nan'"),
        ("-inf", "expected a finite number of seconds > 0, got '-inf'"),
        (
            "1e308",
            "expected a number > 0 and <= 3333.33 (at most 100000 frames at 30 fps), got '1e+308'",
        ),
        (
            "3334",
            "expected a number > 0 and <= 3333.33 (at most 100000 frames at 30 fps), got '3334'",
        ),
    ],
)
def test_view_duration_is_bounded_before_anything_opens(
    tmp_path, monkeypatch, capsys, duration, expected
):
    """--duration inf or 1e308 (an OverflowError once the viewer was up): one line naming
    the bound, exit 2, before the display is even looked at (none here) and with
    nothing written: --out is not created."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    out = tmp_path / "view"
    assert main(["view", "circle", f"--duration={duration}", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"humanoid-ik: error: view: argument --duration: {expected}\n"
    assert not out.exists()


def test_view_duration_rule_of_the_library():
    """view_scene checks the same bound as the command line (a script gets the line)."""
    from humanoid_ik.errors import RenderError
    from humanoid_ik.outputs.viewer import duration_rule, view_scene

    assert duration_rule(3333.0, 30.0) is None and duration_rule(1.0, 1000.0) is None
    assert duration_rule(float("inf"), 30.0) == "a finite number > 0"
    assert duration_rule(1e308, 30.0) == duration_rule(3334.0, 30.0)
    assert "at most 100000 frames at 30 fps" in str(duration_rule(1e308, 30.0))
    with pytest.raises(RenderError, match=r"view duration: expected a finite number > 0, got inf"):
        view_scene(load_scene("circle"), duration=float("inf"))


def _free_display() -> str:
    """A display number no X server serves here (no socket, no lock file)."""
    for n in range(917, 999):
        if not Path(f"/tmp/.X11-unix/X{n}").exists() and not Path(f"/tmp/.X{n}-lock").exists():
            return f":{n}"
    raise AssertionError("no free display number")


def test_view_bad_display_is_one_line_and_leaves_nothing(tmp_path, monkeypatch, capsys):
    """DISPLAY naming no X server: exit 2 and one line with GLFW's reason (it used to be
    MuJoCo's exit 1 from C), no MUJOCO_LOG.TXT in the current folder, no --out made."""
    display = _free_display()
    monkeypatch.setenv("DISPLAY", display)
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "view"
    assert main(["view", "circle", "--duration", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"view needs a display (X11: Failed to open display {display})" in err
    assert "humanoid-ik render" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_view_refuses_an_out_holding_the_users_trajectory(tmp_path, monkeypatch, capsys):
    """--out holding a trajectory.csv of the user's (no manifest names it): refused in one
    line before the session (publishing it would be refused after), the file untouched."""
    monkeypatch.delenv("DISPLAY", raising=False)
    out = tmp_path / "mine"
    out.mkdir()
    (out / "trajectory.csv").write_text("the user's own\n")
    assert main(["view", "circle", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds 'trajectory.csv', which no earlier run wrote" in err
    assert (out / "trajectory.csv").read_text() == "the user's own\n"
    assert sorted(p.name for p in out.iterdir()) == ["trajectory.csv"]


def test_signals_held_defers_a_signal_another_thread_takes():
    """A SIGINT the kernel hands to another thread (as it does when the main thread blocks
    it: OpenBLAS's threads, the viewer's) is raised when the held block ends, not in its
    middle (where the viewer's window handle would be lost, the window never closed);
    the handler is put back."""
    from humanoid_ik.outputs.atomic import signals_held

    handler = signal.getsignal(signal.SIGINT)
    done = threading.Event()
    other = threading.Thread(target=done.wait)
    other.start()
    steps: list[int] = []
    try:
        with pytest.raises(KeyboardInterrupt), signals_held():
            assert other.ident is not None
            signal.pthread_kill(other.ident, signal.SIGINT)
            for k in range(200):  # bytecode and a sleep: where Python would run the handler
                steps.append(k)
                time.sleep(0.001)
            steps.append(-1)
    finally:
        done.set()
        other.join()
    assert steps[-1] == -1 and len(steps) == 201
    assert signal.getsignal(signal.SIGINT) is handler


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


@pytest.fixture(scope="module")
def xvfb() -> Iterator[str]:
    """A virtual X server of this module's own."""
    with virtual_display() as display:
        yield display


def _loaded(proc: subprocess.Popen, library: bytes) -> bool:
    """Whether ``proc`` has mapped a shared library whose name holds ``library``."""
    return library in Path(f"/proc/{proc.pid}/maps").read_bytes()


VIEW_SIGNALS = 20
"""Signals sent in the start-up test: SIGINT and SIGTERM, 10 each."""
VIEW_SIGNAL_SEED = 24_10
"""The seed of their moments (in every failure message, to run one again)."""


def _view_signalled(k: int, out: Path, moments: random.Random) -> dict:
    """Start ``view circle --duration 1 --out OUT`` and send trial ``k``'s signal at a
    random moment of its start-up: up to 2 s after the command line is up (its SIGTERM
    handler installed: scene, model and window still to come), or, every other pair of
    trials, up to 1.5 s after the viewer module is loaded (``_simulate``: the mocap
    model, the window's thread, the window's creation, its first frames)."""
    sig = (signal.SIGINT, signal.SIGTERM)[k % 2]
    tag = uuid.uuid4().hex
    proc = start(["view", "circle", "--duration", "1", "--out", str(out)], tag)
    if k % 4 < 2:
        moment, after = "up", moments.uniform(0.0, 2.0)
        ready = lambda: handles(proc, signal.SIGTERM)  # noqa: E731
    else:
        moment, after = "viewer", moments.uniform(0.0, 1.5)
        ready = lambda: _loaded(proc, b"_simulate")  # noqa: E731
    sent = signal_when(proc, sig, ready, after=after, within=60)
    try:  # the window's creation had begun (its GL library loaded) when the signal went
        making = sent and _loaded(proc, b"libGLX")
    except OSError:  # it has ended already
        making = False
    try:
        stdout, stderr, hang = *ended(proc, tag, 60), ""
    except AssertionError as exc:  # it hung: killed, with all it started
        stdout, stderr, hang = b"", b"", str(exc)
    return {
        "k": k,
        "sig": sig,
        "moment": f"{moment} + {after:.2f} s",
        "sent": sent,
        "making": making,
        "status": proc.returncode,
        "stdout": stdout.decode(),
        "stderr": stderr.decode(),
        "hang": hang,
        "left": none_left(tag),
        "out": out,
    }


def _check_view_trial(t: dict) -> str:
    """One trial's outcome, checked: what the status says happened is on disk; returns
    which it was."""
    sig, status, err, out = t["sig"], t["status"], t["stderr"], t["out"]
    assert not t["hang"], t["hang"]
    assert status != -signal.SIGSEGV, "segfault"
    for text in ("Traceback", "X Error", "Fatal Python", "MUJOCO_LOG"):
        assert text not in err
    assert t["left"] == [], "processes left"
    assert temporaries(out.parent) == []
    assert not (out.parent / "MUJOCO_LOG.TXT").exists()
    lines = err.splitlines()
    whole = t["stdout"].startswith("circle: 30 frame(s) shown")
    if status == 0 or (status == -sig and whole):  # ended first, or the signal met its exit
        assert whole and not lines[-1].startswith("humanoid-ik: interrupted")
        traj = load_trajectory(out / "trajectory.npz")
        assert traj.n_frames == 30 and not traj.interrupted
        return "ended first" if status == 0 else "at exit"
    assert t["sent"] and status == STATUS[sig]
    if lines[-1] == MESSAGE[sig] and not out.exists():  # before the first frame
        assert "frame(s) shown" not in t["stdout"]
        if "viewer open" in err:
            return "before a frame"
        return "while the window was made" if t["making"] else "before the window"
    if lines[-1] == MESSAGE[sig]:  # while publishing or closing: the set is whole
        npz, csv = (load_trajectory(out / f"trajectory.{e}") for e in ("npz", "csv"))
        assert npz.n_frames == csv.n_frames >= 1
        return "while closing"
    frames = int(lines[-1].removeprefix("humanoid-ik: interrupted after ").split()[0])
    traj = load_trajectory(out / "trajectory.csv")
    assert frames >= 1 and traj.n_frames == frames and traj.interrupted
    assert sorted(p.name for p in out.iterdir() if p.name[0] != ".") == [
        "trajectory.csv",
        "trajectory.npz",
    ]
    return "during the frames"


@pytest.mark.slow
def test_view_start_up_under_signals(tmp_path, monkeypatch, xvfb):
    """20 SIGINT/SIGTERM at random moments of the viewer's start-up (two runs at a time,
    one shared Xvfb): the window's creation used to segfault (exit 139) or hang on an
    X error when one landed there. Each run ends within 60 s with 130/143 (or 0 when it
    ended first), one line, no traceback; a run stopped before its first frame wrote
    nothing (no --out folder), one stopped later wrote its interrupted trajectory; no
    temporary, no MUJOCO_LOG.TXT, no process of it left."""
    monkeypatch.setenv("DISPLAY", xvfb)
    monkeypatch.chdir(tmp_path)  # where a MUJOCO_LOG.TXT would appear
    moments = random.Random(VIEW_SIGNAL_SEED)
    plan = [
        (k, tmp_path / f"run{k}" / "view", random.Random(moments.random()))
        for k in range(VIEW_SIGNALS)
    ]
    for _, out, _ in plan:
        out.parent.mkdir()
    with ThreadPoolExecutor(max_workers=2) as pool:
        trials = list(pool.map(lambda p: _view_signalled(*p), plan))
    seen: dict[str, int] = {}
    for t in trials:
        context = {k: t[k] for k in ("k", "sig", "moment", "sent", "status")}
        try:
            outcome = _check_view_trial(t)
        except (AssertionError, OSError, IndexError, ValueError) as exc:
            raise AssertionError(
                f"seed {VIEW_SIGNAL_SEED}: {context}: {exc}\n{t['stderr'][-1500:]}"
            ) from exc
        seen[outcome] = seen.get(outcome, 0) + 1
    print(f"view start-up under {VIEW_SIGNALS} signals: {seen}")


@pytest.mark.slow
def test_view_out_into_a_renders_folder_replaces_its_set(tmp_path, monkeypatch, xvfb):
    """`view --out` onto a folder holding a render: the viewer's trajectory replaces the
    render's set as one (video, frames, metrics gone, the manifest naming only the
    viewer's two files), not a mix of both runs (it used to write its trajectory
    directly, beside the render's files)."""
    out = tmp_path / "shared"
    assert main(["render", "circle", "--frames", "2", "--out", str(out)]) == 0
    assert (out / "circle.mp4").exists() and (out / "metrics.csv").exists()
    (out / "notes.txt").write_text("the user's own\n")  # never touched
    monkeypatch.setenv("DISPLAY", xvfb)
    tag = uuid.uuid4().hex
    proc = start(["view", "circle", "--duration", "0.5", "--out", str(out)], tag)
    stdout, stderr = ended(proc, tag, 120)
    assert proc.returncode == 0, stderr.decode()
    assert stdout.decode().splitlines() == [
        "circle: 15 frame(s) shown",
        f"wrote {out / 'trajectory.npz'}",
        f"wrote {out / 'trajectory.csv'}",
    ]
    assert sorted(p.name for p in out.iterdir() if p.name[0] != ".") == [
        "notes.txt",
        "trajectory.csv",
        "trajectory.npz",
    ]
    assert published(out) == ["trajectory.csv", "trajectory.npz"]
    assert load_trajectory(out / "trajectory.npz").n_frames == 15
    assert temporaries(out) == [] and none_left(tag) == []
