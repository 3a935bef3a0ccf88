"""Limbs found from a model (core/limbs.py): the bundled humanoid, real humanoids of
example-robot-data with their original URDFs, an MJCF humanoid written here, and the
profile file that overrides what was found."""

from __future__ import annotations

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, Target, solve
from humanoid_ik.core.limbs import (
    find_limbs,
    limb_chain,
    profile_file,
    profile_for,
)
from humanoid_ik.core.models import bundled_dir, load_model
from humanoid_ik.core.names import name_words
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.errors import ChainError, ModelError
from tests.robots import g1_arm, robot_file

# an MJCF humanoid in another convention: a floating base, L/R prefixes, a spine joint
# on both arms' path, a head camera, a sensor site and fingers past the wrists
_MJCF = """
<mujoco>
  <worldbody>
    <body name="Hips" pos="0 0 1">
      <freejoint/>
      <geom type="box" size=".1 .15 .1"/>
      <body name="Spine">
        <joint name="SpineYaw" axis="0 0 1"/>
        <geom type="box" size=".1 .15 .2" pos="0 0 .3"/>
        <body name="Neck" pos="0 0 .55">
          <joint name="NeckPitch" axis="0 1 0"/>
          <body name="Head" pos="0 0 .1">
            <geom type="sphere" size=".1"/>
            <camera name="eyes_cam" pos=".1 0 0" xyaxes="0 -1 0 0 0 1"/>
          </body>
        </body>
        ARMS
      </body>
    </body>
  </worldbody>
</mujoco>
"""
_ARM = """
        <body name="S_Clavicle" pos="0 @Y@ .5">
          <body name="S_UpperArm">
            <joint name="SShoulderPitch" axis="0 1 0"/>
            <joint name="SShoulderRoll" axis="1 0 0"/>
            <joint name="SShoulderYaw" axis="0 0 1"/>
            <geom type="capsule" fromto="0 0 0 0 0 -.3" size=".04"/>
            <body name="S_LowerArm" pos="0 0 -.3">
              <joint name="SElbow" axis="0 1 0"/>
              <geom type="capsule" fromto="0 0 0 0 0 -.25" size=".035"/>
              <body name="S_Hand" pos="0 0 -.25">
                <joint name="SWristYaw" axis="0 0 1"/>
                <geom type="box" size=".04 .02 .06"/>
                <site name="S_hand_imu" pos="0 0 -.02"/>
                <site name="S_palm" pos="0 0 -.06"/>
                <body name="S_Index1" pos="0 0 -.08">
                  <joint name="SIndex1" axis="0 1 0"/>
                  <geom type="capsule" fromto="0 0 0 0 0 -.03" size=".01"/>
                </body>
              </body>
            </body>
          </body>
        </body>"""


def _side(arm: str, prefix: str, y: str) -> str:
    return arm.replace('name="S', f'name="{prefix}').replace("@Y@", y)


def _mjcf_humanoid() -> mujoco.MjModel:
    return _humanoid(".2", "-.2")


def _humanoid(left_y: str, right_y: str) -> mujoco.MjModel:
    arms = _side(_ARM, "L", left_y) + _side(_ARM, "R", right_y)
    return mujoco.MjModel.from_xml_string(_MJCF.replace("ARMS", arms))


@pytest.fixture(scope="module")
def g1():
    return load_model(robot_file("g1"))


@pytest.fixture(scope="module")
def talos():
    return load_model(robot_file("talos"))


def test_name_words_splits_the_common_conventions():
    assert name_words("LShoulderPitch") == ["l", "shoulder", "pitch"]
    assert name_words("arm_left_1_joint") == ["arm", "left", "1", "joint"]
    assert name_words("RARM_ELBOW") == ["r", "arm", "elbow"]
    assert name_words("l_wrist_prosup") == ["l", "wrist", "prosup"]
    assert name_words("right_s0") == ["right", "s", "0"]


def test_bundled_humanoid_limbs_are_its_default_chains():
    model = load_model(None)
    prof = find_limbs(model)
    assert list(prof.limbs) == ["left_arm", "right_arm", "head"]
    right = Chain(model)
    assert list(prof.limb("right_arm").joints) == right.joint_names
    assert prof.limb("right_arm").end() == {"site": "right_palm_site"}
    assert prof.limb("left_arm").end() == {"site": "left_palm_site"}
    head = prof.limb("head")
    assert head.joints == ("neck_yaw_joint", "neck_pitch_joint")
    assert head.end() == {"site": "gaze_site"}
    np.testing.assert_allclose(head.axis, [1.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(prof.forward, [1.0, 0.0, 0.0], atol=1e-9)
    chain = limb_chain(model, "right_arm")
    assert chain.joint_names == right.joint_names and chain.ee_name == "right_palm_site"


def test_abbreviated_shoulder_and_wrist_names_make_arms():
    """``models/robot``'s ``r_sh_pitch`` .. ``r_wr_yaw``: ``sh`` and ``wr`` are arm words."""
    assert name_words("r_sh_pitch") == ["r", "sh", "pitch"]
    model = load_model(bundled_dir("models") / "robot" / "robot.xml")
    prof = find_limbs(model)
    for side in ("l", "r"):
        limb = prof.limb(f"{'left' if side == 'l' else 'right'}_arm")
        assert limb.joints == tuple(
            f"{side}_{j}"
            for j in ("sh_pitch", "sh_roll", "sh_yaw", "elbow", "wr_roll", "wr_pitch", "wr_yaw")
        )
    assert "waist_yaw" not in prof.limb("right_arm").joints


def test_g1_arms_leave_out_the_waist_and_its_head_is_fixed(g1):
    prof = find_limbs(g1)
    for side in ("left", "right"):
        arm = prof.limb(f"{side}_arm")
        assert arm.joints == g1_arm(side)
        assert arm.end() == {"body": f"{side}_rubber_hand"}
        leg = prof.limb(f"{side}_leg")
        assert len(leg.joints) == 6 and all(
            "hip" in j or "knee" in j or "ankle" in j for j in leg.joints
        )
    assert prof.limb("torso").joints == ("waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint")
    head = prof.limb("head")
    assert head.joints == () and head.end() == {"body": "head_link"}
    assert any("fixed" in n for n in prof.notes)
    with pytest.raises(ChainError, match="fixed"):
        limb_chain(g1, "head")
    torso_arm = limb_chain(g1, "left_arm", with_torso=True)
    assert torso_arm.joint_names[:3] == ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
    assert len(torso_arm.joint_names) == 10


def test_talos_arms_end_at_the_gripper_base_not_a_sensor(talos):
    prof = find_limbs(talos)
    left = prof.limb("left_arm")
    assert left.joints == tuple(f"arm_left_{k}_joint" for k in range(1, 8))
    assert left.end() == {"body": "gripper_left_base_link"}
    assert prof.limb("right_arm").end() == {"body": "gripper_right_base_link"}
    assert prof.limb("torso").joints == ("torso_1_joint", "torso_2_joint")
    assert prof.limb("head").joints == ("head_1_joint", "head_2_joint")


def test_both_arms_and_the_head_share_one_robot_without_sharing_joints(talos):
    from humanoid_ik.core.robot import Robot

    robot = Robot(talos)
    chains = [limb_chain(robot, n) for n in ("left_arm", "right_arm", "head")]
    joints = [set(c.joint_names) for c in chains]
    assert not (joints[0] & joints[1]) and not (joints[0] & joints[2])
    assert all(c.robot is robot for c in chains)


@pytest.mark.parametrize("side", ["left", "right"])
def test_g1_arm_solves_reachable_poses(g1, side):
    chain = limb_chain(g1, f"{side}_arm")
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = chain.random_q(rng)
        chain.set_q(q)
        target = Target(chain.position.copy(), mat_to_quat(chain.rotation))
        chain.set_q(chain.q_home)
        res = solve(chain, target)
        assert res.converged, res.message
        assert chain.within_limits(res.q)


def test_mjcf_humanoid_with_prefixes_a_spine_and_a_head_camera():
    model = _mjcf_humanoid()
    prof = find_limbs(model)
    left = prof.limb("left_arm")
    assert left.joints == ("LShoulderPitch", "LShoulderRoll", "LShoulderYaw", "LElbow", "LWristYaw")
    assert left.end() == {"site": "L_palm"}  # not the IMU site, not the finger
    assert prof.limb("right_arm").end() == {"site": "R_palm"}
    assert prof.limb("torso").joints == ("SpineYaw",)
    head = prof.limb("head")
    assert head.joints == ("NeckPitch",) and head.end() == {"body": "Head"}
    np.testing.assert_allclose(head.axis, [1.0, 0.0, 0.0], atol=1e-9)  # the camera's view
    np.testing.assert_allclose(prof.forward, [1.0, 0.0, 0.0], atol=1e-9)


def test_forward_follows_a_robot_turned_around():
    """Sides named, the robot built facing -x: the forward direction is -x."""
    model = _humanoid("-.2", ".2")
    np.testing.assert_allclose(find_limbs(model).forward, [-1.0, 0.0, 0.0], atol=1e-9)


def test_single_arm_robot_has_one_arm():
    prof = find_limbs(load_model(robot_file("panda")))
    arm = prof.limb("arm")
    assert arm.joints == tuple(f"panda_joint{k}" for k in range(1, 8))
    assert "left_arm" not in prof.limbs
    with pytest.raises(ChainError, match="limbs: arm"):
        prof.limb("left_arm")


def test_profile_round_trips_and_overrides_what_was_found(tmp_path):
    model = _mjcf_humanoid()
    path = tmp_path / "figure.xml"
    path.write_text("<mujoco/>")  # only its name matters to profile_file
    found = find_limbs(model)
    assert profile_file(path) == tmp_path / "figure.limbs.toml"
    assert profile_for(model, path) == found  # no profile file: what was found
    text = found.to_toml().replace('site = "L_palm"', 'body = "L_Hand"')
    profile_file(path).write_text(text)
    prof = profile_for(model, path)
    assert prof.limb("left_arm").end() == {"body": "L_Hand"}
    assert prof.limb("left_arm").source == "profile"
    assert prof.limb("right_arm").end() == found.limb("right_arm").end()
    assert limb_chain(model, "left_arm", profile=prof).ee_name == "L_Hand"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[limbs.left_arm]\njoints = ["nope"]\n', "limbs.left_arm.joints: no joint 'nope'"),
        ("[limbs.tail]\njoints = []\n", "limbs.tail: not a limb name; valid: left_arm"),
        ('[limbs.head]\nbody = "Nose"\n', "limbs.head.body: no body 'Nose'"),
        ("[limbs.head]\naxis = [0, 0, 0]\n", "limbs.head.axis: must be 3 numbers"),
        ("limbs = [", "is not TOML"),
    ],
)
def test_bad_profile_gives_one_line(tmp_path, text, message):
    path = tmp_path / "p.toml"
    path.write_text(text)
    with pytest.raises(ModelError, match=message.replace("[", r"\[")) as info:
        profile_for(_mjcf_humanoid(), override=path)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("robot", ["romeo", "icub"])
def test_closed_form_arms_are_found_and_auto_solves_them_exactly(robot):
    """Romeo's and iCub's seven arm joints (torso left out) are a spherical shoulder, an
    elbow and a spherical wrist: auto takes closed_form, and reaches every pose."""
    from humanoid_ik.solvers.auto import Auto

    model = load_model(robot_file(robot))
    auto = Auto()
    rng = np.random.default_rng(7)
    for side in ("left", "right"):
        chain = limb_chain(model, f"{side}_arm")
        assert len(chain.joint_names) == 7
        assert auto.choice(chain, True).name == "closed_form"
        for _ in range(15):
            chain.set_q(chain.random_q(rng))
            target = Target(chain.position.copy(), mat_to_quat(chain.rotation))
            res = auto.solve(chain, target, chain.q_home)
            assert res.converged and res.solver == "closed_form"
            assert chain.within_limits(res.q)


def test_other_humanoids_limbs():
    """Baxter's s0..w2, iCub facing -x, Romeo's gaze frame, a human model's spine."""
    baxter = find_limbs(load_model(robot_file("baxter")))
    assert baxter.limb("left_arm").joints == tuple(
        f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
    )
    assert baxter.limb("head").joints == ("head_pan",)
    icub = find_limbs(load_model(robot_file("icub")))
    np.testing.assert_allclose(icub.forward, [-1.0, 0.0, 0.0], atol=1e-5)
    assert icub.limb("torso").joints == ("torso_pitch", "torso_roll", "torso_yaw")
    assert icub.limb("head").joints == ("neck_pitch", "neck_roll", "neck_yaw")
    assert icub.limb("right_arm").end() == {"body": "r_hand"}
    romeo = find_limbs(load_model(robot_file("romeo")))
    assert romeo.limb("head").end() == {"body": "gaze"}
    assert romeo.limb("torso").joints == ("TrunkYaw",)
    assert romeo.limb("left_arm").joints[0] == "LShoulderPitch"
    assert romeo.limb("left_arm").joints[-1] == "LWristPitch"


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "humanoid_ik", *args], capture_output=True, text=True, timeout=300
    )


def test_cli_arm_and_limb_name_the_chain(tmp_path):
    g1 = str(robot_file("g1"))
    out = _cli("solve", "--model", g1, "--arm", "left", "--target", "0.30,0.12,0.02")
    assert out.returncode == 0, out.stderr
    assert "left_shoulder_pitch_joint" in out.stdout and "waist" not in out.stdout
    out = _cli(
        "solve", "--model", g1, "--arm", "left", "--with-torso", "--target", "0.30,0.12,0.02"
    )
    assert out.returncode == 0 and "waist_yaw_joint" in out.stdout
    for args, message in [
        (("--limb", "head"), "limb 'head' has no joints (it is fixed)"),
        (("--with-torso",), "--with-torso goes with --arm or --limb"),
        (("--arm", "left", "--joints", "waist_yaw_joint"), "--joints goes with --site or --body"),
        (("--arm", "middle"), "argument --arm: invalid choice: 'middle'"),
    ]:
        bad = _cli("solve", "--model", g1, *args, "--target", "0.2,0.2,1")
        assert bad.returncode != 0 and message in bad.stderr, bad.stderr
        assert bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr


def test_cli_inspect_names_the_limbs_and_saves_a_profile(tmp_path):
    talos = str(robot_file("talos"))
    saved = tmp_path / "talos.limbs.toml"
    out = _cli("inspect", "--model", talos, "--save-limbs", str(saved))
    assert out.returncode == 0, out.stderr
    text = out.stdout[out.stdout.index("limbs (") :]
    assert "left_arm   7 joint(s) arm_left_1_joint .. arm_left_7_joint" in text
    assert "-> body gripper_left_base_link" in text
    assert "torso      2 joint(s) torso_1_joint, torso_2_joint" in text
    assert "pose targets: auto runs lm" in text
    edited = saved.read_text().replace(
        'body = "gripper_left_base_link"', 'body = "arm_left_7_link"'
    )
    saved.write_text(edited)
    again = _cli("inspect", "--model", talos, "--limbs", str(saved), "--json")
    limbs = {lb["name"]: lb for lb in json.loads(again.stdout)["limbs"]}
    assert limbs["left_arm"]["end"] == "body arm_left_7_link"
    assert limbs["left_arm"]["source"] == "profile"
    solved = _cli(
        "solve", "--model", talos, "--arm", "left", "--limbs", str(saved), "--target", "0.1,0.3,0"
    )
    assert "arm_left_7_joint" in solved.stdout


def test_bench_render_and_replay_on_g1(tmp_path):
    """A real robot through bench (its left arm), a tiny render of a scene file and the
    replay of its trajectory: the same frame count, every frame written."""
    g1 = str(robot_file("g1"))
    bench = _cli("bench", "--model", g1, "--arm", "left", "--solvers", "lm", "--n", "20")
    assert bench.returncode == 0, bench.stderr
    assert "lm" in bench.stdout and "100.0" in bench.stdout
    scene = tmp_path / "g1.toml"
    scene.write_text(
        f'name = "g1_circle"\nmodel = "{g1}"\nduration = 1.0\nfps = 3\n'
        '[[targets]]\nname = "ball"\nmotion = { kind = "circle", center = [0.30, 0.12, 0.02], '
        "radius = 0.04, normal = [1, 0, 0], period = 1.0 }\n"
        '[[effectors]]\nbody = "left_rubber_hand"\ntarget = "ball"\n'
        + "joints = ["
        + ", ".join(f'"{j}"' for j in g1_arm("left"))
        + "]\n"
    )
    out = tmp_path / "render"
    run = _cli("render", str(scene), "--width", "64", "--height", "48", "--out", str(out))
    assert run.returncode == 0, run.stderr
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == 3
    again = tmp_path / "replay"
    replay = _cli(
        "replay", str(out / "trajectory.npz"), "--width", "64", "--height", "48",
        "--out", str(again),
    )  # fmt: skip
    assert replay.returncode == 0, replay.stderr
    assert len(sorted(again.glob("frame_*.png"))) == 3
