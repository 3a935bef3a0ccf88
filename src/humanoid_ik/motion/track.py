"""A named target: a motion and, for a pose target, an orientation."""

from __future__ import annotations

from dataclasses import dataclass

from humanoid_ik.core.types import Target
from humanoid_ik.motion.base import Motion
from humanoid_ik.motion.orientation import Orientation

__all__ = ["TargetTrack"]


@dataclass(frozen=True)
class TargetTrack:
    """A named target: a motion and, for pose targets, an orientation.

    Args:
        name: the target's name (effectors refer to it).
        motion: where it is over time.
        orientation: its orientation over time, or ``None`` for a position target.
    """

    name: str
    motion: Motion
    orientation: Orientation | None = None

    @property
    def is_pose(self) -> bool:
        """True when the target has an orientation."""
        return self.orientation is not None

    def at(self, t: float) -> Target:
        """The :class:`~humanoid_ik.core.types.Target` at time ``t`` [s] (built from the
        motion's checked output: :meth:`Target.from_motion
        <humanoid_ik.core.types.Target.from_motion>`)."""
        quat = None if self.orientation is None else self.orientation.quat_at(t)
        return Target.from_motion(self.motion.position(t), quat)
