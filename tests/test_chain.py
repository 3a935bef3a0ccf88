"""Chains on the humanoid and on models nobody here wrote: paths, limits, FK, Jacobians."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik import (
    Chain,
    ChainError,
    ModelError,
    NameNotFoundError,
    TargetError,
    UnsupportedJointError,
    bundled_model_path,
)

from .chains import SMALL_ARM_XML, model

RIGHT = [
    "right_shoulder_flexion_joint",
    "right_shoulder_abduction_joint",
    "right_shoulder_rotation_joint",
    "right_elbow_joint",
    "right_wrist_pronation_joint",
    "right_wrist_flexion_joint",
    "right_wrist_deviation_joint",
]

BALL_XML = """
<mujoco><worldbody><body>
  <joint name="sh" type="ball"/><geom size="0.1"/>
  <body pos="1 0 0"><joint name="el" axis="0 0 1"/><geom size="0.1"/><site name="tip"/></body>
</body></worldbody></mujoco>
"""

OUTSIDE_XML = """
<mujoco><compiler angle="radian"/><worldbody><body>
  <joint name="a" axis="0 0 1" range="0.5 1.0"/><geom size="0.1"/>
  <body pos="1 0 0"><joint name="b" axis="0 0 1" range="-1.0 -0.2"/><geom size="0.1"/>
  <site name="tip" pos="1 0 0"/></body>
</body></worldbody></mujoco>
"""


def test_default_path_on_humanoid(right_arm):
    """The right palm chain is the seven right-arm hinges, root to tip."""
    assert right_arm.joint_names == RIGHT
    assert right_arm.n == 7
    np.testing.assert_allclose(right_arm.q_home, [0.2, 0.12, 0.1, 0.45, 0.1, 0.05, 0.0])


def test_gaze_chain_is_the_neck():
    """The gaze site's path holds the neck yaw and pitch hinges."""
    chain = Chain(None, "gaze_site")
    assert chain.joint_names == ["neck_yaw_joint", "neck_pitch_joint"]


def test_fk_matches_mujoco_forward(right_arm, rng):
    """Chain FK equals site_xpos/site_xmat of an independent MjData after mj_forward."""
    m = right_arm.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    for _ in range(20):
        q = right_arm.random_q(rng)
        d.qpos[right_arm.qpos_adr] = q
        mujoco.mj_forward(m, d)
        p, R = right_arm.fk(q)
        np.testing.assert_allclose(p, d.site("right_palm_site").xpos, atol=1e-14)
        np.testing.assert_allclose(R.reshape(9), d.site("right_palm_site").xmat, atol=1e-14)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Chain(),
        lambda: Chain(None, "left_palm_site"),
        lambda: Chain(model(SMALL_ARM_XML), "tip"),
        lambda: Chain(model(SMALL_ARM_XML), body="tool"),
    ],
    ids=["right_palm", "left_palm", "small_arm_site", "small_arm_body"],
)
def test_jacobian_matches_finite_differences(make, rng):
    """mj_jacSite / mj_jacBody columns equal central finite differences of MuJoCo FK."""
    chain = make()
    for _ in range(5):
        q = chain.random_q(rng)
        J = chain.jacobian(q)
        h = 1e-6
        for i in range(chain.n):
            qp, qm = q.copy(), q.copy()
            qp[i] += h
            qm[i] -= h
            pp, Rp = chain.fk(qp)
            pm, Rm = chain.fk(qm)
            np.testing.assert_allclose(J[:3, i], (pp - pm) / (2 * h), atol=1e-7)
            W = (Rp @ Rm.T - Rm @ Rp.T) / (4 * h)  # skew part of the rotation difference
            np.testing.assert_allclose(J[3:, i], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-7)


def test_free_root_stops_the_path():
    """A floating base ends the default path: the small arm has its seven hinges only."""
    chain = Chain(model(SMALL_ARM_XML), "tip")
    assert chain.joint_names == ["a_yaw", "a_pitch", "a_roll", "a_elbow", "a_w1", "a_w2", "a_w3"]


def test_other_joints_keep_their_values(rng):
    """Writing the arm's qpos leaves the free base and the slide joint as they were."""
    chain = Chain(model(SMALL_ARM_XML), "tip")
    other = np.setdiff1d(np.arange(chain.model.nq), chain.qpos_adr)
    before = chain.data.qpos[other].copy()
    chain.fk(chain.random_q(rng))
    np.testing.assert_array_equal(chain.data.qpos[other], before)


def test_home_moves_qpos0_inside_ranges():
    """Without a home key, qpos0 = 0 outside the ranges is moved to the nearest range end."""
    chain = Chain(model(OUTSIDE_XML), "tip")
    np.testing.assert_allclose(chain.q_home, [0.5, -0.2])
    np.testing.assert_allclose(chain.q, [0.5, -0.2])
    assert chain.within_limits(chain.q)


def test_ball_joint_on_path_is_named():
    """A ball joint on the path raises an error naming it."""
    with pytest.raises(UnsupportedJointError, match="'sh' \\(ball\\)"):
        Chain(model(BALL_XML), "tip")


def test_ball_joint_can_be_left_out():
    """Choosing the hinges explicitly skips the ball joint."""
    chain = Chain(model(BALL_XML), "tip", ["el"])
    assert chain.joint_names == ["el"]


def test_slide_joint_named_explicitly_is_refused():
    """A slide joint passed by name is refused with its type."""
    with pytest.raises(UnsupportedJointError, match="'rail' \\(slide\\)"):
        Chain(model(SMALL_ARM_XML), "tip", ["rail"])


def test_unknown_names_list_the_valid_ones():
    """Unknown site, body and joint names raise errors listing what exists."""
    with pytest.raises(
        NameNotFoundError, match="site 'hand' not in model; sites: .*right_palm_site"
    ):
        Chain(None, "hand")
    with pytest.raises(NameNotFoundError, match="body 'hand' not in model; bodies: .*"):
        Chain(None, body="hand")
    with pytest.raises(NameNotFoundError, match="joint 'knee' not in model; joints: .*elbow"):
        Chain(None, "right_palm_site", ["knee"])


def test_joint_off_the_path_is_refused():
    """A joint that does not move the end effector is refused, listing the path's joints."""
    with pytest.raises(ChainError, match="does not move site 'right_palm_site'.*right_elbow"):
        Chain(None, "right_palm_site", ["left_elbow_joint"])
    with pytest.raises(ChainError, match="listed twice"):
        Chain(None, "right_palm_site", ["right_elbow_joint", "right_elbow_joint"])
    with pytest.raises(ChainError, match="site or a body"):
        Chain(None, "right_palm_site", body="right_hand_link")
    with pytest.raises(ChainError, match="no hinge joint moves site 'torso_site'"):
        Chain(None, "torso_site")


def test_model_errors(tmp_path):
    """A missing file and XML that does not compile raise ModelError (MuJoCo's message kept)."""
    with pytest.raises(ModelError, match="does not exist"):
        Chain(tmp_path / "nope.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body><joint type='hinge'/></body></mujoco>")
    with pytest.raises(ModelError, match="does not compile: .*"):
        Chain(bad)


def test_joint_vector_checks(right_arm):
    """Wrong shapes and NaN joint vectors are refused."""
    with pytest.raises(TargetError, match="shape \\(7,\\)"):
        right_arm.fk([0.0, 1.0])
    with pytest.raises(TargetError, match="not finite"):
        right_arm.fk([np.nan] * 7)


def test_load_and_apply_on_caller_data(right_arm):
    """load() only reads the caller's data; apply() writes the chain joints and runs forward."""
    m = right_arm.model
    d = mujoco.MjData(m)
    d.qpos[:] = 0.1
    snapshot = d.qpos.copy()
    right_arm.load(d)
    np.testing.assert_array_equal(d.qpos, snapshot)
    np.testing.assert_allclose(right_arm.q, np.full(7, 0.1))
    q = np.array([0.3, 0.2, 0.1, 1.0, 0.0, 0.0, 0.0])
    right_arm.apply(q, d)
    np.testing.assert_allclose(d.qpos[right_arm.qpos_adr], q)
    np.testing.assert_allclose(d.qpos[:2], [0.1, 0.1])
    p, _ = right_arm.fk(q)
    np.testing.assert_allclose(d.site("right_palm_site").xpos, p, atol=1e-14)
    other = mujoco.MjData(mujoco.MjModel.from_xml_string("<mujoco/>"))
    with pytest.raises(ChainError, match="nq=0"):
        right_arm.load(other)


def test_limit_helpers(right_arm):
    """clip, within_limits and limit_margin agree with the model's ranges."""
    q = right_arm.q_home.copy()
    assert right_arm.limit_margin(q) == pytest.approx(0.35)  # deviation 0 vs radial 0.35
    q[3] = -0.5
    assert not right_arm.within_limits(q)
    assert right_arm.limit_margin(q) == pytest.approx(-0.5)
    clipped = right_arm.clip(q)
    assert clipped[3] == 0.0 and q[3] == -0.5  # a new array
    out = right_arm.clip(q, out=q)  # or the one given, overwritten
    assert out is q and q[3] == 0.0
    np.testing.assert_array_equal(q, clipped)


def test_bundled_model_path_points_at_scene():
    """The bundled model is models/humanoid/scene.xml."""
    p = bundled_model_path()
    assert p.parts[-3:] == ("models", "humanoid", "scene.xml")
    assert p.is_file()


def test_robot_path_includes_the_waist():
    """On the robot humanoid the default right-hand chain is the waist and the 7 arm
    hinges: the floating base ends the path."""
    robot = Path(__file__).resolve().parents[1] / "models" / "robot" / "robot.xml"
    chain = Chain(robot, "right_hand_site")
    assert chain.joint_names[0] == "waist_yaw" and chain.n == 8
    assert chain.joint_names[-1] == "r_wr_yaw"


def test_path_joint_ids_reach_the_world():
    """``path_joint_ids`` lists every joint from the hand's body to the world, tip first:
    the chain's hinges and, past them, the floating base the path rule stops at."""
    robot = Path(__file__).resolve().parents[1] / "models" / "robot" / "robot.xml"
    chain = Chain(robot, "right_hand_site")
    m = chain.model
    names = [m.joint(int(j)).name for j in chain.path_joint_ids]
    assert names[: chain.n] == chain.joint_names[::-1]
    assert len(names) == chain.n + 1
    assert m.jnt_type[chain.path_joint_ids[-1]] == mujoco.mjtJoint.mjJNT_FREE


def test_base_state_follows_the_joints_off_the_chain():
    """``base_state`` reads the path's joints outside the chain (the robot's floating
    base: 7 numbers) and is ``None`` when nothing moves the chain's base."""
    robot = Path(__file__).resolve().parents[1] / "models" / "robot" / "robot.xml"
    chain = Chain(robot, "right_hand_site")
    before = chain.base_state()
    assert before is not None and len(before) == 7
    chain.data.qpos[0] += 0.25  # the free joint's x
    assert chain.base_state() == [before[0] + 0.25, *before[1:]]
    assert Chain().base_state() is None


@pytest.mark.parametrize("dtype", [complex, bool, str])
def test_a_joint_vector_of_complex_bool_or_text_values_is_refused(dtype):
    """numpy would drop an imaginary part or read True as 1.0; every entry point that
    takes a joint vector (FK, the Jacobian) refuses such an array in one line."""
    chain = Chain()
    q = np.zeros(chain.n, dtype=dtype)
    for call in (chain.fk, chain.jacobian):
        with pytest.raises(TargetError, match="joint vector must be real numbers, got an array of"):
            call(q)
