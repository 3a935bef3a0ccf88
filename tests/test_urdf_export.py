"""The URDF exporter (``outputs/urdf.py``): the forward kinematics of the exported URDF
equals MuJoCo's to 1e-9, read by an independent URDF reader written here and by
TRAC-IK's own FK (``pytracik``, the ``bench-peers`` extra); ranges, continuous joints,
joints held outside the chain, a body end effector, gimbal-locked tip frames."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain
from humanoid_ik.core.models import bundled_dir
from humanoid_ik.outputs.urdf import BASE_LINK, chain_urdf, joint_link, matrix_rpy, write_urdf

from .chains import SMALL_ARM_XML, fixture

# Rotated body frames, an unlimited hinge, an oblique axis, a joint off the chain between
# two chain joints, and a tip site turned by pi/2 about y (URDF rpy at gimbal lock).
TWISTED_XML = """
<mujoco model="twisted">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="0.1 -0.2 0.9" quat="0.9 0.1 -0.3 0.2">
      <joint name="j1" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.05"/>
      <body name="b2" pos="0 0.05 0.3" quat="0 0 -0.7071068 0.7071068">
        <joint name="j2" type="hinge" axis="1 1 0" range="-2 1.5"/>
        <geom type="sphere" size="0.05"/>
        <body name="b3" pos="0.25 0 0.02" euler="0.3 -0.2 1.1">
          <joint name="held" type="hinge" axis="0 1 0" range="-1 1"/>
          <geom type="sphere" size="0.05"/>
          <body name="b4" pos="0 0 0.2">
            <joint name="j3" type="hinge" pos="0 0 0.03" axis="0 1 0" range="-2.5 0.4"/>
            <joint name="j4" type="hinge" axis="0.2 0 1"/>
            <geom type="sphere" size="0.05"/>
            <site name="tip" pos="0.04 0.01 0.15" euler="0 1.5707963267948966 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _twisted() -> Chain:
    c = Chain.from_xml_string(TWISTED_XML, "tip", ["j1", "j2", "j3", "j4"])
    c.data.qpos[c.model.joint("held").qposadr[0]] = 0.7  # held there, off the chain
    mujoco.mj_kinematics(c.model, c.data)
    return c


CHAINS = {
    "humanoid": lambda: Chain(),
    "robot_with_waist": lambda: Chain(
        bundled_dir("models") / "robot" / "robot.xml", "right_hand_site"
    ),
    "small_arm": lambda: Chain.from_xml_string(SMALL_ARM_XML, "tip"),
    "three_hinge_arm": lambda: fixture("three_hinge_arm"),
    "body_effector": lambda: Chain(body="right_hand_link"),
    "twisted": _twisted,
}


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    return (
        _rot(np.array([0, 0, 1.0]), y)
        @ _rot(np.array([0, 1.0, 0]), p)
        @ _rot(np.array([1.0, 0, 0]), r)
    )


def _urdf_fk(text: str, tip: str, q: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of a serial URDF from its root to link ``tip``: an independent
    reader (origins as ``xyz`` + ``rpy``, revolute/continuous about ``axis``)."""
    root = ET.fromstring(text)
    by_child = {j.find("child").get("link"): j for j in root.iter("joint")}
    path = []
    link = tip
    while link in by_child:
        path.append(by_child[link])
        link = by_child[link].find("parent").get("link")
    p, R = np.zeros(3), np.eye(3)
    for j in reversed(path):
        o = j.find("origin")
        xyz = np.array([float(v) for v in o.get("xyz").split()])
        rpy = [float(v) for v in o.get("rpy").split()]
        p, R = p + R @ xyz, R @ _rpy(*rpy)
        if j.get("type") != "fixed":
            axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
            R = R @ _rot(axis, q[j.get("name")])
    return p, R


@pytest.mark.parametrize("name", list(CHAINS))
def test_urdf_fk_matches_mujoco(name):
    """At 30 random in-range joint vectors (unlimited hinges in [-pi, pi]), the URDF's
    tip pose from the reader above and from TRAC-IK's FK equals MuJoCo's to 1e-9."""
    pytracik = pytest.importorskip("pytracik")
    chain = CHAINS[name]()
    text = chain_urdf(chain)
    solver = pytracik.TRAC_IK(BASE_LINK, chain.ee_name, text, 0.005, 1e-5, pytracik.SolveType.Speed)
    assert pytracik.get_num_joints(solver) == chain.n
    rng = np.random.default_rng(7)
    held = chain.data.qpos.copy()
    for _ in range(30):
        q = chain.random_q(rng)
        p, R = chain.fk(q)
        p_own, R_own = _urdf_fk(text, chain.ee_name, dict(zip(chain.joint_names, q, strict=True)))
        T = pytracik.fk(solver, q)
        for pp, RR in ((p_own, R_own), (T[:3, 3], T[:3, :3])):
            assert np.abs(pp - p).max() < 1e-9
            assert np.abs(RR - R).max() < 1e-9
        held[chain.qpos_adr] = q
        assert np.array_equal(chain.data.qpos, held)  # only the chain's joints moved


def test_ranges_names_and_continuous_joints():
    """Limited hinges are revolute with MuJoCo's range, unlimited ones continuous; links
    are named after their joints; the tip link after the effector; TRAC-IK reads the
    same bounds."""
    pytracik = pytest.importorskip("pytracik")
    chain = _twisted()
    text = chain_urdf(chain)
    root = ET.fromstring(text)
    joints = {j.get("name"): j for j in root.iter("joint")}
    assert list(joints) == ["j1", "j2", "j3", "j4", "tip_fixed"]
    assert [joints[n].get("type") for n in joints] == [
        "continuous",
        "revolute",
        "revolute",
        "continuous",
        "fixed",
    ]
    assert joints["j2"].find("limit").get("lower") == "-2.0"
    assert joints["j3"].find("limit").get("upper") == "0.4"
    assert joints["j3"].find("child").get("link") == joint_link("j3")
    assert joints["tip_fixed"].find("child").get("link") == "tip"
    solver = pytracik.TRAC_IK(BASE_LINK, "tip", text, 0.005, 1e-5, pytracik.SolveType.Speed)
    lower = np.array(pytracik.get_joint_lower_bounds(solver))
    upper = np.array(pytracik.get_joint_upper_bounds(solver))
    np.testing.assert_allclose(lower[[1, 2]], [-2.0, -2.5], rtol=0, atol=1e-7)  # float32 inside
    np.testing.assert_allclose(upper[[1, 2]], [1.5, 0.4], rtol=0, atol=1e-7)


def test_export_leaves_the_chain_alone_and_writes_atomically(tmp_path):
    """The chain's scratch data is bit for bit the same after an export; the file holds
    the same document."""
    chain = _twisted()
    chain.set_q([0.3, -0.4, 0.1, 1.2])
    before = (chain.data.qpos.copy(), chain.data.site_xpos.copy())
    text = chain_urdf(chain)
    assert np.array_equal(chain.data.qpos, before[0])
    assert np.array_equal(chain.data.site_xpos, before[1])
    path = write_urdf(chain, tmp_path / "arm.urdf")
    assert path.read_text() == text
    assert [p.name for p in tmp_path.iterdir()] == ["arm.urdf"]


@pytest.mark.parametrize(
    "rpy",
    [
        (0.3, math.pi / 2, -1.1),
        (0.3, -math.pi / 2, 0.4),
        (1.0, math.pi / 2 - 1e-7, 2.0),
        (-2.0, 0.4, 3.0),
    ],
)
def test_matrix_rpy_rebuilds_the_rotation(rpy):
    """``matrix_rpy`` returns angles that rebuild the matrix to 1e-12, also at and near
    gimbal lock, where roll and yaw are not unique."""
    R = _rpy(*rpy)
    np.testing.assert_allclose(_rpy(*matrix_rpy(R)), R, rtol=0, atol=1e-12)
