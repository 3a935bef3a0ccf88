"""The IK solvers, by name."""

from __future__ import annotations

from typing import Any

from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.ccd import CCD
from humanoid_ik.solvers.closed_form import ClosedForm
from humanoid_ik.solvers.dls import DLS
from humanoid_ik.solvers.jacobian_transpose import JacobianTranspose
from humanoid_ik.solvers.look_at import LookAt
from humanoid_ik.solvers.mink_ik import MinkSolver
from humanoid_ik.solvers.pseudoinverse import PseudoInverse
from humanoid_ik.solvers.two_link import TwoLink

__all__ = [
    "SOLVERS",
    "Solver",
    "TwoLink",
    "CCD",
    "JacobianTranspose",
    "PseudoInverse",
    "DLS",
    "LookAt",
    "ClosedForm",
    "MinkSolver",
    "make_solver",
]

SOLVERS: dict[str, type[Solver]] = {
    cls.name: cls
    for cls in (TwoLink, CCD, JacobianTranspose, PseudoInverse, DLS, LookAt, MinkSolver, ClosedForm)
}


def make_solver(name: str, **options: Any) -> Solver:
    """A solver by name with its options.

    Raises:
        SolverError: unknown name (the valid names are listed) or a bad option.
    """
    try:
        cls = SOLVERS[name]
    except KeyError:
        raise SolverError(f"solver '{name}' unknown; solvers: {choices(SOLVERS)}") from None
    return cls(**options)
