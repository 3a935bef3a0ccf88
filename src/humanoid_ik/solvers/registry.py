"""The solvers by name: :data:`SOLVERS`, the one list a new solver is added to, and
``make_solver(name, **options)``. One-call IK, ``solve``, is :mod:`humanoid_ik.solvers.one_call`.
"""

from __future__ import annotations

from typing import Any

from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers.analytic.closed_form import ClosedForm
from humanoid_ik.solvers.analytic.subproblem import Subproblem
from humanoid_ik.solvers.analytic.two_link import TwoLink
from humanoid_ik.solvers.auto import Auto
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.ccd import CCD
from humanoid_ik.solvers.fabrik import FABRIK
from humanoid_ik.solvers.jacobian.dls import DLS
from humanoid_ik.solvers.jacobian.lm import LM
from humanoid_ik.solvers.jacobian.pseudoinverse import PseudoInverse
from humanoid_ik.solvers.jacobian.transpose import JacobianTranspose
from humanoid_ik.solvers.look_at import LookAt
from humanoid_ik.solvers.mink.solver import MinkSolver

__all__ = ["SOLVERS", "make_solver"]

SOLVERS: dict[str, type[Solver]] = {
    cls.name: cls
    for cls in (
        Auto,
        TwoLink,
        CCD,
        FABRIK,
        JacobianTranspose,
        PseudoInverse,
        DLS,
        LM,
        LookAt,
        MinkSolver,
        ClosedForm,
        Subproblem,
    )
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


def __getattr__(name: str) -> Any:
    if name == "solve":  # where it was, for one release
        import warnings

        from humanoid_ik.solvers.one_call import solve

        warnings.warn(
            f"{__name__}.solve is deprecated; use humanoid_ik.solve",
            DeprecationWarning,
            stacklevel=2,
        )
        return solve
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
