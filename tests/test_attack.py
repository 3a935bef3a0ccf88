"""Regression table of the attack on the command line (issue 14): each bad input as
(command arguments, expected exit status, expected message fragment), run through the
real CLI, ``humanoid_ik.cli.main(argv)`` in-process, and a few as real subprocesses.

Placeholders in the arguments are files the ``files`` fixture writes: ``{sweep}`` (a
one-job sweep file), ``{tmp}`` (the test's folder), ``{scene:NAME}`` (the bundled
``circle`` scene with one value changed, see :data:`SCENE_EDITS`) and ``{sweep:NAME}``
(the one-job sweep with one value changed, see :data:`SWEEP_EDITS`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import Chain, Target
from humanoid_ik.cli import main
from humanoid_ik.core.models import bundled_dir
from humanoid_ik.motion import MAX_KNOTS, Points, RandomWalk
from humanoid_ik.solvers.jacobian.dls import DLS
from tests.chains import PLANAR_ARM_XML

SWEEP = """
name = "attack"
solvers = ["closed_form"]

[[targets]]
name = "a"
n = 2
"""

CIRCLE_MOTION = (
    "[targets.motion]\n"
    "# center: 0.63 reach forward of the right shoulder, 0.21 out to the right, 0.32 down; "
    "radius 0.19\n"
    "# reach (on the bundled humanoid: center [0.40, -0.32, 1.20] m, radius 0.12 m); normal: "
    "forward\n"
    'kind = "circle"\n'
    'center = { limb = "right_arm", at = [0.634920635, -0.206349206, -0.317460317] }\n'
    'radius = { limb = "right_arm", reach = 0.19047619 }\n'
    "normal = { robot = [1, 0, 0] }\n"
    "period = 4.0"
)
"""circle.toml's motion table, which the edits below replace by another motion."""

SCENE_EDITS = {
    "duration": ("duration = 4.0", "duration = 1e300"),
    "duration-inf": ("duration = 4.0", "duration = 1e308"),  # x fps overflows to inf
    "long": ("duration = 4.0", "duration = 3334.0"),
    "fps": ("fps = 30", "fps = 0.001"),
    "trail": ("trail = 2.0", "trail = 1e300"),
    "width": ('camera = "front"', 'camera = "front"\nwidth = 10000'),
    "sheet": ('camera = "front"', 'camera = "front"\ncontact_sheet = 1000000'),
    "snapshots": ('camera = "front"', f'camera = "front"\nsnapshots = {[0.0] * 101}'),
    "interval": (
        CIRCLE_MOTION,
        'motion = { kind = "random_walk", center = [0.4, -0.3, 1.2], '
        "half_extent = [0.1, 0.1, 0.1], interval = 1e-9 }",
    ),
    "walk": (
        CIRCLE_MOTION,
        'motion = { kind = "random_walk", center = [0.4, -0.3, 1.2], '
        "half_extent = [0.1, 0.1, 0.1], interval = 0.001 }",
    ),
    "points": (
        CIRCLE_MOTION,
        'motion = { kind = "points", points = ' + str([[0.4, -0.3, 1.2]] * 10_001) + " }",
    ),
}
"""Scene files that break a bound: name -> (text of circle.toml, replaced by)."""

SWEEP_EDITS = {
    "n": ("n = 2", "n = 1000000000"),
    "frames": ("[[targets]]", '[[scenes]]\nscene = "random_walk"\nframes = 1000000\n\n[[targets]]'),
    "walk-frames": (
        "[[targets]]",
        '[[scenes]]\nscene = "scene_walk.toml"\nframes = 5000\n[[targets]]',
    ),
    "jobs": (
        'solvers = ["closed_form"]',
        f"seeds = {list(range(400))}\n"
        f'solvers = [{{ name = "dls", grid = {{ restarts = {list(range(300))} }} }}]',
    ),
}
"""Sweep files that break a bound: name -> (text of :data:`SWEEP`, replaced by)."""

SOLVE = ["solve", "--target", "0.3,-0.3,1.1"]
SMALL = ["--frames", "2", "--width", "64", "--height", "48"]

USERS_FILES = {
    "mine_mp4": "circle.mp4",
    "mine_png": "frame_0000.png",
    "mine_csv": "trajectory.csv",
    "mine_summary": "summary.csv",
}
"""Folders of the user's own files (no run of the tool wrote them): folder -> file."""

ARM = PLANAR_ARM_XML

MODELS = {
    "inverted": ARM.replace("RANGE", 'range="0.5 -0.5"'),
    "locked": ARM.replace("RANGE", 'range="0.5 0.5"'),
    "unlimited": ARM.replace("RANGE", 'range="0.5 0.5" limited="false"'),
    "continuous": ARM.replace("RANGE", ""),
    "nan-colour": ARM.replace("RANGE", "").replace(
        'size="0.03"/>', 'size="0.03" rgba="nan 1 1 1"/>', 1
    ),
}
"""Model files, ``{model:NAME}`` in :data:`CASES`."""

CASES = [
    # --- item 7: tracebacks and hangs that are one line now
    ("bench-seed", ["bench", "--n", "2", "--solvers", "dls", "--seed", "-1"], 2,
     "argument --seed: expected an integer >= 0, got '-1'"),
    ("nullspace-dls", [*SOLVE, "--solver", "dls", "--option", "nullspace_gain=1e308"], 2,
     "option 'nullspace_gain' of solver 'dls' must be a finite number >= 0 and <= 1, "
     "got 1e+308"),
    ("nullspace-pinv", [*SOLVE, "--solver", "pseudoinverse", "--option", "nullspace_gain=1e308"],
     2, "option 'nullspace_gain' of solver 'pseudoinverse' must be a finite number >= 0 and <= 1"),
    ("nullspace-transpose",
     [*SOLVE, "--solver", "jacobian_transpose", "--option", "nullspace_gain=1e308"], 2,
     "option 'nullspace_gain' of solver 'jacobian_transpose' must be a finite number >= 0"),
    ("ray-empty", ["sweep", "{sweep}", "--out", "{tmp}/o", "--ray", ""], 2,
     "argument --ray: expected 'local', 'auto' or a cluster address (HOST:PORT, "
     "ray://HOST:PORT), got ''"),
    ("ray-space", ["sweep", "{sweep}", "--out", "{tmp}/o", "--ray", "a b"], 2,
     "argument --ray: expected 'local', 'auto' or a cluster address"),
    ("fps-tiny", ["render", "circle", "--out", "{tmp}/r", "--fps", "1e-10"], 2,
     "argument --fps: expected a number >= 0.01 and <= 1000, got '1e-10'"),
    ("render-out-empty", ["render", "circle", "--out", ""], 2,
     "argument --out: expected a path, got ''"),
    ("sweep-out-empty", ["sweep", "{sweep}", "--out", ""], 2,
     "argument --out: expected a path, got ''"),
    ("dataset-out-empty", ["dataset", "--n", "1", "--out", ""], 2,
     "argument --out: expected a path, got ''"),
    ("bench-json-empty", ["bench", "--n", "2", "--json", ""], 2,
     "argument --json: expected a path, got ''"),
    ("model-empty", [*SOLVE, "--model", ""], 2, "argument --model: expected a path, got ''"),
    ("bench-json-folder", ["bench", "--n", "2", "--solvers", "dls", "--json", "{tmp}/folder"], 2,
     "cannot write '{tmp}/folder': it is a folder; expected a file path"),
    ("dataset-out-folder", ["dataset", "--n", "2", "--out", "{tmp}/folder.npz"], 2,
     "cannot write '{tmp}/folder.npz': it is a folder; expected a file path"),
    # --- item 5: every size-like input has an upper bound, named in the message
    ("frames", ["render", "circle", "--out", "{tmp}/r", "--frames", "100001"], 2,
     "argument --frames: expected an integer >= 1 and <= 100000, got '100001'"),
    ("width", ["render", "circle", "--out", "{tmp}/r", "--width", "8192"], 2,
     "argument --width: expected an even integer >= 16 and <= 4096, got '8192'"),
    ("height", ["render", "circle", "--out", "{tmp}/r", "--height", "100000"], 2,
     "argument --height: expected an even integer >= 16 and <= 4096, got '100000'"),
    ("fps-high", ["render", "circle", "--out", "{tmp}/r", "--fps", "1001"], 2,
     "argument --fps: expected a number >= 0.01 and <= 1000, got '1001'"),
    ("scene-duration", ["render", "{scene:duration}", "--out", "{tmp}/r"], 2,
     "duration: expected a number > 0 and <= 3333.33 (at most 100000 frames at 30 fps), "
     "got 1e+300"),
    ("scene-duration-inf", ["run", "{scene:duration-inf}", "--out", "{tmp}/r"], 2,
     "duration: expected a number > 0 and <= 3333.33 (at most 100000 frames at 30 fps), "
     "got 1e+308"),
    ("scene-long", ["render", "{scene:long}", "--out", "{tmp}/r"], 2,
     "duration: expected a number > 0 and <= 3333.33"),
    ("scene-fps", ["render", "{scene:fps}", "--out", "{tmp}/r"], 2,
     "fps: expected a number >= 0.01 and <= 1000, got 0.001"),
    ("scene-trail", ["render", "{scene:trail}", "--out", "{tmp}/r"], 2,
     "render.trail: expected a number >= 0 and <= 60, got 1e+300"),
    ("scene-width", ["render", "{scene:width}", "--out", "{tmp}/r"], 2,
     "render.width: expected an even integer >= 16 and <= 4096 (pixels), got 10000"),
    ("scene-sheet", ["render", "{scene:sheet}", "--out", "{tmp}/r"], 2,
     "render.contact_sheet: expected an integer >= 0 and <= 100, got 1000000"),
    ("scene-snapshots", ["render", "{scene:snapshots}", "--out", "{tmp}/r"], 2,
     "render.snapshots: expected at most 100 times, got 101"),
    ("scene-interval", ["render", "{scene:interval}", "--out", "{tmp}/r"], 2,
     "targets[0].motion.interval: expected a number >= 3.97e-05 (a random_walk draws at most "
     "100000 knots, and this one runs 3.96667 s), got 1e-09"),
    ("scene-points", ["render", "{scene:points}", "--out", "{tmp}/r"], 2,
     "targets[0].motion.points: expected at most 10000 points, got 10001"),
    ("dataset-n", ["dataset", "--n", "99999999999999", "--out", "{tmp}/d.npz"], 2,
     "argument --n: expected an integer >= 1 and <= 100000000, got '99999999999999'"),
    ("dataset-chunk", ["dataset", "--n", "5", "--chunk", "10000000", "--out", "{tmp}/d.npz"], 2,
     "argument --chunk: expected an integer >= 1 and <= 1048576, got '10000000'"),
    ("bench-n", ["bench", "--n", "1000001"], 2,
     "argument --n: expected an integer >= 1 and <= 1000000, got '1000001'"),
    ("sweep-n", ["sweep", "{sweep:n}", "--out", "{tmp}/o"], 2,
     "targets[0].n: expected an integer >= 1 and <= 1000000, got 1000000000"),
    ("sweep-frames", ["sweep", "{sweep:frames}", "--out", "{tmp}/o"], 2,
     "scenes[0].frames: expected an integer >= 1 and <= 100000, got 1000000"),
    ("sweep-walk-frames", ["sweep", "{sweep:walk-frames}", "--out", "{tmp}/o"], 2,
     "scenes[0].frames: expected an integer >= 1 and <= 3000, got 5000"),
    ("sweep-workers", ["sweep", "{sweep}", "--out", "{tmp}/o", "--workers", "100000"], 2,
     "argument --workers: expected an integer >= 1 and <= 256, got '100000'"),
    ("sweep-jobs", ["sweep", "{sweep:jobs}", "--out", "{tmp}/o"], 2,
     "expected at most 100000 jobs (sets x configurations x seeds), got 120000"),
    ("max-iterations", [*SOLVE, "--solver", "dls", "--option", "max_iterations=1e12"], 2,
     "option 'max_iterations' of solver 'dls' must be an integer >= 0 and <= 100000, "
     "got 1000000000000"),
    ("stall-window", [*SOLVE, "--solver", "dls", "--option", "stall_window=1e12"], 2,
     "option 'stall_window' of solver 'dls' must be an integer >= 0 and <= 100000"),
    ("restarts", [*SOLVE, "--solver", "pseudoinverse", "--option", "restarts=1e9"], 2,
     "option 'restarts' of solver 'pseudoinverse' must be an integer >= 0 and <= 1000"),
    # --- issue 24, item 16: a sweep is a file or a bundled sweep's name (listed when unknown)
    ("sweep-name", ["sweep", "no_such_sweep", "--out", "{tmp}/o"], 2,
     "no_such_sweep: no such sweep file; expected a path or a bundled sweep: compare_solvers"),
    # --- issue 24, item 5: an output onto a FIFO is refused (a device by the same rule)
    ("fifo-keyframes", ["export-keyframes", "{trajectory}", "--out", "{tmp}/fifo"], 2,
     "not a regular file (a device, FIFO or socket); give a file path: {tmp}/fifo"),
    ("fifo-bvh", ["export-bvh", "{trajectory}", "--out", "{tmp}/fifo"], 2,
     "not a regular file (a device, FIFO or socket); give a file path: {tmp}/fifo"),
    ("fifo-bench", ["bench", "--n", "2", "--solvers", "dls", "--json", "{tmp}/fifo"], 2,
     "not a regular file (a device, FIFO or socket); give a file path: {tmp}/fifo"),
    # --- issue 24, item 13: an MJCF range MuJoCo drops: inverted is refused (locked: below)
    ("mjcf-inverted", ["inspect", "--model", "{model:inverted}"], 2,
     "model '{model:inverted}': joint 'elbow' has range 0.5 -0.5 (lower > upper, which "
     "MuJoCo would take as unlimited); swap them"),
    ("mjcf-inverted-solve",
     ["solve", "--model", "{model:inverted}", "--site", "tip", "--target", "0.3,0.2,0"], 2,
     "joint 'elbow' has range 0.5 -0.5 (lower > upper"),
]  # fmt: skip
"""(id, command arguments, exit status, message fragment): the bad-input table."""


USER_CASES = [
    ("users-mp4", ["render", "circle", *SMALL, "--out", "{tmp}/mine_mp4"], 2,
     "not written over a file that no earlier run wrote here (remove it or choose another "
     "output folder): {tmp}/mine_mp4/circle.mp4"),
    ("users-png", ["render", "circle", *SMALL, "--no-video", "--out", "{tmp}/mine_png"], 2,
     "no earlier run wrote here (remove it or choose another output folder): "
     "{tmp}/mine_png/frame_0000.png"),
    ("users-csv", ["run", "circle", "--frames", "2", "--out", "{tmp}/mine_csv"], 2,
     "no earlier run wrote here (remove it or choose another output folder): "
     "{tmp}/mine_csv/trajectory.csv"),
    ("users-replay",
     ["replay", "{trajectory}", *SMALL[2:], "--no-video", "--out", "{tmp}/mine_png"],
     2, "no earlier run wrote here (remove it or choose another output folder): "
     "{tmp}/mine_png/frame_0000.png"),
    ("users-sweep", ["sweep", "{sweep}", "--out", "{tmp}/mine_summary", "--no-plot"], 2,
     "not written over a file that no earlier sweep wrote here (remove it or choose another "
     "output folder): {tmp}/mine_summary/summary.csv"),
]  # fmt: skip
"""Issue 24, item 3: (id, command arguments, exit status, message fragment) of commands
writing into a folder of the user's own files (:data:`USERS_FILES`)."""


@pytest.fixture(scope="module")
def trajectory(tmp_path_factory) -> Path:
    """The trajectory.npz of a run of ``circle`` of 3 frames."""
    out = tmp_path_factory.mktemp("run") / "run"
    assert main(["run", "circle", "--frames", "3", "--out", str(out)]) == 0
    return out / "trajectory.npz"


@pytest.fixture()
def files(tmp_path: Path, trajectory: Path) -> dict[str, str]:
    """The placeholders of :data:`CASES`, as the files they name."""
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder.npz").mkdir()
    os.mkfifo(tmp_path / "fifo")
    for folder, name in USERS_FILES.items():
        (tmp_path / folder).mkdir()
        (tmp_path / folder / name).write_text("the user's own\n")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    out = {"{tmp}": str(tmp_path), "{sweep}": str(sweep), "{trajectory}": str(trajectory)}
    for name, text in MODELS.items():
        (tmp_path / f"{name}.xml").write_text(text)
        out[f"{{model:{name}}}"] = str(tmp_path / f"{name}.xml")
    circle = (bundled_dir("scenes") / "circle.toml").read_text()
    for name, (old, new) in SCENE_EDITS.items():
        assert old in circle, name
        path = tmp_path / f"scene_{name}.toml"
        path.write_text(circle.replace(old, new))
        out[f"{{scene:{name}}}"] = str(path)
    for name, (old, new) in SWEEP_EDITS.items():
        assert old in SWEEP, name
        path = tmp_path / f"sweep_{name}.toml"
        path.write_text(SWEEP.replace(old, new))
        out[f"{{sweep:{name}}}"] = str(path)
    return out


def _fill(text: str, files: dict[str, str]) -> str:
    for key in sorted(files, key=len, reverse=True):
        text = text.replace(key, files[key])
    return text


def _listing(folder: Path) -> list[str]:
    """Every path under ``folder`` (hidden files too)."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.parametrize(
    ("args", "status", "fragment"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_input_is_one_line(capsys, files, tmp_path, args, status, fragment):
    """Each case: the exit status, one stderr line holding the fragment, no traceback,
    nothing written (no stray temporary file either)."""
    before = _listing(tmp_path)
    code = main([_fill(a, files) for a in args])
    out, err = capsys.readouterr()
    assert code == status, err
    assert err.count("\n") == 1 and err.startswith("humanoid-ik: error: "), err
    assert _fill(fragment, files) in err, err
    assert "Traceback" not in err and out == ""
    assert _listing(tmp_path) == before
    for folder, name in USERS_FILES.items():  # the user's files as they were
        assert (tmp_path / folder / name).read_text() == "the user's own\n"
    assert (tmp_path / "fifo").is_fifo()


@pytest.mark.parametrize(
    ("args", "status", "fragment"), [c[1:] for c in USER_CASES], ids=[c[0] for c in USER_CASES]
)
def test_no_command_replaces_the_users_files(capsys, files, tmp_path, args, status, fragment):
    """Each command writing a folder, given one holding a file of the user's that it would
    write: refused in one line naming that file, exit 2; the file as it was and nothing
    else in the folder but the folder's lock (hidden, the tool's own)."""
    code = main([_fill(a, files) for a in args])
    out, err = capsys.readouterr()
    assert code == status, err
    assert err.count("\n") == 1 and err.startswith("humanoid-ik: error: "), err
    assert _fill(fragment, files) in err and "Traceback" not in err, err
    for folder, name in USERS_FILES.items():
        assert (tmp_path / folder / name).read_text() == "the user's own\n"
        assert set(_listing(tmp_path / folder)) <= {name, ".humanoid-ik-outputs.lock"}
    if any(f"/{name}" in err for name in ("circle.mp4", "trajectory.csv")):
        # a name the run knows beforehand: refused before it ran (no lock, no frame solved)
        assert out == "", out
        assert all(
            _listing(tmp_path / f) == [n] for f, n in USERS_FILES.items() if f != "mine_summary"
        )


def test_a_file_of_the_users_that_the_render_does_not_write_is_no_obstacle(tmp_path):
    """A render without the plot into a folder holding the user's own ``metrics.png``
    runs (it writes no file of that name) and leaves that file as it was; with the plot
    it is refused before the run, nothing written."""
    from humanoid_ik.config.scene import load_scene
    from humanoid_ik.outputs.render import render_scene

    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "metrics.png").write_text("the user's own\n")
    scene = load_scene("circle").with_overrides(frames=2, width=64, height=48)
    out = render_scene(scene, folder, video=False, plot=False)
    assert out.frames == 2 and (folder / "trajectory.npz").is_file()
    assert (folder / "metrics.png").read_text() == "the user's own\n"
    other = tmp_path / "mine2"
    other.mkdir()
    (other / "metrics.png").write_text("the user's own\n")
    with pytest.raises(FileExistsError, match="metrics.png"):
        render_scene(scene, other, video=False, plot=True)
    assert _listing(other) == ["metrics.png"]


def test_bench_json_folder_is_refused_before_the_run(capsys, tmp_path):
    """``bench --json <folder>`` (even the filesystem root's child ``/tmp``-like case: a
    folder whose parent is writable) is refused before any solve: nothing on stdout, no
    temporary file beside it or inside it."""
    folder = tmp_path / "res"
    folder.mkdir()
    t0 = time.perf_counter()
    assert main(["bench", "--n", "500", "--json", str(folder)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "it is a folder" in err
    assert _listing(tmp_path) == ["res"]
    assert time.perf_counter() - t0 < 60  # refused, not benchmarked (500 targets x 7 solvers)


def test_damaged_job_result_runs_again_with_a_note(capsys, tmp_path):
    """A job result cut down to ``{"status": "ok"}`` does not break the resume: the job
    runs again (with a note naming the file) and its result is whole again."""
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    out = tmp_path / "o"
    argv = ["sweep", str(sweep), "--out", str(out), "--workers", "1", "--no-plot"]
    assert main(argv) == 0
    (result,) = (out / "jobs").glob("*.json")
    whole = json.loads(result.read_text())
    capsys.readouterr()
    for damage in ('{"status": "ok"}', "[1, 2]", "{not json", json.dumps({**whole, "id": "x"})):
        result.write_text(damage)
        assert main(argv) == 0
        stdout, err = capsys.readouterr()
        assert "1 job(s), 0 already done, 1 to run" in stdout
        assert f"humanoid-ik: note: {result} is not a whole job result" in err
        assert "that job runs again" in err and "Traceback" not in err
        again = json.loads(result.read_text())
        assert again["status"] == "ok" and again["id"] == whole["id"]
    assert main(argv) == 0
    assert "1 already done, 0 to run" in capsys.readouterr().out


def test_jacobian_step_that_overflows_ends_the_start():
    """A step rule whose step is not finite (what an absurd option did) gives a finite,
    not-converged answer instead of NaN joints and a LinAlgError."""

    class Overflowing(DLS):
        def _step(self, work, J, e):
            return np.full(J.shape[1], np.inf)

    chain = Chain()
    res = Overflowing(nullspace_gain=0.5, restarts=2).solve(chain, Target([0.3, -0.3, 1.1]))
    assert not res.converged and np.all(np.isfinite(res.q))


def test_motion_bounds_in_the_library():
    """The library refuses the same sizes: a random walk past its knots, too many points."""
    walk = RandomWalk([0.4, -0.3, 1.2], [0.1, 0.1, 0.1], interval=1e-9)
    assert walk.horizon == pytest.approx((MAX_KNOTS - 3) * 1e-9)
    with pytest.raises(Exception, match=r"t: expected a time <= .* at most 100000 knots"):
        walk.position(1.0)
    assert len(walk._knots) < 10
    with pytest.raises(Exception, match="points: expected at most 10000 points, got 10001"):
        Points([[0.0, 0.0, 0.0]] * 10_001)


SUBPROCESS_CASES = [
    (["bench", "--n", "2", "--solvers", "dls", "--seed", "-1"], 2, "expected an integer >= 0"),
    ([*SOLVE, "--solver", "pseudoinverse", "--option", "nullspace_gain=1e308"], 2, "<= 1"),
    (["render", "circle", "--fps", "1e-10"], 2, "--fps: expected a number >= 0.01 and <= 1000"),
]


def _cli(args: list[str], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run(
        [sys.executable, "-m", "humanoid_ik", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        check=False,
    )


@pytest.mark.parametrize(("args", "status", "fragment"), SUBPROCESS_CASES)
def test_bad_input_in_a_real_process(tmp_path, args, status, fragment):
    """A few of the table as real processes: exit status, one line, no traceback."""
    proc = _cli(args, tmp_path)
    assert proc.returncode == status, proc.stderr
    assert proc.stderr.count("\n") == 1 and fragment in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_ray_address_where_nothing_answers_fails_soon(tmp_path):
    """``--ray 127.0.0.1:1`` (nothing listens) fails in one line within a minute instead
    of waiting for minutes."""
    pytest.importorskip("ray")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    t0 = time.monotonic()
    proc = _cli(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--ray", "127.0.0.1:1"],
                tmp_path, timeout=180)  # fmt: skip
    assert time.monotonic() - t0 < 60
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip().splitlines()
    assert err[-1].startswith("humanoid-ik: error: cannot connect to Ray at '127.0.0.1:1': ")
    assert len(err) == 1 and "Traceback" not in proc.stderr, proc.stderr


# ----------------------------------------------------------------------------- issue 24, item 16
def test_scene_found_by_its_file_name_and_its_declared_name(capsys, monkeypatch, tmp_path):
    """``scenes`` lists a scene by the ``name`` its TOML declares; ``run`` finds it by that
    name and by its file name; a file name wins over another file's declared name; a
    declared name two files share is refused in one line naming both files."""
    folder = tmp_path / "scenes"
    folder.mkdir()
    circle = (bundled_dir("scenes") / "circle.toml").read_text()
    assert 'name = "circle"' in circle
    for stem, name in [
        ("file_stem", "shown"),
        ("shown2", "file_stem"),
        ("a", "twin"),
        ("b", "twin"),
    ]:
        (folder / f"{stem}.toml").write_text(circle.replace('name = "circle"', f'name = "{name}"'))
    monkeypatch.setenv("HUMANOID_IK_SCENES", str(folder))
    assert main(["scenes"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == ["twin", "twin", "shown", "file_stem"]  # a, b, file_stem, shown2
    for i, (arg, source) in enumerate([("shown", "file_stem"), ("file_stem", "file_stem"),
                                       ("shown2", "shown2")]):  # fmt: skip
        out = tmp_path / f"r{i}"
        assert main(["run", arg, "--out", str(out), "--frames", "3"]) == 0, capsys.readouterr()
        metrics = json.loads((out / "metrics.json").read_text())
        assert Path(metrics["source"]).name == f"{source}.toml" and metrics["frames"] == 3
    capsys.readouterr()
    assert main(["run", "twin", "--out", str(tmp_path / "tw")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert (
        "twin: a scene name several bundled files declare; expected one of their file "
        "names: a, b" in err
    )
    assert not (tmp_path / "tw").exists()


@contextmanager
def unwritable(folder: Path) -> Iterator[None]:
    """``folder`` made unwritable: read-only, or immutable (``chattr +i``) when running
    as root makes a read-only folder writable anyway; the test is skipped if neither holds."""
    folder.chmod(0o555)
    immutable = False
    try:
        if os.access(folder, os.W_OK):
            immutable = subprocess.run(["chattr", "+i", str(folder)], capture_output=True,
                                       check=False).returncode == 0  # fmt: skip
        if os.access(folder, os.W_OK):
            pytest.skip("cannot make a folder unwritable here (root, no chattr)")
        yield
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], check=False)
        folder.chmod(0o755)


@pytest.mark.parametrize(
    ("out", "where"),
    [("ro", "it"), ("ro/new/deeper", "folder '{tmp}/ro'"), ("w", "folder '{tmp}/w/jobs'")],
    ids=["read-only", "under-read-only", "jobs-read-only"],
)
def test_sweep_onto_an_unwritable_folder_announces_nothing(capsys, files, tmp_path, out, where):
    """A sweep whose output folder cannot be written says so in one line, exit 2, before
    it announces or runs any job (nothing on stdout, nothing created)."""
    (tmp_path / "ro").mkdir()
    (tmp_path / "w" / "jobs").mkdir(parents=True)
    locked = tmp_path / ("w/jobs" if out == "w" else "ro")
    before = _listing(tmp_path)
    with unwritable(locked):
        code = main(["sweep", files["{sweep}"], "--out", str(tmp_path / out), "--no-plot"])
    stdout, err = capsys.readouterr()
    assert code == 2, err
    assert stdout == "" and err.count("\n") == 1, (stdout, err)
    expected = f"humanoid-ik: error: cannot write '{tmp_path / out}': {_fill(where, files)} "
    assert err == expected + "is not writable\n"
    assert _listing(tmp_path) == before


def test_sweep_help_names_a_bundled_sweep(capsys):
    """``sweep --help`` says the sweep may be a bundled sweep's name, as it may."""
    assert main(["sweep", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "SWEEP.toml|NAME" in text and "a sweep file, or a bundled sweep's name" in text


# ----------------------------------------------------------------------------- issue 24, item 13
def test_an_mjcf_range_of_zero_width_locks_the_joint(tmp_path):
    """``range="0.5 0.5"`` (which MuJoCo takes as unlimited) locks the elbow at 0.5, with
    one note, and a solve keeps it there; with ``limited="false"`` written it stays free."""
    import warnings

    from humanoid_ik import solve
    from humanoid_ik.core.models import ModelWarning, load_model

    path = tmp_path / "locked.xml"
    path.write_text(MODELS["locked"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chain = Chain(load_model(path), site="tip")
    said = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert (
        f"model '{path}': 1 joint(s) locked (range lower = upper, which MuJoCo would take "
        "as unlimited; give a range to let them move): 'elbow' at 0.5" in said
    ), said
    assert chain.lower[1] == pytest.approx(0.5, abs=1e-8) and chain.upper[1] == pytest.approx(0.5)
    target = chain.fk([0.7, 0.5])[0]
    result = solve(chain, target, solver="dls")
    assert result.q[1] == pytest.approx(0.5, abs=1e-8)
    assert np.linalg.norm(chain.fk(result.q)[0] - target) < 1e-4
    free = tmp_path / "free.xml"
    free.write_text(MODELS["unlimited"])
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelWarning)
        assert np.isinf(Chain(load_model(free), site="tip").upper[1])


def test_an_mjcf_string_s_dropped_ranges_are_read_as_a_file_s():
    """``Chain.from_xml_string``: the same MJCF as a string, not a file, is refused when
    its elbow's range is inverted and locks it (with the note) when the range has zero
    width; ``limited="false"`` written keeps it free."""
    import warnings

    from humanoid_ik.core.models import ModelWarning
    from humanoid_ik.errors import ModelError

    with pytest.raises(ModelError) as info:
        Chain.from_xml_string(MODELS["inverted"], "tip")
    assert str(info.value) == (
        "model 'MJCF string': joint 'elbow' has range 0.5 -0.5 (lower > upper, which MuJoCo "
        "would take as unlimited); swap them"
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chain = Chain.from_xml_string(MODELS["locked"], "tip")
    said = [str(w.message) for w in caught if issubclass(w.category, ModelWarning)]
    assert any("1 joint(s) locked" in m and "'elbow' at 0.5" in m for m in said), said
    assert chain.lower[1] == pytest.approx(0.5, abs=1e-8) and chain.upper[1] == pytest.approx(0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelWarning)
        assert np.isinf(Chain.from_xml_string(MODELS["unlimited"], "tip").upper[1])


# ----------------------------------------------------------------------------- issue 24, item 15
def test_mujocos_warning_in_library_use_is_a_python_warning_and_writes_no_log(
    tmp_path, monkeypatch, capsys
):
    """A model MuJoCo warns about (a NaN colour: ``XML contains a 'NaN'``) loaded from
    Python, in a folder of the user's: no ``MUJOCO_LOG.TXT`` there and nothing printed,
    one :class:`MuJoCoWarning` instead, the user's own MuJoCo callback back after (and
    not called); a warning filter of ``error`` raises it (MuJoCo's C code would abort on
    a Python exception); the command line prints it as one note."""
    import mujoco

    from humanoid_ik.core.models import load_model, model_spec
    from humanoid_ik.core.mujoco_warnings import MuJoCoWarning

    monkeypatch.chdir(tmp_path)
    path = tmp_path / "nan-colour.xml"
    path.write_text(MODELS["nan-colour"])
    theirs: list[str] = []

    def callback(message: str) -> None:
        theirs.append(message)

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(callback)
    try:
        said = "MuJoCo: XML contains a 'NaN'. Please check it carefully."
        for load in (
            lambda: load_model(path),
            lambda: model_spec(path),
            lambda: Chain.from_xml_string(MODELS["nan-colour"], site="tip"),
        ):
            with pytest.warns(MuJoCoWarning) as caught:
                load()
            assert [str(w.message) for w in caught if w.category is MuJoCoWarning] == [said]
            assert mujoco.get_mju_user_warning() is callback
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error", MuJoCoWarning)
            with pytest.raises(MuJoCoWarning, match="XML contains a 'NaN'"):
                load_model(path)
        assert mujoco.get_mju_user_warning() is callback
        assert theirs == []
        mujoco.MjModel.from_xml_string(MODELS["nan-colour"])  # not the package's call
        assert theirs == ["XML contains a 'NaN'. Please check it carefully."]
    finally:
        mujoco.set_mju_user_warning(previous)
    assert capsys.readouterr() == ("", "")
    assert main(["solve", "--model", str(path), "--site", "tip", "--target", "0.3,0.2,0"]) == 0
    out, err = capsys.readouterr()
    assert "converged" in out and err == f"humanoid-ik: note: {said}\n", err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["nan-colour.xml"]


# ----------------------------------------------------------------------------- issue 24, item 11
def _strict_json(text: str):
    def refuse(name: str):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_a_runs_files_are_strict_json_and_xml_with_a_continuous_joint(tmp_path, capsys):
    """A run on an arm whose joints are both continuous (its range margin is infinite):
    ``metrics.json``, the folder's manifest and the trajectory's header parse with a
    strict JSON parser (the margin ``null``), and ``export-keyframes`` gives XML that a
    strict parser reads, with one key per frame."""
    import xml.etree.ElementTree as ET

    from humanoid_ik.outputs.atomic import MANIFEST

    (tmp_path / "arm.xml").write_text(MODELS["continuous"])
    scene = tmp_path / "arm.toml"
    scene.write_text(
        'name = "arm--two"\nmodel = "arm.xml"\nduration = 1.0\nfps = 4\n[solver]\nname = "dls"\n'
        '[[targets]]\nname = "p"\nmotion = { kind = "points", points = [[0.3, 0.2, 0.0], '
        "[0.2, 0.3, 0.0]], hold = 0.5, travel = 0.0 }\n"
        '[[effectors]]\nsite = "tip"\ntarget = "p"\n'
    )
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out)]) == 0
    metrics = _strict_json((out / "metrics.json").read_text())
    assert metrics["frames"] == 4 and len(metrics["samples"]) == 4
    assert [s["limit_margin_rad"] for s in metrics["samples"]] == [None] * 4
    assert sorted(_strict_json((out / MANIFEST).read_text())["files"]) == [
        "metrics.csv", "metrics.json", "trajectory.csv", "trajectory.npz"
    ]  # fmt: skip
    with np.load(out / "trajectory.npz") as z:
        assert _strict_json(str(z["header"]))["scene"] == "arm--two"
    keys = tmp_path / "keys.xml"
    assert main(["export-keyframes", str(out / "trajectory.npz"), "--out", str(keys)]) == 0
    capsys.readouterr()
    root = ET.fromstring(keys.read_text())
    assert [len(k.get("qpos").split()) for k in root.iter("key")] == [2] * 4


# ----------------------------------------------------------------------------- issue 24, item 4
def test_a_trajectory_of_no_frames_leaves_the_previous_replay(trajectory, tmp_path, capsys):
    """A 0-frame trajectory replayed into the folder of an earlier replay: refused in one
    line, exit 2, the earlier replay's set as it was (not replaced by a lone manifest)."""
    out = tmp_path / "replay"
    small = ["--width", "64", "--height", "48"]
    assert main(["replay", str(trajectory), *small, "--out", str(out)]) == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert "frame_0002.png" in before
    with np.load(trajectory) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays.pop("header")))
    empty = {k: v[:0] if v.ndim and k != "stage_points" else v for k, v in arrays.items()}
    header["frames"] = 0
    np.savez(tmp_path / "empty.npz", header=np.array(json.dumps(header)), **empty)
    assert main(["replay", str(tmp_path / "empty.npz"), *small, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "frames: expected an integer >= 1 and <= 100000, got 0" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


# ----------------------------------------------------------------------------- issue 24, item 9
def _frames(traj, n: int):
    """``traj`` stretched to ``n`` frames: each per-frame array repeated, times ascending."""
    from dataclasses import fields, replace

    def grow(value):
        if isinstance(value, np.ndarray) and value.ndim and len(value) == traj.n_frames:
            return np.resize(value, (n, *value.shape[1:]))
        if isinstance(value, tuple) and len(value) == traj.n_frames:
            return tuple(value[i % len(value)] for i in range(n))
        return value

    effectors = tuple(
        replace(e, **{f.name: grow(getattr(e, f.name)) for f in fields(e)}) for e in traj.effectors
    )
    return replace(traj, time=np.arange(n) / traj.fps, qpos=grow(traj.qpos), effectors=effectors)


def _bytes_read() -> int:
    """Bytes this process has read so far (``rchar`` of ``/proc/self/io``)."""
    for line in Path("/proc/self/io").read_text().splitlines():
        if line.startswith("rchar:"):
            return int(line.split()[1])
    raise AssertionError("no rchar in /proc/self/io")


def test_the_trajectory_readers_bound(trajectory, tmp_path):
    """The bound of ``docs/formats.md``: a file of MAX_FRAMES frames (npz and CSV) reads
    whole, holding less than MAX_TRAJECTORY_BYTES; one frame more is refused from the
    header. A CSV whose rows go on past its header's ``frames`` (a 1 GiB tail here) is
    refused at the first row too many: the reader reads a few kB of it, not the tail."""
    import tracemalloc

    from humanoid_ik.config.specs import MAX_FRAMES
    from humanoid_ik.errors import TrajectoryFileError
    from humanoid_ik.outputs.trajectory import load_trajectory, write_trajectory
    from humanoid_ik.outputs.trajectory_layout import MAX_TRAJECTORY_BYTES

    if not Path("/proc/self/io").is_file():
        pytest.skip("needs /proc/self/io (Linux)")
    good = load_trajectory(trajectory)
    big = _frames(good, MAX_FRAMES)
    (tmp_path / "big").mkdir()
    npz, csv_path = write_trajectory(big, tmp_path / "big")
    for path in (npz, csv_path):
        tracemalloc.start()
        try:
            back = load_trajectory(path)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert back.n_frames == MAX_FRAMES and peak < MAX_TRAJECTORY_BYTES, (path, peak)
        np.testing.assert_array_equal(back.qpos[-1], big.qpos[-1])
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays.pop("header")))
    np.savez(
        tmp_path / "over.npz",
        header=np.array(json.dumps({**header, "frames": MAX_FRAMES + 1})),
        **arrays,
    )
    with pytest.raises(
        TrajectoryFileError, match="frames: expected an integer >= 1 and <= 100000, got 100001"
    ):
        load_trajectory(tmp_path / "over.npz")
    lines = (trajectory.parent / "trajectory.csv").read_text().splitlines()
    endless = tmp_path / "endless.csv"
    endless.write_text("\n".join([*lines, lines[-1]]) + "\n")
    with open(endless, "r+b") as fh:
        fh.truncate(2**30)  # a sparse tail of 1 GiB (NUL bytes)
    before = _bytes_read()
    with pytest.raises(
        TrajectoryFileError, match="has more than 3 rows; its header says frames = 3"
    ):
        load_trajectory(endless)
    assert _bytes_read() - before < 2**20


def test_a_sweeps_files_are_strict_json(tmp_path, capsys):
    """A sweep's summary, run record and job records parse with a strict JSON parser,
    a job that failed to converge included (its errors are numbers or ``null``)."""
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.replace('solvers = ["closed_form"]', 'solvers = ["closed_form", "ccd"]'))
    out = tmp_path / "o"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "1", "--no-plot"]) == 0
    capsys.readouterr()
    records = sorted((out / "jobs").glob("*.json"))
    assert len(records) == 2
    for path in [out / "summary.json", out / "run.json", *records]:
        _strict_json(path.read_text())
    assert _strict_json((out / "run.json").read_text())["executed"] == 2
