"""The IK solvers, by name (see :mod:`humanoid_ik.solvers.registry`)."""

from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.batch import solve_batch
from humanoid_ik.solvers.one_call import solve
from humanoid_ik.solvers.registry import SOLVERS, make_solver

__all__ = ["SOLVERS", "Solver", "make_solver", "solve", "solve_batch"]
