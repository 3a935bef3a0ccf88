"""A URDF of a chain, for IK libraries that read URDF (TRAC-IK, IKPy).

The URDF describes the chain's hinges as MuJoCo places them, with every other joint of
the model held at its value in the chain's scratch data (a floating base, a torso hinge
and the other arm become fixed parts of the tree):

- the root link ``base`` is the world frame, so a target in the world is a target in
  the URDF's base frame;
- one link per hinge, ``<joint>_link``, whose frame at zero joint values sits at the
  hinge's anchor with the world's orientation; its joint (the MuJoCo joint's name) turns
  about the hinge's world axis at zero joint values, so no joint origin carries a
  rotation and the positions are copied exactly;
- a fixed joint ``<effector>_fixed`` to the link named as the end effector (site or
  body), at its pose at zero joint values (the one ``rpy`` of the file);
- ``revolute`` with the MuJoCo range for a limited hinge, ``continuous`` otherwise.

Numbers are written with Python's shortest round-trip repr, so the URDF's forward
kinematics equals MuJoCo's to rounding (``tests/test_urdf_export.py`` checks 1e-9 m
and rad through an independent reader and through TRAC-IK's own FK). Links carry no
inertia or geometry: the file is for kinematics only.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.outputs.atomic import write_text

__all__ = ["BASE_LINK", "chain_urdf", "joint_link", "matrix_rpy", "write_urdf"]

BASE_LINK = "base"
"""The URDF's root link: the world frame."""


def joint_link(joint: str) -> str:
    """The name of the link a chain joint moves."""
    return f"{joint}_link"


def _num(x: float) -> str:
    return repr(float(x)) if x != 0.0 else "0"


def _vec(v: NDArray[np.float64]) -> str:
    return " ".join(_num(x) for x in v)


def _rpy_matrix(r: float, p: float, y: float) -> NDArray[np.float64]:
    """``Rz(y) Ry(p) Rx(r)``, the rotation of URDF's ``rpy``."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_rpy(R: NDArray[np.float64]) -> tuple[float, float, float]:
    """URDF ``rpy`` (roll, pitch, yaw) [rad] of a rotation matrix ``(3, 3)``, with
    ``R = Rz(yaw) Ry(pitch) Rx(roll)``. At and near pitch = +-pi/2 (gimbal lock) both
    the general formula and the yaw = 0 one are tried and the one that rebuilds ``R``
    more closely is kept."""
    R = np.asarray(R, dtype=np.float64).reshape(3, 3)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    general = (math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0]))
    locked = (math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0)
    return min((general, locked), key=lambda rpy: float(np.abs(_rpy_matrix(*rpy) - R).max()))


def chain_urdf(chain: Chain, name: str | None = None) -> str:
    """The URDF document of ``chain`` (see the module docstring).

    The joints outside the chain keep their values in ``chain.data``; the chain's
    scratch data is not changed (the zero-joint pose is computed on a copy).

    Args:
        chain: the chain.
        name: the robot's name (default: the end effector's name).
    """
    m = chain.model
    d = mujoco.MjData(m)
    d.qpos[:] = chain.data.qpos
    d.mocap_pos[:] = chain.data.mocap_pos
    d.mocap_quat[:] = chain.data.mocap_quat
    d.qpos[chain.qpos_adr] = 0.0
    mujoco.mj_kinematics(m, d)
    anchors = d.xanchor[chain.joint_ids]
    axes = d.xaxis[chain.joint_ids]
    if chain.ee_kind == "site":
        tip_pos, tip_mat = d.site_xpos[chain.ee_id], d.site_xmat[chain.ee_id]
    else:
        tip_pos, tip_mat = d.xpos[chain.ee_id], d.xmat[chain.ee_id]

    robot = ET.Element("robot", name=name or chain.ee_name)
    ET.SubElement(robot, "link", name=BASE_LINK)
    parent, origin = BASE_LINK, np.zeros(3)
    for i, joint in enumerate(chain.joint_names):
        child = joint_link(joint)
        ET.SubElement(robot, "link", name=child)
        limited = bool(np.isfinite(chain.lower[i]) and np.isfinite(chain.upper[i]))
        el = ET.SubElement(robot, "joint", name=joint, type="revolute" if limited else "continuous")
        ET.SubElement(el, "parent", link=parent)
        ET.SubElement(el, "child", link=child)
        ET.SubElement(el, "origin", xyz=_vec(anchors[i] - origin), rpy="0 0 0")
        ET.SubElement(el, "axis", xyz=_vec(axes[i] / np.linalg.norm(axes[i])))
        if limited:
            ET.SubElement(
                el,
                "limit",
                lower=_num(chain.lower[i]),
                upper=_num(chain.upper[i]),
                effort="1",
                velocity="1",
            )
        parent, origin = child, anchors[i]
    ET.SubElement(robot, "link", name=chain.ee_name)
    el = ET.SubElement(robot, "joint", name=f"{chain.ee_name}_fixed", type="fixed")
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=chain.ee_name)
    rpy = matrix_rpy(tip_mat.reshape(3, 3))
    ET.SubElement(el, "origin", xyz=_vec(tip_pos - origin), rpy=_vec(np.array(rpy)))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def write_urdf(chain: Chain, path: str | os.PathLike[str], name: str | None = None) -> Path:
    """Write :func:`chain_urdf` to ``path`` atomically; returns the path."""
    return write_text(path, chain_urdf(chain, name))
