"""The motion kinds by the name a scene file gives in ``motion.kind``: the one list a
new kind is added to."""

from __future__ import annotations

from humanoid_ik.motion.base import Motion
from humanoid_ik.motion.curves import Circle, FigureEight, Lissajous
from humanoid_ik.motion.paths import OutAndBack, Points, RandomWalk, Waypoints

__all__ = ["MOTIONS"]

MOTIONS: dict[str, type[Motion]] = {
    cls.kind: cls
    for cls in (Points, Circle, FigureEight, Lissajous, Waypoints, RandomWalk, OutAndBack)
}
"""Motion classes by ``kind``, in the order ``humanoid-ik scenes`` lists them."""
