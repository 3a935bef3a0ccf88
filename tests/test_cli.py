"""The command line: output, JSON, exit codes, one-line errors."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from humanoid_ik import Chain
from humanoid_ik.cli import main
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.experiments.sweep.summary import percent
from tests.processes import handles, signal_when


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _solve_pose_json(capsys, target, quat, solver: str):
    """`solve --target --quat --solver --json` with every digit of the target and quat."""
    exact = [",".join(f"{v:.17g}" for v in values) for values in (target, quat)]
    return _run(
        capsys, "solve", "--target", exact[0], "--quat", exact[1], "--solver", solver, "--json"
    )


def test_solve_prints_joints_and_errors(capsys):
    """solve prints every joint of the chain and a sub-millimetre error; exit 0."""
    code, out, err = _run(capsys, "solve", "--target", "0.3,-0.3,1.1", "--solver", "dls")
    assert code == 0 and err == ""
    assert "solver dls: converged" in out
    assert out.count("rad") >= 7 and "right_wrist_deviation_joint" in out
    assert "position error" in out


def test_solve_json_reaches_target(capsys):
    """--json gives joint values by name whose FK lands on the target."""
    chain = Chain()
    target, R = chain.fk([0.5, 0.3, 0.2, 1.2, 0.1, 0.2, 0.1])
    quat = mat_to_quat(R)
    code, out, _ = _solve_pose_json(capsys, target, quat, "pseudoinverse")
    doc = json.loads(out)
    assert code == 0 and doc["status"] == "converged" and doc["site"] == "right_palm_site"
    p, _ = chain.fk([doc["q"][n] for n in chain.joint_names])
    np.testing.assert_allclose(p, target, atol=1e-3)
    assert doc["orientation_error_rad"] < 1e-2


def test_solve_two_link_options_and_unreachable(capsys):
    """--option passes solver options; an unreachable target exits 1 with the distance."""
    code, out, _ = _run(
        capsys,
        "solve",
        "--target",
        "0.3,-0.3,1.1",
        "--solver",
        "two_link",
        "--option",
        "method=angle_axis",
    )
    assert code == 0
    code, out, _ = _run(capsys, "solve", "--target", "3,0,1.4", "--solver", "two_link")
    assert code == 1 and "unreachable" in out and "beyond the reachable shell" in out


def test_solve_other_site_and_joints(capsys):
    """--site and --joints choose the chain: the left hand with two joints."""
    code, out, _ = _run(
        capsys,
        "solve",
        "--target",
        "0.0,0.19,0.85",
        "--site",
        "left_palm_site",
        "--joints",
        "left_shoulder_flexion_joint,left_elbow_joint",
        "--json",
    )
    doc = json.loads(out)
    assert list(doc["q"]) == ["left_shoulder_flexion_joint", "left_elbow_joint"]


def test_bench_writes_json(tmp_path, capsys):
    """bench prints the table and writes the documented JSON."""
    path = tmp_path / "bench.json"
    code, out, _ = _run(
        capsys,
        "bench",
        "--n",
        "5",
        "--solvers",
        "dls,two_link",
        "--task",
        "pose",
        "--json",
        str(path),
    )
    assert code == 0 and "skipped: two_link solves position targets only" in out
    doc = json.loads(path.read_text())
    assert doc["task"] == "pose" and doc["n"] == 5 and doc["site"] == "right_palm_site"
    assert [r["solver"] for r in doc["results"]] == ["dls", "two_link"]
    assert doc["results"][0]["success_rate"] == 1.0
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["solve", "--target", "1,2"], "--target '1,2' has 2 value(s); expected 3"),
        (["solve", "--target", "a,b,c"], "is not 3 comma-separated numbers"),
        (["solve", "--target", "nan,0,1"], "not finite"),
        (["solve", "--target", "0,0,1", "--quat", "0,0,0,0"], "zero norm"),
        (["solve", "--target", "0,0,1", "--solver", "nosuch"], "invalid choice: 'nosuch'"),
        (["solve", "--target", "0,0,1", "--site", "hand"], "site 'hand' not in model; sites:"),
        (["solve", "--target", "0,0,1", "--joints", "knee"], "joint 'knee' not in model"),
        (["solve", "--target", "0,0,1", "--model", "nope.xml"], "model file 'nope.xml' does not"),
        (["solve", "--target", "0,0,1", "--option", "damp=1"], "option 'damp' unknown"),
        (["solve", "--target", "0,0,1", "--option", "damping"], "is not KEY=VALUE"),
        (
            ["solve", "--target", "0,0,1", "--quat", "1,0,0,0", "--solver", "ccd"],
            "ccd solves position targets only",
        ),
        (["bench", "--task", "orientation"], "invalid choice: 'orientation'"),
        (["bench", "--n", "0"], "argument --n: expected an integer >= 1, got '0'"),
        (["bench", "--n", "2", "--seed", "-1"], "argument --seed: expected an integer >= 0"),
        (["bench", "--n", "1", "--json", "missing/out.json"], "folder 'missing' does not exist"),
        (["frobnicate"], "invalid choice: 'frobnicate'"),
        ([], "required: COMMAND"),
    ],
)
def test_errors_are_one_line(capsys, argv, message):
    """Bad input: exit 2 and exactly one line on stderr naming the problem, no traceback."""
    code, out, err = _run(capsys, *argv)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert message in lines[0] and lines[0].startswith("humanoid-ik: error: ")
    assert "Traceback" not in err


def test_debug_shows_the_traceback(capsys):
    """--debug prints the traceback before the one-line message."""
    code, _, err = _run(capsys, "--debug", "solve", "--target", "0,0,1", "--site", "hand")
    assert code == 2 and "Traceback" in err


def test_bad_xml_keeps_mujocos_message(tmp_path, capsys):
    """XML that does not compile: MuJoCo's own message on one line."""
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><geom type='sphere'/></worldbody></mujoco>")
    code, _, err = _run(capsys, "solve", "--target", "0,0,1", "--model", str(bad))
    assert code == 2 and "does not compile" in err and len(err.strip().splitlines()) == 1


def test_module_and_console_script_share_main():
    """python -m humanoid_ik and the humanoid-ik script both run main(); --version names
    the package and MuJoCo."""
    import mujoco

    for cmd in (
        [sys.executable, "-m", "humanoid_ik"],
        [sys.executable, "-c", "import sys; from humanoid_ik.cli import main; sys.exit(main())"],
    ):
        proc = subprocess.run(
            [*cmd, "solve", "--target", "0.3,-0.3,1.1", "--json"],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["status"] == "converged"
    proc = subprocess.run(
        [sys.executable, "-m", "humanoid_ik", "--version"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0 and proc.stdout.startswith("humanoid-ik ")
    assert proc.stdout.endswith(f"(mujoco {mujoco.__version__})\n"), proc.stdout


def test_option_values_are_typed(capsys):
    """--option values parse as numbers, booleans, strings and lists."""
    code, out, _ = _run(
        capsys,
        "solve",
        "--target",
        "0.6,-0.2,1.6",
        "--site",
        "gaze_site",
        "--solver",
        "look_at",
        "--option",
        "forward_axis=x",
        "--option",
        "rot_tol=1e-8",
        "--json",
    )
    doc = json.loads(out)
    assert code == 0 and doc["orientation_error_rad"] < 1e-8
    code, _, err = _run(
        capsys, "solve", "--target", "0,0,1", "--solver", "dls", "--option", "restarts=true"
    )
    assert code == 2 and "'restarts' of solver 'dls' must be a number, got True" in err
    code, _, err = _run(
        capsys, "solve", "--target", "0,0,1", "--solver", "dls", "--option", "tol=1,2"
    )
    assert code == 2 and "'tol' of solver 'dls' must be a number, got [1, 2]" in err
    code, _, err = _run(capsys, "solve", "--target", "0,0,1", "--joints", ",")
    assert code == 2 and "empty name list ','" in err


# ----------------------------------------------------------------------------- rough edges
def test_negative_numbers_in_target_and_quat(capsys):
    """--target -0.1,... and --quat -0.5,... are values, not options (argparse alone says
    'expected one argument'); the solve lands on the negative target."""
    chain = Chain()
    q = [0.3, 0.2, -0.4, 1.3, 0.2, 0.1, -0.1]
    target, R = chain.fk(q)
    quat = -mat_to_quat(R)  # the same rotation, its w negative
    assert target[1] < 0 and quat[0] < 0
    code, out, err = _solve_pose_json(capsys, target, quat, "dls")
    assert code == 0 and err == ""
    doc = json.loads(out)
    np.testing.assert_allclose(doc["target"]["position"], target)
    p, _ = chain.fk([doc["q"][n] for n in chain.joint_names])
    np.testing.assert_allclose(p, target, atol=1e-3)
    code, out, err = _run(capsys, "solve", "--target", "-0.1,-0.2,1.1", "--solver", "dls")
    assert "expected one argument" not in err and code in (0, 1) and "solver dls" in out
    code, _, err = _run(capsys, "solve", "--target", "-x,0,1")
    assert code == 2 and "expected one argument" in err  # not a number: still an option


def test_debug_is_accepted_after_the_command(capsys):
    """--debug before or after the command: no 'unrecognized arguments'; an error then
    shows its traceback and the one line."""
    for argv in (
        ["--debug", "solve", "--target", "0.3,-0.3,1.1", "--solver", "dls"],
        ["solve", "--target", "0.3,-0.3,1.1", "--solver", "dls", "--debug"],
    ):
        code, out, err = _run(capsys, *argv)
        assert code == 0 and err == "" and "converged" in out
    code, _, err = _run(capsys, "solve", "--target", "0,0", "--debug")
    assert code == 2 and "Traceback" in err
    assert err.splitlines()[-1] == ("humanoid-ik: error: --target '0,0' has 2 value(s); expected 3")
    assert "unrecognized" not in err


def _cli(*argv: str) -> list[str]:
    return [sys.executable, "-m", "humanoid_ik", *argv]


def test_closed_pipe_ends_quietly_with_141():
    """The reader of the output gone (its end of the pipe closed): no 'Broken pipe' error,
    no traceback, exit 141 (128 + SIGPIPE, what a shell shows)."""
    p = subprocess.Popen(_cli("scenes"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert p.stdout is not None and p.stderr is not None
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=60) == 141 and err == ""


@pytest.mark.slow
def test_render_into_a_closed_pipe_through_a_shell(tmp_path):
    """`humanoid-ik render ... | head -n 0`: head is gone before render prints; render
    still writes its files, exits 141 and prints no error."""
    cmd = " ".join(
        _cli(
            "render",
            "circle",
            "--frames",
            "2",
            "--width",
            "32",
            "--height",
            "32",
            "--no-video",
            "--out",
            str(tmp_path / "r"),
        )
    )
    res = subprocess.run(
        ["bash", "-c", f"{cmd} | head -n 0; echo status=${{PIPESTATUS[0]}}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.stdout.strip() == "status=141"
    assert "Broken pipe" not in res.stderr and "error" not in res.stderr
    assert (tmp_path / "r" / "metrics.json").is_file()


@pytest.mark.slow
def test_sigterm_is_handled_like_ctrl_c():
    """SIGTERM during a long bench: one line 'humanoid-ik: terminated', exit 143, no
    traceback."""
    code = (
        "import sys\n"
        "from humanoid_ik.cli import main\n"
        "print('ready', flush=True)\n"
        "sys.exit(main(['bench', '--n', '100000', '--solvers', 'ccd']))\n"
    )
    p = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert p.stdout is not None
    assert p.stdout.readline().strip() == "ready"
    # once the command line handles SIGTERM (on a busy machine its start-up takes
    # longer than any fixed delay), then a moment inside the benchmark loop
    assert signal_when(p, signal.SIGTERM, lambda: handles(p, signal.SIGTERM), after=0.5)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143
    assert err.strip().splitlines()[-1] == "humanoid-ik: terminated"
    assert "Traceback" not in err


def test_sweep_percentages_never_round_up_to_100():
    """99.75% shows 99.7 (rounded down), 100% shows 100.0, a share of 0.29 stays 29.0
    (no binary-fraction floor to 28.9), and a missing value is a dash."""
    assert percent(0.9975) == "99.7"
    assert percent(0.99999999) == "99.9"
    assert percent(1.0) == "100.0"
    assert percent(0.29) == "29.0"
    assert percent(0.123456, "11.1f") == "       12.3"
    assert percent(None, "11.1f") == "          -"
    assert percent(0.9999, ".0f") == "99"


def test_a_bad_mujoco_gl_leaves_no_output_folder(tmp_path):
    """`MUJOCO_GL=foo humanoid-ik render circle`: the backend is chosen before the output
    folder is made, so the one-line error (exit 2) leaves no folder behind, neither the
    default renders/circle nor --out's."""
    env = {k: v for k, v in os.environ.items() if k != "PYOPENGL_PLATFORM"}
    env["MUJOCO_GL"] = "foo"
    for out in ((), ("--out", str(tmp_path / "a" / "b"))):
        res = subprocess.run(
            _cli("render", "circle", "--frames", "2", "--no-video", *out),
            capture_output=True,
            text=True,
            env=env,
            cwd=tmp_path,
            timeout=300,
        )
        assert res.returncode == 2 and res.stdout == ""
        assert res.stderr.splitlines() == [
            "humanoid-ik: error: MUJOCO_GL='foo' is not an OpenGL backend; expected one of "
            "egl, osmesa, glfw, glx (or unset it: EGL, else OSMesa)"
        ]
        assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_bundled_folder_variable_is_named_when_nothing_is_there(tmp_path, monkeypatch, capsys):
    """HUMANOID_IK_MODELS / _SCENES / _SWEEPS pointing at a folder without the default
    file: the one-line error (exit 2) names the variable and its value; a path the user
    gave, not in that folder, is not blamed on it."""
    empty = str(tmp_path)

    def error(var: str, *argv: str) -> str:
        with monkeypatch.context() as m:
            m.setenv(var, empty)
            code, out, err = _run(capsys, *argv)
        assert code == 2 and out == "" and len(err.splitlines()) == 1, err
        return err

    said = " sets the bundled {} folder; unset it for the package's own)\n"
    models = f"(HUMANOID_IK_MODELS='{empty}'" + said.format("models")
    scenes = f"(HUMANOID_IK_SCENES='{empty}'" + said.format("scenes")
    sweeps = f"(HUMANOID_IK_SWEEPS='{empty}'" + said.format("sweeps")
    err = error("HUMANOID_IK_MODELS", "solve", "--target", "0.3,-0.3,1.1")
    assert (
        err
        == f"humanoid-ik: error: model file '{empty}/humanoid/scene.xml' does not exist {models}"
    )
    err = error("HUMANOID_IK_MODELS", "run", "circle", "--frames", "2", "--out", f"{empty}/o")
    assert err.endswith(
        f"circle.toml: model: model file '{empty}/humanoid/scene.xml' does not exist {models}"
    )
    err = error("HUMANOID_IK_MODELS", "solve", "--target", "0.3,-0.3,1.1", "--model", "x.xml")
    assert err == "humanoid-ik: error: model file 'x.xml' does not exist\n"
    err = error("HUMANOID_IK_SCENES", "render", "circle")
    assert err == (
        "humanoid-ik: error: circle: no such scene file; expected a path or a bundled scene: "
        f"(none) {scenes}"
    )
    assert error("HUMANOID_IK_SCENES", "scenes").endswith(
        f"no bundled scenes in '{empty}' {scenes}"
    )
    err = error("HUMANOID_IK_SWEEPS", "sweep", "compare_solvers")
    assert err == (
        "humanoid-ik: error: compare_solvers: no such sweep file; expected a path or a bundled "
        f"sweep: (none) {sweeps}"
    )
    # unset: the names are looked up in the package's own folders
    err = error("HUMANOID_IK_MOTIONS", "sweep", "compare_solver")
    assert err.endswith("no such sweep file; expected a path or a bundled sweep: compare_solvers\n")
    from humanoid_ik.config.sweep_file import load_sweep

    assert len(load_sweep("compare_solvers").jobs) == 60  # a bundled sweep by its name
    assert sorted(p.name for p in tmp_path.iterdir()) == []
