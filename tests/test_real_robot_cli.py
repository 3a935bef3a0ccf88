"""The command line on real robots of example-robot-data, their original URDFs: what a
user meets first. ``inspect`` lists the end effectors its header counts, ``solve``
prints its CPU and wall time and names a home pose outside the ranges once (as every
other command does, with one note), and a two_link solve on a chain that is not a
two-link limb is refused in one line."""

from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import HomeWarning, load_model
from tests.robots import g1_arm, robot_file

G1_ARM = list(g1_arm("left"))


@pytest.fixture(scope="module")
def g1_target():
    """A target G1's left hand reaches with its arm: FK of an in-range pose [m]."""
    chain = Chain(load_model(robot_file("g1")), joints=G1_ARM, body="left_rubber_hand")
    q = chain.q_home.copy()
    q[:4] = [-0.4, 0.5, 0.2, 0.6]
    return chain.fk(q)[0]


def test_inspect_g1_lists_what_it_counts(capsys):
    """The header's count is the number of effector blocks; the sensor and camera links
    are under "not end effectors"; the JSON document holds the same lists."""
    assert main(["inspect", "--model", str(robot_file("g1"))]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    blocks = [ln.split(":")[0] for ln in lines if re.match(r"(site|body) \S+: \d+ joint", ln)]
    count = int(lines[1].split()[0])
    assert count == len(blocks) == 5
    assert "body left_rubber_hand" in blocks and "body imu_in_torso" not in blocks
    assert "  camera frame: d435_link" in lines
    assert main(["inspect", "--model", str(robot_file("g1")), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [f"body {e['name']}" for e in doc["effectors"]] == blocks
    assert {"kind": "body", "name": "d435_link", "reason": "camera frame"} in doc["others"]


def test_solve_prints_cpu_and_wall_time(g1_target, capsys):
    """A converged solve prints its time in ms, CPU then wall, after the errors; --json
    gives both in seconds."""
    args = [
        "solve",
        "--model",
        str(robot_file("g1")),
        "--body",
        "left_rubber_hand",
        "--joints",
        ",".join(G1_ARM),
        "--target",
        ",".join(f"{v:.6f}" for v in g1_target),
    ]
    assert main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-2].startswith("position error ")
    m = re.fullmatch(r"solve time {9}(\d+\.\d{3}) ms CPU, (\d+\.\d{3}) ms wall", lines[-1])
    assert m is not None, lines[-1]
    assert 0.0 < float(m.group(1)) < 5000 and 0.0 < float(m.group(2)) < 5000
    assert main(args + ["--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["converged"] and 0.0 < doc["solve_cpu_s"] < 5 and 0.0 < doc["solve_wall_s"] < 5
    assert doc["warnings"] == []


def test_talos_home_outside_its_ranges_is_said_once(capsys):
    """Talos's qpos0 has both arm_*_2 joints at 0, just outside their ranges: solve says
    so once on stderr (joints, values and the range ends it starts from), and the run
    starts from there; inspect lists the same line among its warnings."""
    urdf = str(robot_file("talos"))
    args = ["solve", "--model", urdf, "--body", "gripper_left_base_link"]
    assert main(args + ["--target", "0.3,0.3,0.2", "--solver", "dls"]) in (0, 1)
    err = capsys.readouterr().err.splitlines()
    home = [ln for ln in err if "home pose" in ln]
    assert len(home) == 1 and home[0].startswith("humanoid-ik: warning: the home pose (qpos0)")
    assert "'arm_left_2_joint' +0.0000 -> +0.0087" in home[0]
    assert "'arm_right_2_joint' +0.0000 -> -0.0087" in home[0]
    model = load_model(urdf)
    chain = Chain(model, body="gripper_left_base_link")
    i = chain.joint_names.index("arm_left_2_joint")
    assert chain.q_home[i] == pytest.approx(model.jnt_range[model.joint("arm_left_2_joint").id][0])
    assert main(["inspect", "--model", urdf]) == 0
    out = capsys.readouterr().out
    assert out.count("'arm_left_2_joint' +0.0000 -> +0.0087") == 1


KINOVA_HOME = (
    "the home pose (qpos0) has 3 joint(s) outside their ranges; solves start from it moved "
    "inside: 'j2s6s200_joint_2' +0.0000 -> +0.8203, 'j2s6s200_joint_3' +0.0000 -> +0.3316, "
    "'j2s6s200_joint_5' +0.0000 -> +0.5236 (rad, or m for slides)"
)


def test_home_outside_the_ranges_is_one_note_on_every_command(tmp_path, capsys):
    """Kinova's qpos0 has joints 2, 3 and 5 at 0, outside their ranges: loading it warns
    (HomeWarning, once per model), and run, render (which loads it twice: the scene's
    model and the film's stage) and bench each print it as one note line, naming the
    file, the joints and the values they start from."""
    urdf = robot_file("kinova")
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("default")  # Python's own rule: once per place and text
        model = load_model(urdf)
        load_model(urdf)
    assert [(w.category, str(w.message)) for w in said] == [
        (HomeWarning, f"model '{urdf}': {KINOVA_HOME}")
    ]
    chain = Chain(model, body="j2s6s200_end_effector")
    a, b = chain.fk(chain.q_home)[0], chain.fk(chain.q_home + 0.2)[0]
    pts = ", ".join(f"[{', '.join(f'{v:.5f}' for v in p)}]" for p in (a, b))
    scene = tmp_path / "kinova.toml"
    scene.write_text(
        f'name = "kinova"\nmodel = "{urdf}"\nduration = 1.0\nfps = 2\n[solver]\n'
        'name = "dls"\n[render]\nwidth = 64\nheight = 48\ncontact_sheet = 0\n'
        '[[targets]]\nname = "p"\n'
        f'motion = {{ kind = "points", points = [{pts}], hold = 0.5, travel = 0.0 }}\n'
        '[[effectors]]\nbody = "j2s6s200_end_effector"\ntarget = "p"\n'
    )
    bench = ["bench", "--model", str(urdf), "--body", "j2s6s200_end_effector"]
    for args in (
        ["run", str(scene), "--out", str(tmp_path / "run")],
        ["render", str(scene), "--out", str(tmp_path / "render"), "--no-video"],
        [*bench, "--solvers", "dls", "--n", "3"],
    ):
        assert main(args) == 0, args
        err = capsys.readouterr().err.splitlines()
        notes = [ln for ln in err if "home pose" in ln]
        assert notes == [f"humanoid-ik: note: model '{urdf}': {KINOVA_HOME}"], (args, err)


def test_two_link_refused_on_g1_default_chain(capsys):
    """two_link on G1's default hand chain (waist and arm): exit 2, one line with the
    reason and the fix; inspect lists it among the solvers that do not apply."""
    args = ["solve", "--model", str(robot_file("g1")), "--body", "left_rubber_hand"]
    assert main(args + ["--target", "0.2,0.2,0.2", "--solver", "two_link"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("humanoid-ik: error: two_link needs a wrist of at most 3 hinges")
    assert "'waist_pitch_joint'" in err and "--joints" in err
    assert main(["inspect", "--model", str(robot_file("g1"))]) == 0
    out = capsys.readouterr().out
    block = out[out.index("body left_rubber_hand:") :].split("\n\n")[0]
    assert "  not two_link: two_link needs a wrist of at most 3 hinges" in block
    assert "two_link" not in block.split("  solvers: ")[1].splitlines()[0]
    assert np.isfinite(float(block.split("reach ")[1].split()[0]))
