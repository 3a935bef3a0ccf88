"""Two-link analytic IK (the worksheet and the report): the elbow by the law of cosines,
then the shoulder in closed form, for three kinds of shoulder.

- **planar**: one shoulder hinge parallel to the elbow's (the report's arm):
  ``theta1 = atan2 -+ law of cosines``, two elbow branches;
- **two_hinge**: two shoulder hinges whose axes meet: up to two shoulder solutions per
  elbow branch, for targets inside the band of directions the two axes reach;
- **three_hinge**: a spherical shoulder (the worksheet's, the humanoid's): the twist
  about the shoulder-target line is free; the one kept is the feasible twist nearest
  the preferred one, found from the range ends in closed form.

The links' lengths and offsets come from MuJoCo at the zero pose; joints after the
elbow ride along at their start values. No search, no iteration.

Modules, in the order they build on each other:

- :mod:`.geometry`: the structure check, the geometry read from MuJoCo, the hand's
  law-of-cosines constants, the per-chain cache;
- :mod:`.shoulders`: the elbow branches and the shoulder's angles per kind, the
  worksheet's polar and angle/axis methods;
- :mod:`.solver`: the :class:`TwoLink` solver, its options, :class:`Solution`.

See ``docs/two_link.md``.
"""

from humanoid_ik.solvers.analytic.two_link.geometry import (
    KINDS,
    Shell,
    law_of_cosines,
    read_structure,
)
from humanoid_ik.solvers.analytic.two_link.shoulders import (
    AngleAxis,
    Polar,
    angle_axis_method,
    between,
    polar_angles,
    polar_method,
)
from humanoid_ik.solvers.analytic.two_link.solver import (
    Details,
    Solution,
    TwoLink,
    TwoLinkOptions,
)

__all__ = [
    "TwoLink",
    "TwoLinkOptions",
    "Solution",
    "Details",
    "Polar",
    "AngleAxis",
    "Shell",
    "KINDS",
    "law_of_cosines",
    "polar_angles",
    "polar_method",
    "angle_axis_method",
    "between",
    "read_structure",
]
