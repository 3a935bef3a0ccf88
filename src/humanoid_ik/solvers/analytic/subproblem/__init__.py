"""Exact IK of 6-hinge arms by Paden-Kahan subproblems (as IK-Geo and EAIK do).

A pose of the end frame fixes ``G = T T0^-1``, the product of the six hinges'
exponentials; the families of :mod:`.geometry` split ``G`` into subproblems (SP1-SP4,
and SP6, a quartic, for three parallel axes), solved in C (``_subproblem.c``, built by
``setup.py`` beside ``lm``'s kernel): every solution, up to 8. The modules:

- :mod:`.geometry`: the chain in its base frame at zero, the family, the cache;
- :mod:`.solver`: the :class:`Subproblem` solver (ranges with the 2 pi shift, the
  solution nearest the start) and :func:`solutions` (every solution).
"""

from humanoid_ik.solvers.analytic.subproblem.geometry import Family, family_of, subproblem_cache
from humanoid_ik.solvers.analytic.subproblem.solver import (
    Subproblem,
    SubproblemOptions,
    solutions,
)

__all__ = [
    "Family",
    "Subproblem",
    "SubproblemOptions",
    "family_of",
    "solutions",
    "subproblem_cache",
]
