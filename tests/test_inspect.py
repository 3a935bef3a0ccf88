"""``humanoid-ik inspect``: the end effectors of a model, their joints, the solvers that
apply (and why the others do not), the reach, and the warnings, on the bundled humanoid,
the URDF arm, models with suspicious ranges and real robots of example-robot-data (G1,
Talos, UR5, Panda): no false degree warnings on +-2 pi, no sensor, camera or finger
frame offered, hand links offered, axes in the world frame, a home pose outside the
ranges said once."""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import home_qpos, load_model
from humanoid_ik.core.names import frame_role
from humanoid_ik.experiments.inspection import (
    home_outside_ranges,
    inspect_model,
    range_hints,
)
from tests.robots import PACKAGE, robot_file

REPO = Path(__file__).resolve().parents[1]
ARM7 = REPO / "examples" / "urdf_arm" / "arm7.urdf"
DEGREES = REPO / "tests" / "models" / "degrees_arm.xml"


def _effector(report, name):
    return next(e for e in report.effectors if e.name == name)


def test_humanoid_palm_joints_solvers_and_reach():
    """right_palm_site: the 7 arm hinges in order with their ranges in rad and deg,
    every reaching solver applies; the reach is the polyline shoulder-elbow-wrist-palm."""
    report = inspect_model()
    assert report.model == "models/humanoid/scene.xml" and not report.staged
    palm = _effector(report, "right_palm_site")
    assert palm.kind == "site"
    names = [j.name for j in palm.joints]
    assert names[0] == "right_shoulder_flexion_joint" and names[3] == "right_elbow_joint"
    assert len(names) == 7 and all(j.type == "hinge" for j in palm.joints)
    elbow = palm.joints[3]
    assert elbow.range_rad == pytest.approx((0.0, 2.62))
    assert elbow.range_deg == pytest.approx((0.0, math.degrees(2.62)))
    assert elbow.axis == pytest.approx((0.0, -1.0, 0.0)) and elbow.qpos0_inside
    assert palm.solvers["closed_form"] is None and palm.solvers["dls"] is None
    assert "does not reach" in palm.solvers["look_at"]
    assert palm.reach == pytest.approx(0.63, abs=1e-6)
    assert palm.base == pytest.approx((0.0, -0.19, 1.40))
    assert report.warnings == ()


def test_humanoid_says_why_a_solver_does_not_apply():
    """A 4-hinge chain (elbow site) is not closed_form's: the reason names the count; a
    site without hinges (torso) has no chain and says so."""
    report = inspect_model()
    elbow = _effector(report, "right_elbow_site")
    assert elbow.solvers["closed_form"] == (
        "closed_form needs 7 hinges (3 shoulder, elbow, 3 wrist); the chain has 4 joint(s)"
    )
    torso = next(o for o in report.others if o.name == "torso_site")
    assert (
        torso.kind == "site" and torso.reason == "no chain: no hinge joint moves site 'torso_site'"
    )
    assert "torso_site" not in [e.name for e in report.effectors]


def test_urdf_arm_offers_its_tool_link():
    """The URDF arm has no sites: its candidate is the leaf body tool_link with joint1..7,
    their URDF limits, reach 1.1 m (shoulder to tool: 0.2+0.2+0.2+0.2+0.18+0.06+0.06 from
    joint1), and a render needs the stage."""
    report = inspect_model(ARM7)
    assert report.staged and report.counts == {"bodies": 10, "joints": 7, "sites": 0, "cameras": 0}
    assert [(e.kind, e.name) for e in report.effectors] == [("body", "tool_link")]
    assert report.others == ()
    tool = report.effectors[0]
    assert [j.name for j in tool.joints] == [f"joint{i}" for i in range(1, 8)]
    assert tool.joints[1].range_rad == pytest.approx((-2.0, 2.0))
    assert tool.joints[1].axis == pytest.approx((0.0, 1.0, 0.0))
    assert tool.reach == pytest.approx(1.10, abs=1e-9)
    assert tool.base == pytest.approx((0.0, 0.0, 0.10))
    assert tool.solvers["dls"] is None


def test_ranges_read_as_degrees_are_flagged():
    """An MJCF without angle="radian" and range="-3 3" reads +-3 deg: inspect warns, and
    a failed solve on it prints the same hint."""
    report = inspect_model(DEGREES)
    assert len(report.warnings) == 2
    assert report.warnings[0].startswith("joint 'shoulder' range -3 .. 3 deg (-0.0524 .. ")
    assert 'add <compiler angle="radian"/>' in report.warnings[0]
    assert report.effectors[0].joints[0].range_rad == pytest.approx(
        (-math.radians(3), math.radians(3))
    )


def test_failed_solve_hints_at_degrees(capsys):
    """Every solve on the degrees arm fails (the arm barely moves); the output hints at
    the angle unit, once per joint of the chain."""
    code = main(
        [
            "solve",
            "--model",
            str(DEGREES),
            "--site",
            "tip",
            "--target",
            "0.3,0,0.8",
            "--solver",
            "dls",
        ]
    )
    out = capsys.readouterr().out
    assert code == 1
    hints = [line for line in out.splitlines() if line.startswith("hint: ")]
    assert len(hints) == 2 and "joint 'elbow' range -3 .. 3 deg" in hints[1]


def test_wide_ranges_free_joint_and_unlimited_joint(tmp_path):
    """A radian MJCF with range="-180 180" (wider than 2 pi), a hinge without a range and a
    free joint on the path each give one warning; qpos0 outside a range is marked."""
    p = tmp_path / "odd.xml"
    p.write_text(
        """<mujoco><compiler angle="radian"/><worldbody>
  <body name="base" pos="0 0 1"><freejoint name="float"/>
    <geom type="sphere" size="0.05"/>
    <body name="a"><joint name="wide" axis="0 0 1" range="-180 180"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="b" pos="0.3 0 0"><joint name="free_spin" axis="0 1 0" limited="false"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
        <body name="c" pos="0.2 0 0"><joint name="late" axis="0 1 0" range="0.5 1"/>
          <geom type="sphere" size="0.02"/><site name="tip"/></body></body></body></body>
</worldbody></mujoco>"""
    )
    report = inspect_model(p)
    w = "\n".join(report.warnings)
    assert "joint 'wide' range -180 .. +180 rad goes beyond a full turn (+-2 pi)" in w
    assert "joint 'free_spin' has no range" in w
    assert (
        "the home pose (qpos0) has 1 joint(s) outside their ranges; solves start from it "
        "moved inside: 'late' +0.0000 -> +0.5000 (rad, or m for slides)"
    ) in report.warnings
    assert "free joint 'float' on the path of site 'tip'" in w
    tip = _effector(report, "tip")
    assert [j.name for j in tip.joints] == ["wide", "free_spin", "late"]
    assert tip.joints[1].range_rad is None and not tip.joints[2].qpos0_inside
    assert range_hints(load_model(p)) == [
        x for x in report.warnings if "free joint" not in x and "home pose" not in x
    ]


def test_cli_inspect_text_and_json(capsys):
    """inspect prints the joint table; --json gives the same report as a document."""
    assert main(["inspect", "--model", str(ARM7)]) == 0
    out = capsys.readouterr().out
    head = "body tool_link: 7 joint(s), reach 1.100 m (sampled, 500 poses)"
    assert f"{head} from [0.000, 0.000, 0.100]" in out
    assert "  joint   type   axis (world, home)  range [rad]       range [deg]       qpos0" in out
    assert "  joint2  hinge  +0.00 +1.00 +0.00   -2.000 .. +2.000  -114.6 .. +114.6  +0.000" in out
    assert "not look_at: " in out and "warnings: none" in out
    assert main(["inspect", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    palm = next(e for e in doc["effectors"] if e["name"] == "right_palm_site")
    assert palm["joints"][3]["range_rad"] == pytest.approx([0.0, 2.62])
    assert doc["counts"]["sites"] == 10


def test_cli_inspect_bad_model_is_one_line(capsys, tmp_path):
    """A missing model file: exit 2, one line naming it."""
    code = main(["inspect", "--model", str(tmp_path / "none.urdf")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "none.urdf' does not exist" in err


# ----------------------------------------------------------------------------- real robots
def mjcf_copy(robot: str, folder: Path) -> Path:
    """The robot's original URDF as MuJoCo compiles it (links on fixed joints kept, the
    ``package://`` meshes pointed at the installed package), saved as MJCF in
    ``folder``: for robots whose visual meshes need a converter the loader may lack."""
    spec = mujoco.MjSpec.from_file(str(robot_file(robot)))
    for mesh in spec.meshes:
        if mesh.file.startswith("package:"):
            rest = mesh.file.split(":", 1)[1].lstrip("/")  # example-robot-data/robots/...
            mesh.file = str(PACKAGE.parent / rest)
    spec.compiler.fusestatic = False
    spec.compile()
    out = folder / f"{robot}.xml"
    out.write_text(spec.to_xml())
    return out


@pytest.fixture(scope="module")
def g1():
    """inspect on G1's original URDF."""
    return inspect_model(robot_file("g1"))


@pytest.fixture(scope="module")
def talos():
    """inspect on Talos's original URDF."""
    return inspect_model(robot_file("talos"))


def test_ur5_full_turn_ranges_are_not_degrees(tmp_path, capsys):
    """UR5's +-2 pi limits are radians: no warning, no hint under a failed solve; a range
    end beyond a full turn (+-2 pi + 0.01) still is degrees, one just inside is not."""
    ur5 = mjcf_copy("ur5", tmp_path)
    report = inspect_model(ur5)
    pan = _effector(report, "tool0").joints[0]
    assert pan.range_rad == pytest.approx((-2 * math.pi, 2 * math.pi), abs=1e-5)
    assert report.warnings == () and range_hints(load_model(ur5), ur5) == []
    far = ["solve", "--model", str(ur5), "--body", "tool0", "--target", "3,0,0.5"]
    assert main(far) == 1
    assert "hint:" not in capsys.readouterr().out
    xml = """<mujoco><compiler angle="radian"/><worldbody><body>
      <joint name="inside" axis="0 0 1" range="-6.29 6.29"/><geom size=".1"/>
      <body><joint name="beyond" axis="0 1 0" range="-6.3 6.3"/><geom size=".1"/>
      <body><joint name="deg" axis="0 1 0" range="0 90"/><geom size=".1"/>
      </body></body></body></worldbody></mujoco>"""
    hints = range_hints(mujoco.MjModel.from_xml_string(xml))
    assert [h.split("'")[1] for h in hints] == ["beyond", "deg"]


def test_g1_end_effectors_are_its_hands_feet_and_head(g1):
    """G1: the feet, the head and the rubber hands; its IMUs, camera (d435), lidar
    (mid360) and logo are listed apart with the reason; the count in the text's header
    is the number of effectors it lists."""
    assert [e.name for e in g1.effectors] == [
        "left_ankle_roll_link",
        "right_ankle_roll_link",
        "head_link",
        "left_rubber_hand",
        "right_rubber_hand",
    ]
    reasons = {o.name: o.reason for o in g1.others}
    assert reasons["imu_in_torso"] == reasons["imu_in_pelvis"] == "sensor frame"
    assert reasons["mid360_link"] == "sensor frame" and reasons["d435_link"] == "camera frame"
    assert reasons["logo_link"] == "visual or helper frame"
    assert reasons["pelvis_contour_link"].startswith("no chain: no hinge joint moves")
    text = g1.text()
    listed = [ln for ln in text.splitlines() if ln.startswith(("site ", "body "))]
    assert text.splitlines()[1].startswith(f"{len(listed)} end effector(s)") and len(listed) == 5
    assert "  sensor frame: imu_in_torso, mid360_link, imu_in_pelvis" in text


def test_g1_axes_are_world_axes_at_home(g1):
    """The table's axes are the world axes at the home pose (MuJoCo's xaxis), labelled:
    G1's hip roll turns about its body's x, which the hip's rest rotation tilts by 0.17 rad."""
    foot = _effector(g1, "left_ankle_roll_link")
    roll = next(j for j in foot.joints if j.name == "left_hip_roll_joint")
    model = load_model(robot_file("g1"))
    data = mujoco.MjData(model)
    data.qpos[:] = home_qpos(model)
    mujoco.mj_kinematics(model, data)
    world = data.xaxis[model.joint("left_hip_roll_joint").id]
    assert roll.world_axis == pytest.approx(tuple(world), abs=1e-12)
    assert roll.axis == (1.0, 0.0, 0.0) and abs(world[2]) > 0.17
    assert "axis (world, home)" in g1.text() and "+0.98 +0.00 +0.17" in g1.text()


def test_talos_offers_its_gripper_base(talos):
    """Talos: the gripper's base link (not a leaf: its children are the gripper's motors,
    links and fingertips) and the soles; the gripper's parts, the IMU and the RGB-D
    frames are not end effectors; two_link does not apply to the 9-joint torso-and-arm
    chain and says why."""
    names = [e.name for e in talos.effectors]
    assert names == [
        "gripper_left_base_link",
        "gripper_right_base_link",
        "left_sole_link",
        "right_sole_link",
    ]
    reasons = {o.name: o.reason for o in talos.others}
    assert reasons["gripper_left_fingertip_1_link"] == "finger"
    assert reasons["gripper_left_motor_double_link"] == "gripper part"
    assert reasons["imu_link"] == "sensor frame"
    assert reasons["rgbd_optical_frame"] == "camera frame"
    hand = _effector(talos, "gripper_left_base_link")
    assert len(hand.joints) == 9 and "wrist of at most 3 hinges" in hand.solvers["two_link"]


def test_frame_roles():
    """Names as robots write them: CamelCase, glued numbers, suffixes."""
    assert frame_role("LFsrRCenter_frame") == "sensor"
    assert frame_role("CameraLeftEye_frame") == "camera"
    assert frame_role("panda_leftfinger") == "finger"
    assert frame_role("dummyhead1") == "helper"
    assert frame_role("wrist_left_ft_tool_link") == "sensor"
    assert frame_role("j2s6s200_end_effector") == "hand"
    assert frame_role("gripper_left_motor_double_link") == "part"
    assert frame_role("left_ankle_roll_link") is None


def test_home_outside_the_ranges_is_said_once(tmp_path, capsys):
    """Panda's qpos0 has joint 4 at 0, outside its range [-3.07, -0.07]: inspect warns
    once naming it and the value solves start from (the range end, as the chain's
    home and the robot's reset take it); solve prints it once on stderr."""
    panda = mjcf_copy("panda", tmp_path)
    model = load_model(panda)
    assert home_outside_ranges(model) == [("panda_joint4", 0.0, pytest.approx(-0.0698, abs=1e-4))]
    chain = Chain(model, body="panda_hand_tcp")
    assert chain.q_home[3] == pytest.approx(-0.0698, abs=1e-4)
    assert chain.data.qpos[model.joint("panda_joint4").qposadr[0]] == chain.q_home[3]
    report = inspect_model(panda)
    home = [w for w in report.warnings if "home pose" in w]
    assert home == [
        "the home pose (qpos0) has 1 joint(s) outside their ranges; solves start from it "
        "moved inside: 'panda_joint4' +0.0000 -> -0.0698 (rad, or m for slides)"
    ]
    args = ["solve", "--model", str(panda), "--body", "panda_hand_tcp", "--target", "0.4,0,0.5"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert err.count("panda_joint4") == 1 and err.startswith("humanoid-ik: warning: the home pose")
    assert main(["solve"] + args[1:] + ["--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == home
    joints = np.array(home_qpos(model))
    assert joints[model.joint("panda_joint4").qposadr[0]] == 0.0  # the model is unchanged


def test_joints_choose_the_chains(capsys):
    """--joints: each end effector both joints move gets a chain of those two; the
    others are listed as not moved by them; an unknown joint is one line naming it."""
    report = inspect_model(None, ["right_shoulder_flexion_joint", "right_elbow_joint"])
    assert [e.name for e in report.effectors] == [
        "right_elbow_site",
        "right_wrist_site",
        "right_palm_site",
        "right_hand_link",
    ]
    assert all(len(e.joints) == 2 for e in report.effectors)
    skipped = {o.name for o in report.others if o.reason == "not moved by every joint given"}
    assert {"gaze_site", "left_palm_site", "right_shoulder_site"} <= skipped
    assert main(["inspect", "--joints", "nope"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("humanoid-ik: error: joint 'nope' not in model")
