"""The command line: output, JSON, exit codes, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from humanoid_ik import Chain
from humanoid_ik.cli import main
from humanoid_ik.core.rotations import mat_to_quat


def _run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_solve_prints_joints_and_errors(capsys):
    """solve prints every joint of the chain and a sub-millimetre error; exit 0."""
    code, out, err = _run(capsys, "solve", "--target", "0.3,-0.3,1.1")
    assert code == 0 and err == ""
    assert "solver dls: converged" in out
    assert out.count("rad") >= 7 and "right_wrist_deviation_joint" in out
    assert "position error" in out


def test_solve_json_reaches_target(capsys):
    """--json gives joint values by name whose FK lands on the target."""
    chain = Chain()
    target, R = chain.fk([0.5, 0.3, 0.2, 1.2, 0.1, 0.2, 0.1])
    quat = mat_to_quat(R)
    code, out, _ = _run(
        capsys,
        "solve",
        "--target",
        ",".join(f"{v:.17g}" for v in target),
        "--quat",
        ",".join(f"{v:.17g}" for v in quat),
        "--solver",
        "pseudoinverse",
        "--json",
    )
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
        (["solve", "--target", "0,0,1", "--solver", "fabrik"], "invalid choice: 'fabrik'"),
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
    """python -m humanoid_ik and the humanoid-ik script both run main()."""
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
    code, _, err = _run(capsys, "solve", "--target", "0,0,1", "--option", "restarts=true")
    assert code == 2 and "'restarts' of solver 'dls' must be a number, got True" in err
    code, _, err = _run(capsys, "solve", "--target", "0,0,1", "--option", "tol=1,2")
    assert code == 2 and "'tol' of solver 'dls' must be a number, got [1, 2]" in err
    code, _, err = _run(capsys, "solve", "--target", "0,0,1", "--joints", ",")
    assert code == 2 and "empty name list ','" in err
