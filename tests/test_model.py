"""The bundled humanoid: loads cleanly, human proportions, ranges, sites, home, simulation."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from humanoid_ik import bundled_model_path

ARM_JOINTS = [
    "shoulder_flexion",
    "shoulder_abduction",
    "shoulder_rotation",
    "elbow",
    "wrist_pronation",
    "wrist_flexion",
    "wrist_deviation",
]


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(bundled_model_path()))


def _site(model, data, name):
    return data.site(name).xpos.copy()


def test_every_hinge_has_a_range_and_home_is_inside(model):
    """Every joint is a limited hinge and the home keyframe lies strictly inside each range."""
    key = model.key("home")
    for j in range(model.njnt):
        assert model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
        assert model.jnt_limited[j]
        lo, hi = model.jnt_range[j]
        q = key.qpos[model.jnt_qposadr[j]]
        assert lo < q < hi, model.joint(j).name
    names = {model.joint(j).name for j in range(model.njnt)}
    for side in ("right", "left"):
        assert {f"{side}_{j}_joint" for j in ARM_JOINTS} <= names
    assert {"neck_yaw_joint", "neck_pitch_joint"} <= names


@pytest.mark.parametrize("side", ["right", "left"])
def test_arm_proportions(model, side):
    """Upper arm 0.30 m, forearm 0.25 m, palm centre 0.08 m past the wrist, at any pose."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.key("home").qpos
    mujoco.mj_kinematics(model, data)
    s, e, w, p = (
        _site(model, data, f"{side}_{n}_site") for n in ("shoulder", "elbow", "wrist", "palm")
    )
    assert np.linalg.norm(e - s) == pytest.approx(0.30, abs=1e-9)
    assert np.linalg.norm(w - e) == pytest.approx(0.25, abs=1e-9)
    assert np.linalg.norm(p - w) == pytest.approx(0.08, abs=1e-9)


@pytest.mark.parametrize("side", ["right", "left"])
def test_shoulder_and_wrist_axes_meet(model, side):
    """The three shoulder hinges meet at the shoulder point, the three wrist hinges at the wrist."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    data.qpos[:] = rng.uniform(model.jnt_range[:, 0], model.jnt_range[:, 1])
    mujoco.mj_kinematics(model, data)
    for group, site in (("shoulder", "shoulder"), ("wrist", "wrist")):
        point = data.site(f"{side}_{site}_site").xpos
        joints = [j for j in ARM_JOINTS if j.startswith(group)]
        for j in joints:
            jid = model.joint(f"{side}_{j}_joint").id
            anchor, axis = data.xanchor[jid], data.xaxis[jid]
            assert np.linalg.norm(np.cross(point - anchor, axis)) < 1e-12


def test_right_arm_flexion_moves_hand_forward(model):
    """Positive shoulder flexion swings the right hand forward (+x) and up."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    p0 = _site(model, data, "right_palm_site")
    data.joint("right_shoulder_flexion_joint").qpos = math.pi / 2
    mujoco.mj_kinematics(model, data)
    p1 = _site(model, data, "right_palm_site")
    np.testing.assert_allclose(p0, [0.0, -0.19, 1.40 - 0.63], atol=1e-9)
    np.testing.assert_allclose(p1, [0.63, -0.19, 1.40], atol=1e-9)


def test_mirror_symmetry(model):
    """The left arm mirrors the right in the x-z plane for equal joint values."""
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    q = rng.uniform(-0.5, 0.5, 7)
    q[3] = 1.0
    data.qpos[2:9] = q
    data.qpos[9:16] = q
    mujoco.mj_kinematics(model, data)
    r = _site(model, data, "right_palm_site")
    l = _site(model, data, "left_palm_site")
    np.testing.assert_allclose(l, r * [1, -1, 1], atol=1e-12)


def test_simulates_one_second_without_warnings(model):
    """One second of simulation from home raises no MuJoCo warning and stays finite."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    steps = int(round(1.0 / model.opt.timestep))
    for _ in range(steps):
        mujoco.mj_step(model, data)
    assert data.time == pytest.approx(1.0)
    assert all(w.number == 0 for w in data.warning)
    assert np.all(np.isfinite(data.qpos))


def test_scene_has_named_cameras(model):
    """The scene frames the workspace with front, side and top cameras."""
    names = {model.camera(i).name for i in range(model.ncam)}
    assert {"front", "side", "top"} <= names


def test_the_loader_reads_mjcf_as_mujoco_does(model):
    """load_model and model_spec leave an MJCF as MuJoCo compiles it: the URDF rules
    (geom groups, fused roots, package search) apply to URDF and xacro files only."""
    from humanoid_ik.core.models import load_model, model_spec

    loaded = load_model(bundled_model_path())
    assert loaded.ngeom == model.ngeom and loaded.nbody == model.nbody
    np.testing.assert_array_equal(loaded.geom_group, model.geom_group)
    np.testing.assert_array_equal(loaded.geom_contype, model.geom_contype)
    spec = model_spec(bundled_model_path())
    assert (
        spec.compiler.fusestatic
        == mujoco.MjSpec.from_file(str(bundled_model_path())).compiler.fusestatic
    )
    np.testing.assert_array_equal(spec.compile().geom_group, model.geom_group)
