"""The IK solvers, by name (see :mod:`humanoid_ik.solvers.registry`)."""

from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.registry import SOLVERS, make_solver
from humanoid_ik.solvers.solve import solve

__all__ = ["SOLVERS", "Solver", "make_solver", "solve"]
