"""Target motions: where a target is at time ``t`` [s].

Motions: :class:`Points` (fixed points with holds), :class:`Circle` (in any plane),
:class:`FigureEight`, :class:`Lissajous`, :class:`Waypoints` (linear or smooth),
:class:`RandomWalk` (seeded) and :class:`OutAndBack` (leaves the workspace and returns),
registered by kind in :data:`MOTIONS`. :class:`Orientation` gives a target orientation
over time (for pose targets) and :class:`TargetTrack` puts a motion and an orientation
together into a :class:`~humanoid_ik.core.types.Target` per instant.

Modules: ``base`` (the :class:`Motion` interface, easing and interpolation), ``curves``
(closed curves), ``paths`` (paths through points), ``registry`` (kinds by name),
``orientation`` and ``track``.
"""

from humanoid_ik.motion.base import Motion, hermite, plane_basis, smoothstep
from humanoid_ik.motion.curves import Circle, FigureEight, Lissajous
from humanoid_ik.motion.orientation import Orientation
from humanoid_ik.motion.paths import MAX_KNOTS, OutAndBack, Points, RandomWalk, Waypoints
from humanoid_ik.motion.registry import MOTIONS
from humanoid_ik.motion.track import TargetTrack

__all__ = [
    "MAX_KNOTS",
    "MOTIONS",
    "Circle",
    "FigureEight",
    "Lissajous",
    "Motion",
    "Orientation",
    "OutAndBack",
    "Points",
    "RandomWalk",
    "TargetTrack",
    "Waypoints",
    "hermite",
    "plane_basis",
    "smoothstep",
]
