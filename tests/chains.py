"""Inline MJCF chains for the tests (built with ``Chain.from_xml_string``), and the
fixture arms of ``tests/models/``."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from humanoid_ik import Chain, Target
from humanoid_ik.core.rotations import mat_to_quat

MODELS = Path(__file__).resolve().parent / "models"
"""Fixture arms unlike the humanoid's (see ``tests/models/README.md``)."""

# The worksheet's limb: a 3-hinge shoulder at p1 = origin (Y, Z, X: the YZX Euler order of
# the polar method), d12 = (3, 0, 0), an elbow about z, d23 = (2, 0, 0). No joint limits.
WORKSHEET_XML = """
<mujoco model="worksheet">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper">
      <joint name="sh_y" type="hinge" axis="0 1 0"/>
      <joint name="sh_z" type="hinge" axis="0 0 1"/>
      <joint name="sh_x" type="hinge" axis="1 0 0"/>
      <geom type="capsule" fromto="0 0 0 3 0 0" size="0.1"/>
      <body name="lower" pos="3 0 0">
        <joint name="elbow_z" type="hinge" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 2 0 0" size="0.1"/>
        <site name="p3" pos="2 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# The lecture notes' CCD example: two hinges about z, d12 = (2, 0, 0), d23 = (1, 0, 0).
CCD_XML = """
<mujoco model="ccd">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link1">
      <joint name="j1" type="hinge" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 2 0 0" size="0.05"/>
      <body name="link2" pos="2 0 0">
        <joint name="j2" type="hinge" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 1 0 0" size="0.05"/>
        <site name="p3" pos="1 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# A second arm nobody wrote for the humanoid: other lengths (0.42 / 0.33 / 0.05), other
# axis directions (tilted, negative), a body frame rotated away from the world, a
# free-floating base, and a slide joint off the arm's path.
SMALL_ARM_XML = """
<mujoco model="small_arm">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="cart" pos="0 2 0">
      <joint name="rail" type="slide" axis="1 0 0" range="-1 1"/>
      <geom type="box" size="0.1 0.1 0.1"/>
    </body>
    <body name="base" pos="0.1 -0.2 0.8" euler="0.3 -0.2 0.5">
      <freejoint name="float"/>
      <geom type="box" size="0.1 0.1 0.05"/>
      <body name="arm" pos="0 0 0.1">
        <joint name="a_yaw" axis="0 0 -1" range="-2.5 2.5"/>
        <joint name="a_pitch" axis="0 1 0" range="-1.8 1.8"/>
        <joint name="a_roll" axis="0.6 0 0.8" range="-2.0 2.0"/>
        <geom type="capsule" fromto="0 0 0 0.42 0 0" size="0.03"/>
        <body name="fore" pos="0.42 0 0">
          <joint name="a_elbow" axis="0 0 1" range="-2.4 0.1"/>
          <geom type="capsule" fromto="0 0 0 0.33 0 0" size="0.025"/>
          <body name="tool" pos="0.33 0 0">
            <joint name="a_w1" axis="1 0 0" range="-2.0 2.0"/>
            <joint name="a_w2" axis="0 -1 0" range="-1.2 1.2"/>
            <joint name="a_w3" axis="0 0 1" range="-1.0 1.0"/>
            <geom type="box" pos="0.03 0 0" size="0.03 0.02 0.01"/>
            <site name="tip" pos="0.05 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


# The humanoid report's arm (the third seed): an upper arm and a forearm in the xy plane,
# both hinges about z, lengths L1 = 0.32 and L2 = 0.27, limited as an elbow bends.

PLANAR_ARM_XML = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 0 1" RANGE/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03"/>
        <site name="tip" pos="0.25 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
"""A planar arm of two hinges, site ``tip``; its elbow's range attributes are ``RANGE``
(the shoulder has none: continuous)."""


REPORT_XML = """
<mujoco model="report_arm">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="upper_arm_link" pos="0.1 0.2 1.3">
      <joint name="shoulder_joint" axis="0 0 1" range="-3.1 3.1"/>
      <geom type="capsule" fromto="0 0 0 0.32 0 0" size="0.03"/>
      <body name="forearm_link" pos="0.32 0 0">
        <joint name="elbow_joint" axis="0 0 1" range="-3.0 3.0"/>
        <geom type="capsule" fromto="0 0 0 0.27 0 0" size="0.025"/>
        <site name="hand_site" pos="0.27 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

FIXTURES = {
    "planar_arm": ("hand_site", ["shoulder_joint", "elbow_joint", "wrist_joint"]),
    "two_hinge_arm": (
        "hand_site",
        ["shoulder_pitch_joint", "shoulder_roll_joint", "elbow_joint", "wrist_joint"],
    ),
    "three_hinge_arm": (
        "hand_site",
        [
            "shoulder_yaw_joint",
            "shoulder_pitch_joint",
            "shoulder_roll_joint",
            "elbow_joint",
            "wrist_joint",
        ],
    ),
}
"""Fixture name -> (site, joints): shoulder, elbow, and a wrist that rides along."""


def model(xml: str) -> mujoco.MjModel:
    """Compile an inline MJCF string."""
    return mujoco.MjModel.from_xml_string(xml)


def chain(xml: str, site: str | None = None, joints: Sequence[str] | None = None) -> Chain:
    """A chain on an inline MJCF string (:meth:`Chain.from_xml_string`)."""
    return Chain.from_xml_string(xml, site, joints)


def fixture(name: str, riding: bool = True) -> Chain:
    """The chain of fixture arm ``name`` (with its wrist, or without: then the wrist is
    a joint off the chain, held at home)."""
    site, joints = FIXTURES[name]
    return Chain(MODELS / f"{name}.xml", site, joints if riding else joints[:-1])


def fk_poses(chain: Chain, n: int, seed: int) -> list[Target]:
    """``n`` reachable pose targets: the FK of seeded random in-range joint vectors
    (:meth:`Chain.random_q`); the chain's joints are left at the last of them."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        p, R = chain.fk(chain.random_q(rng))
        out.append(Target(p, mat_to_quat(R)))
    return out
