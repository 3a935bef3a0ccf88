"""BVH and keyframe export of real trajectories: the BVH of `showcase` and of a G1 run
(example-robot-data's original URDF) parses with an independent reader (bvhio) whose
forward kinematics puts the hands, the head and every joint where MuJoCo does in every
frame, rest rotations, slanted hinges, ball joints and floating bases included; what
BVH cannot hold is refused pointing at export-keyframes; the keyframes load into the
model with the same qpos."""

from __future__ import annotations

import dataclasses
import json
import math
import xml.etree.ElementTree as ET

import bvhio
import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot import joint_name
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.experiments.retarget import retarget
from humanoid_ik.motion.human import human_bvh
from humanoid_ik.outputs.bvh import bvh_text
from humanoid_ik.outputs.keyframes import keyframes_xml
from humanoid_ik.outputs.run_files import write_run
from humanoid_ik.outputs.trajectory import load_trajectory, write_trajectory
from humanoid_ik.run.trajectory import EffectorTrack, Trajectory, qpos_names
from tests.robots import robot_file

ENDS = ("right_palm_site", "left_palm_site", "gaze_site")
"""The hands and the head (the gaze point on the face) compared with MuJoCo."""


@pytest.fixture(scope="module")
def showcase(tmp_path_factory):
    """showcase run in full: 180 frames over 6 s (both hands and the head move)."""
    folder = tmp_path_factory.mktemp("showcase")
    out = write_run(load_scene("showcase"), folder)
    return out.trajectory[0]


def mujoco_ends(model, qpos: np.ndarray) -> dict[str, np.ndarray]:
    """World positions of the hands and the head at ``qpos`` [m], MuJoCo axes."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return {s: data.site(s).xpos.copy() for s in ENDS}


def from_bvh_axes(p, scale: float) -> np.ndarray:
    """A BVH point (X, Y, Z) = MuJoCo (y, z, x), in MuJoCo axes [m]."""
    x, y, z = (float(v) / scale for v in p)
    return np.array([z, x, y])


@pytest.mark.parametrize(("units", "scale"), [("m", 1.0), ("cm", 100.0)])
def test_bvh_forward_kinematics_matches_mujoco(showcase, tmp_path, units, scale):
    """Every frame: bvhio's FK of the parsed skeleton puts both palms and the gaze point
    within 1e-6 m of MuJoCo's site positions (after the documented Y-up mapping)."""
    path = tmp_path / "motion.bvh"
    assert main(["export-bvh", str(showcase), "--out", str(path), "--units", units]) == 0
    traj = load_trajectory(showcase)
    model = load_model(traj.model_file)
    bvh = bvhio.readAsBvh(str(path))
    assert bvh.FrameCount == 180 and bvh.FrameTime == pytest.approx(1 / 30)
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    assert {"torso_link", "head_link", "right_upper_arm_link", "right_forearm_link"} <= set(joints)
    assert {"right_hand_link", "left_hand_link", *ENDS} <= set(joints)
    worst = 0.0
    moved = {s: [] for s in ENDS}
    for f in range(traj.n_frames):
        root.loadPose(f)
        want = mujoco_ends(model, traj.qpos[f])
        for s in ENDS:
            got = from_bvh_axes(joints[s].PositionWorld, scale)
            worst = max(worst, float(np.abs(got - want[s]).max()))
            moved[s].append(got)
    assert worst < 1e-6, worst
    for s in ENDS:  # the comparison is not trivial: every end moves over the scene
        assert np.ptp(np.array(moved[s]), axis=0).max() > 0.05, s


def test_bvh_skeleton_offsets_are_the_models_lengths(showcase):
    """Upper arm 0.30 m, forearm 0.25 m, shoulder 0.19 m to the side, Y up; channels from
    the hinge axes in joint order."""
    traj = load_trajectory(showcase)
    text = bvh_text(traj, load_model(traj.model_file))
    lines = [ln.strip() for ln in text.splitlines()]

    def block(name: str) -> list[str]:
        i = lines.index(f"JOINT {name}")
        return lines[i + 2 : i + 4]

    assert block("right_upper_arm_link") == [
        "OFFSET -0.1900000000 0.4000000000 0.0000000000",
        "CHANNELS 3 Xrotation Zrotation Yrotation",
    ]
    assert block("right_forearm_link")[0] == "OFFSET 0.0000000000 -0.3000000000 0.0000000000"
    assert block("right_hand_link") == [
        "OFFSET 0.0000000000 -0.2500000000 0.0000000000",
        "CHANNELS 3 Yrotation Zrotation Xrotation",
    ]
    assert block("head_link")[1] == "CHANNELS 2 Yrotation Xrotation"
    assert lines[1:5] == [
        "ROOT torso_link",
        "{",
        "OFFSET 0.0000000000 1.0000000000 0.0000000000",
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
    ]
    # right shoulder flexion turns about MuJoCo -y = BVH -X: its channel is the negated angle
    first = [float(v) for v in lines[lines.index("MOTION") + 3].split()]
    q = traj.joint("right_shoulder_flexion_joint")[0]
    assert first[6 + 2] == pytest.approx(-np.degrees(q), abs=1e-9)


# a floating base, a body with a rest rotation whose hinge is along a world axis, a
# slanted hinge, a ball joint, two hinges about one point, a rotated sensor body without
# joints (folded into its parent) with a site past it, and a finger on a slide joint
TREE_XML = """<mujoco><worldbody>
<body name="base" pos="0 0 1"><freejoint name="float"/><geom size=".05"/>
  <body name="turned" pos="0.2 0 0" quat="0.7071068 0 0 0.7071068">
    <joint name="along" axis="1 0 0"/><geom size=".03"/>
    <body name="slanted" pos="0.3 0 0"><joint name="slant" axis="1 1 0"/><geom size=".03"/>
      <body name="sensor_mount" pos="0.1 0.05 0" quat="0.9238795 0.3826834 0 0">
        <site name="beyond" pos="0.15 0 0.02"/></body></body></body>
  <body name="cup" pos="0 0.2 0"><joint name="cup" type="ball"/><geom size=".03"/>
    <site name="cup_tip" pos="0 0.2 0.1"/></body>
  <body name="twice" pos="0 -0.2 0"><joint name="t1" axis="0 0 1"/><joint name="t2" axis="0 1 0"/>
    <geom size=".03"/><site name="twice_tip" pos="0 -0.2 0"/>
    <body name="finger" pos="0 -0.25 0"><joint name="slide" type="slide" axis="0 1 0"/>
      <geom size=".01"/><site name="finger_tip" pos="0 -0.05 0"/></body></body>
</body></worldbody></mujoco>"""
TREE_SITES = ("beyond", "cup_tip", "twice_tip", "finger_tip")


def motion(model: mujoco.MjModel, qpos: np.ndarray) -> Trajectory:
    """A trajectory of ``qpos`` ``(F, nq)`` on ``model`` at 30 frames/s, no effectors."""
    return Trajectory(
        time=np.arange(len(qpos)) / 30.0,
        qpos=qpos,
        qpos_names=tuple(qpos_names(model)),
        joint_names=tuple(joint_name(model, j) for j in range(model.njnt)),
        effectors=(),
        fps=30.0,
        scene="tree",
        scene_file="",
        model_file="",
        model_sha256="",
    )


def tree_motion(model: mujoco.MjModel, frames: int, seed: int = 1) -> np.ndarray:
    """Random poses: the base moved and turned, every hinge and the ball turned far, the
    finger's slide left at 0."""
    rng = np.random.default_rng(seed)
    qpos = np.tile(model.qpos0, (frames, 1))
    for f in range(frames):
        for j in range(model.njnt):
            a = model.jnt_qposadr[j]
            t = model.jnt_type[j]
            if t == mujoco.mjtJoint.mjJNT_FREE:
                qpos[f, a : a + 3] = rng.uniform(-1, 1, 3)
                qpos[f, a + 3 : a + 7] = rng.normal(size=4) / 1.0
                qpos[f, a + 3 : a + 7] /= np.linalg.norm(qpos[f, a + 3 : a + 7])
            elif t == mujoco.mjtJoint.mjJNT_BALL:
                quat = rng.normal(size=4)
                qpos[f, a : a + 4] = quat / np.linalg.norm(quat)
            elif t == mujoco.mjtJoint.mjJNT_HINGE:
                qpos[f, a] = rng.uniform(-2.5, 2.5)
    return qpos


def test_bvh_holds_rest_rotations_slanted_hinges_balls_and_a_floating_base(tmp_path):
    """A model with every case BVH holds: bvhio's FK of the parsed file puts each site
    where MuJoCo does in 20 random frames (1e-5 m: bvhio computes in float32); a hinge
    along a world axis at qpos0 is one channel (the joint's angle, though its body has
    a rest rotation), a slanted hinge or a ball three; the jointless rotated body and
    the held slide are folded."""
    model = mujoco.MjModel.from_xml_string(TREE_XML)
    traj = motion(model, tree_motion(model, 20))
    path = tmp_path / "tree.bvh"
    path.write_text(bvh_text(traj, model))
    lines = [ln.strip() for ln in path.read_text().splitlines()]

    def channels(name: str) -> str:
        return lines[lines.index(f"JOINT {name}") + 3]

    assert lines[1] == "ROOT base"
    assert channels("turned") == "CHANNELS 1 Xrotation"  # local x turned to world y
    assert channels("slanted") == "CHANNELS 3 Zrotation Xrotation Yrotation"
    assert channels("cup") == "CHANNELS 3 Zrotation Xrotation Yrotation"
    assert channels("twice") == "CHANNELS 2 Yrotation Xrotation"
    assert "JOINT sensor_mount" not in lines and "JOINT finger" not in lines
    first = [float(v) for v in lines[lines.index("MOTION") + 3].split()]
    assert first[6] == pytest.approx(np.degrees(traj.joint("along")[0]), abs=1e-9)
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    data = mujoco.MjData(model)
    worst = 0.0
    for f in range(traj.n_frames):
        root.loadPose(f)
        data.qpos[:] = traj.qpos[f]
        mujoco.mj_kinematics(model, data)
        for s in TREE_SITES:
            got = from_bvh_axes(joints[s].PositionWorld, 1.0)
            worst = max(worst, float(np.abs(got - data.site(s).xpos).max()))
    assert worst < 1e-5, worst


@pytest.mark.parametrize(
    ("xml", "message"),
    [
        (TREE_XML, "joint 'slide' is a slide joint that moves in this trajectory"),
        (
            "<mujoco><worldbody><body><joint name='a' axis='0 0 1'/>"
            "<joint name='b' pos='0.1 0 0' axis='0 1 0'/><geom size='.1'/></body>"
            "</worldbody></mujoco>",
            "the joints of body 'body1' turn about different points",
        ),
        (
            "<mujoco><worldbody><body><freejoint/><geom size='.1'/></body>"
            "<body name='loose'><joint type='slide'/><geom size='.1'/></body>"
            "</worldbody></mujoco>",
            "joint 'joint0' is a free joint below the skeleton's root",
        ),
        ("<mujoco><worldbody><body><geom size='.1'/></body></worldbody></mujoco>", None),
    ],
)
def test_bvh_refuses_what_it_cannot_hold(xml, message):
    """A slide that moves, hinges of one body about two points, a free joint below the
    root (two bodies on the world): one line naming the joint or body and pointing at
    export-keyframes; a model without joints: one line."""
    model = mujoco.MjModel.from_xml_string(xml)
    qpos = np.tile(model.qpos0, (3, 1))
    qpos[1, model.nq - 1 :] += 0.01  # the last joint moves (if there is one)
    with pytest.raises(TrajectoryFileError) as err:
        bvh_text(motion(model, qpos), model)
    text = str(err.value)
    assert "\n" not in text
    if message is None:
        assert text == "BVH export needs a model with hinge joints; it has none"
    else:
        assert message in text and "export-keyframes writes any model's motion" in text


GRIPPER_ARM = """<mujoco><compiler angle="radian"/><worldbody>
<body name="base" pos="0 0 0.5"><geom size=".05"/>
  <body name="upper"><joint name="shoulder" axis="0 1 0" range="-2 2"/><geom size=".03"/>
    <body name="fore" pos="0.3 0 0"><joint name="elbow" axis="0 1 0" range="-2 2"/>
      <geom size=".03"/><site name="tip" pos="0.25 0 0"/>
      <body name="finger" pos="0.25 0 0">
        <joint name="grip" type="slide" axis="0 0 1" range="0 0.04"/><geom size=".01"/>
      </body></body></body></body></worldbody></mujoco>"""


def test_export_bvh_holds_a_still_finger_and_refuses_a_moving_one(tmp_path, capsys):
    """A run of an arm with a slide finger it never moves exports (the finger folded into
    the forearm); the same trajectory with the finger moving is refused in one line
    that points at export-keyframes, which writes it."""
    (tmp_path / "arm.xml").write_text(GRIPPER_ARM)
    (tmp_path / "reach.toml").write_text(
        """name = "grip"
model = "arm.xml"
duration = 0.1
fps = 30
[solver]
name = "dls"
[[targets]]
name = "ball"
[targets.motion]
kind = "circle"
center = [0.35, 0, 0.3]
radius = 0.05
normal = [0, 1, 0]
period = 0.1
[[effectors]]
site = "tip"
target = "ball"
"""
    )
    out = write_run(load_scene(tmp_path / "reach.toml"), tmp_path / "run")
    bvh = tmp_path / "arm.bvh"
    assert main(["export-bvh", str(out.trajectory[0]), "--out", str(bvh)]) == 0
    text = bvh.read_text()
    assert "JOINT fore" in text and "JOINT finger" not in text
    traj = load_trajectory(out.trajectory[0])
    qpos = traj.qpos.copy()
    qpos[1, traj.qpos_names.index("grip")] = 0.02
    moved = write_trajectory(dataclasses.replace(traj, qpos=qpos), tmp_path)[0]
    capsys.readouterr()
    assert main(["export-bvh", str(moved), "--out", str(tmp_path / "x.bvh")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "joint 'grip' is a slide joint that moves" in err
    assert "export-keyframes writes any model's motion" in err
    assert main(["export-keyframes", str(moved), "--out", str(tmp_path / "keys.xml")]) == 0


@pytest.fixture(scope="module")
def g1_run(tmp_path_factory):
    """The G1 (its original URDF) reaching with its left hand for 4 frames: the
    trajectory file, its model and the BVH ``export-bvh`` wrote."""
    folder = tmp_path_factory.mktemp("g1")
    arm = [
        f"left_{j}_joint"
        for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll")
    ]
    scene = folder / "reach.toml"
    scene.write_text(
        f"""name = "g1_reach"
model = "{robot_file("g1")}"
duration = 0.2
fps = 20
[solver]
name = "lm"
[[targets]]
name = "ball"
[targets.motion]
kind = "circle"
center = [0.25, 0.25, 0.15]
radius = 0.05
normal = [1, 0, 0]
period = 0.2
[[effectors]]
body = "left_rubber_hand"
joints = {json.dumps(arm)}
target = "ball"
"""
    )
    out = write_run(load_scene(scene), folder / "out")
    bvh = folder / "g1.bvh"
    assert main(["export-bvh", str(out.trajectory[0]), "--out", str(bvh)]) == 0
    traj = load_trajectory(out.trajectory[0])
    return traj, load_model(traj.model_file), bvh


def test_g1_exports_its_joint_tree(g1_run):
    """G1: the BVH has the root (the pelvis), one joint per hinge body and the run's end
    effector (the fixed ``left_rubber_hand``, without channels), 31 in all; the IMU,
    camera and lidar links (fixed, rotated) are folded in; bvhio's FK puts every
    joint where MuJoCo has its anchor, in every frame; the elbow's channels hold the
    elbow's angle (its axis is 2e-4 off the world's y at qpos0: three channels)."""
    traj, model, path = g1_run
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    hinged = [mujoco.mj_id2name(model, 1, b) for b in range(model.nbody) if model.body_jntnum[b]]
    assert set(joints) == {"pelvis", *hinged, "left_rubber_hand"} and len(joints) == 31
    assert not {"imu_in_torso", "d435_link", "mid360_link", "logo_link"} & set(joints)
    data = mujoco.MjData(model)
    worst, moved = 0.0, []
    elbow = traj.joint("left_elbow_joint")
    for f in range(traj.n_frames):
        root.loadPose(f)
        data.qpos[:] = traj.qpos[f]
        mujoco.mj_kinematics(model, data)
        for name in hinged:
            b = model.body(name).id
            got = from_bvh_axes(joints[name].PositionWorld, 1.0)
            worst = max(worst, float(np.abs(got - data.xanchor[model.body_jntadr[b]]).max()))
        moved.append(from_bvh_axes(joints["left_wrist_yaw_link"].PositionWorld, 1.0))
        rot = joints["left_elbow_link"].Keyframes[f][1].Rotation
        assert 2 * math.degrees(math.acos(min(1.0, abs(rot.w)))) == pytest.approx(
            math.degrees(abs(elbow[f])), abs=0.05
        )
    assert worst < 1e-6, worst
    assert np.ptp(np.array(moved), axis=0).max() > 0.01  # the arm moved
    assert np.ptp(elbow) > 0.01


@pytest.fixture(scope="module")
def wave_clip(tmp_path_factory):
    """The procedural human's wave, 1 s at 120 Hz (CMU names, Y up, cm), as a file."""
    path = tmp_path_factory.mktemp("clip") / "wave.bvh"
    path.write_text(human_bvh("wave", seconds=1.0))
    return path


@pytest.mark.parametrize("robot", ["humanoid", "g1"])
def test_retargeted_bvh_matches_mujoco_hands(wave_clip, tmp_path, robot):
    """A retargeted wave (60 frames: the right arm starts rising) exports for the bundled
    humanoid (palm sites, the gaze site) and G1 (hands that are fixed bodies,
    ``left_rubber_hand``, folded into the wrists: written as joints without channels);
    bvhio's FK of the parsed file puts every end-effector frame where MuJoCo has it, in
    every frame, within 1e-6 m, and the hands moved."""
    model_path = None if robot == "humanoid" else robot_file("g1")
    traj = retarget(wave_clip, model_path, None, frames=60).trajectory
    model = load_model(model_path)
    path = tmp_path / "robot.bvh"
    path.write_text(bvh_text(traj, model))
    assert bvhio.readAsBvh(str(path)).FrameCount == 60
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    ends = [e.site for e in traj.effectors]
    want = {"humanoid": ["left_palm_site", "right_palm_site", "gaze_site"]}
    assert ends == want.get(robot, ["left_rubber_hand", "right_rubber_hand"])
    assert set(ends) <= set(joints)
    data = mujoco.MjData(model)
    worst, moved = 0.0, {e: [] for e in ends}
    for f in range(traj.n_frames):
        root.loadPose(f)
        data.qpos[:] = traj.qpos[f]
        mujoco.mj_kinematics(model, data)
        for e in traj.effectors:
            mj = data.site(e.site).xpos if e.kind == "site" else data.body(e.site).xpos
            got = from_bvh_axes(joints[e.site].PositionWorld, 1.0)
            worst = max(worst, float(np.abs(got - mj).max()))
            moved[e.site].append(got)
            if e.task == "reach":  # the trajectory's own record of the hand agrees
                np.testing.assert_allclose(mj, e.achieved[f], atol=1e-12)
    assert worst < 1e-6, worst
    hand = "right_palm_site" if robot == "humanoid" else "right_rubber_hand"
    assert np.ptp(np.array(moved[hand]), axis=0).max() > 0.02  # the waving hand rose


def test_a_jointed_end_body_off_its_anchor_is_written_at_its_origin(tmp_path):
    """An effector on a body whose hinge is away from the body's origin: the origin is a
    ``<body>_origin`` joint without channels, where MuJoCo has the body (1e-5 m)."""
    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body name='arm' pos='0 0 1'><joint name='a' pos='0 0 -0.1' "
        "axis='0 1 0'/><geom size='.05'/></body></worldbody></mujoco>"
    )
    qpos = np.linspace(-1.5, 1.5, 7)[:, None]
    traj = dataclasses.replace(motion(model, qpos), effectors=(_track("arm", 7),))
    path = tmp_path / "arm.bvh"
    path.write_text(bvh_text(traj, model))
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    assert "arm_origin" in joints
    data = mujoco.MjData(model)
    for f in range(7):
        root.loadPose(f)
        data.qpos[:] = qpos[f]
        mujoco.mj_kinematics(model, data)
        got = from_bvh_axes(joints["arm_origin"].PositionWorld, 1.0)
        assert np.abs(got - data.body("arm").xpos).max() < 1e-5


def _track(body: str, frames: int) -> EffectorTrack:
    """A reach effector on ``body`` over ``frames`` frames (the values do not matter)."""
    z = np.zeros(frames)
    return EffectorTrack(
        site=body,
        target_name="t",
        task="reach",
        solver="dls",
        joints=("a",),
        q=z[:, None],
        target=np.zeros((frames, 3)),
        target_quat=None,
        achieved=np.zeros((frames, 3)),
        position_error=z,
        on_target=np.ones(frames, dtype=bool),
        reachable=np.ones(frames, dtype=bool),
        status=("converged",) * frames,
        kind="body",
    )


def test_bvh_units_are_m_or_cm(showcase):
    """Another unit is refused naming the valid ones."""
    traj = load_trajectory(showcase)
    with pytest.raises(TrajectoryFileError, match="units 'mm' unknown; units: m, cm"):
        bvh_text(traj, load_model(traj.model_file), "mm")


def test_keyframes_load_into_the_model(showcase, tmp_path):
    """The exported <key> elements, added to the model through MjSpec, compile and hold
    each frame's qpos and time; resetting to a key puts the palm where the frame had it."""
    xml = tmp_path / "keys.xml"
    assert main(["export-keyframes", str(showcase), "--out", str(xml), "--every", "7"]) == 0
    traj = load_trajectory(showcase)
    keys = ET.parse(xml).getroot().find("keyframe").findall("key")
    assert [k.get("name") for k in keys[:2]] == ["showcase_000", "showcase_007"]
    assert len(keys) == len(range(0, 180, 7))
    spec = mujoco.MjSpec.from_file(traj.model_file)
    for k in keys:
        spec.add_key(
            name=k.get("name"),
            time=float(k.get("time")),
            qpos=[float(v) for v in k.get("qpos").split()],
        )
    model = spec.compile()
    data = mujoco.MjData(model)
    for frame in range(0, traj.n_frames, 7):
        kid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, f"showcase_{frame:03d}")
        np.testing.assert_array_equal(model.key_qpos[kid], traj.qpos[frame])
        assert model.key_time[kid] == traj.time[frame]
        mujoco.mj_resetDataKeyframe(model, data, kid)
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(
            data.site("right_palm_site").xpos, traj.effectors[0].achieved[frame], atol=1e-12
        )


def test_keyframes_are_well_formed_xml_whatever_the_names(showcase, tmp_path):
    """A scene name or model path holding ``--`` (valid in scene names), ``&`` or ``<``
    still gives a document a strict XML parser reads, with the names intact."""
    import dataclasses
    import xml.parsers.expat

    traj = dataclasses.replace(
        load_trajectory(showcase), scene="a--b&<c>-", model_file="/x--y/m.xml"
    )
    text = keyframes_xml(traj, every=60)
    parser = xml.parsers.expat.ParserCreate()
    comments: list[str] = []
    parser.CommentHandler = comments.append
    parser.Parse(text, True)  # raises on anything not well-formed
    assert "a- -b&<c>-" in comments[0] and "/x- -y/m.xml" in comments[0]
    names = [k.get("name") for k in ET.fromstring(text).iter("key")]
    assert names == ["a--b&<c>-_000", "a--b&<c>-_060", "a--b&<c>-_120"]


def test_keyframes_every_must_be_positive(showcase):
    """`every` below 1 is refused in one line."""
    with pytest.raises(TrajectoryFileError, match="every: expected an integer >= 1, got 0"):
        keyframes_xml(load_trajectory(showcase), every=0)


def test_export_commands_bad_input(showcase, tmp_path, capsys):
    """A folder as --out, an unknown unit, a missing trajectory: exit 2, one line."""
    assert main(["export-bvh", str(showcase), "--out", str(tmp_path)]) == 2
    assert "it is a folder" in capsys.readouterr().err
    assert main(["export-bvh", str(showcase), "--out", "x.bvh", "--units", "mm"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "invalid choice: 'mm'" in err
    assert main(["export-keyframes", str(tmp_path / "no.npz"), "--out", str(tmp_path / "k")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err
