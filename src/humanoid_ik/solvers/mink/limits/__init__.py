"""Our mink limits, one per file as in mink: joint range and joint velocity on chosen
joints, and collision avoidance with a displacement bound.

Importing this package imports mink.
"""

from humanoid_ik.solvers.mink.limits.collision import CollisionLimit
from humanoid_ik.solvers.mink.limits.joint_range import JointRangeLimit
from humanoid_ik.solvers.mink.limits.joint_velocity import JointVelocityLimit

__all__ = ["CollisionLimit", "JointRangeLimit", "JointVelocityLimit"]
