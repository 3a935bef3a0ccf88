"""Real robots for the tests: the original files of the ``example-robot-data`` package
(PyPI, BSD-3; in the test extra), with their ``package://`` mesh paths."""

from __future__ import annotations

from importlib.metadata import distribution
from pathlib import Path

SHARE = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share")))
"""The install prefix's ``share`` folder (``share/example-robot-data`` is the package)."""
PACKAGE = SHARE / "example-robot-data"
"""The ROS package ``example-robot-data``: its ``package.xml`` and ``robots/``."""

ROBOTS = {
    "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "g1_hands": "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    "talos": "talos_data/robots/talos_full_v2.urdf",
    "romeo": "romeo_description/urdf/romeo.urdf",
    "icub": "icub_description/robots/icub.urdf",
    "baxter": "baxter_description/urdf/baxter.urdf",
    "pr2": "pr2_description/urdf/pr2.urdf",
    "tiago_dual": "tiago_description/robots/tiago_dual.urdf",
    "panda": "panda_description/urdf/panda.urdf",
    "ur5": "ur_description/urdf/ur5_robot.urdf",
    "kinova": "kinova_description/robots/kinova.urdf",
    "so100": "so_arm_description/urdf/so100.urdf",
    "so101": "so_arm_description/urdf/so101.urdf",
}
"""Short names of the robots the tests use, and their URDFs under ``robots/``."""


def robot_file(name: str) -> Path:
    """The original URDF of the robot ``name`` (a key of :data:`ROBOTS`)."""
    return PACKAGE / "robots" / ROBOTS[name]


def g1_arm(side: str) -> tuple[str, ...]:
    """The joints of G1's ``side`` (``left`` or ``right``) arm, shoulder to wrist."""
    return tuple(
        f"{side}_{j}_joint"
        for j in (
            "shoulder_pitch",
            "shoulder_roll",
            "shoulder_yaw",
            "elbow",
            "wrist_roll",
            "wrist_pitch",
            "wrist_yaw",
        )
    )
