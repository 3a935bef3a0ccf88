"""BVH and keyframe export of real trajectories: the BVH of `showcase` parses with an
independent reader (bvhio) whose forward kinematics puts the hands and the head where
MuJoCo does in every frame, and the keyframes load into the model with the same qpos."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import bvhio
import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.models import load_model
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.outputs.bvh import bvh_text
from humanoid_ik.outputs.keyframes import keyframes_xml
from humanoid_ik.outputs.record import record_scene
from humanoid_ik.outputs.trajectory import load_trajectory

ENDS = ("right_palm_site", "left_palm_site", "gaze_site")
"""The hands and the head (the gaze point on the face) compared with MuJoCo."""


@pytest.fixture(scope="module")
def showcase(tmp_path_factory):
    """showcase run in full: 180 frames over 6 s (both hands and the head move)."""
    folder = tmp_path_factory.mktemp("showcase")
    out = record_scene(load_scene("showcase"), folder)
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


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("<body><joint name='b' type='ball'/><geom size='.1'/></body>", "joint 'b' is not a hinge"),
        ("<body><joint name='t' axis='1 1 0'/><geom size='.1'/></body>", "joint 't' has axis"),
        (
            "<body name='r' quat='0.7071068 0 0 0.7071068'><joint/><geom size='.1'/></body>",
            "body 'r' has quat",
        ),
        ("<body><geom size='.1'/></body>", "needs a model with hinge joints; it has none"),
    ],
)
def test_bvh_refuses_models_it_cannot_hold(showcase, body, message):
    """A ball joint, a hinge off the body axes, a body with a rest rotation, no joint at
    all: one line naming it."""
    model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{body}</worldbody></mujoco>")
    with pytest.raises(TrajectoryFileError, match=message) as err:
        bvh_text(load_trajectory(showcase), model)
    assert "\n" not in str(err.value)


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
