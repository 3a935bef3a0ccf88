"""One-call IK: ``solve(chain, target, solver=...)`` with the caller's MjData left alone.

``solve`` given a solver name reuses one solver object per name and options (solvers
hold no state, so one object serves every chain and thread): the call costs what the
solver costs, not the building of it (``benchmarks/solve_call.py``).
"""

from __future__ import annotations

import threading
from typing import Any

import mujoco
from numpy.typing import ArrayLike

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import IKResult, Target
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.registry import SOLVERS, make_solver

__all__ = ["solve", "solver_for"]

_MADE: dict[tuple[str, tuple[tuple[str, Any], ...]], Solver] = {}
_MADE_LOCK = threading.Lock()
_MADE_MAX = 64
"""At most this many solver objects are kept for :func:`solve` (then all are dropped)."""


def solver_for(name: str, options: dict[str, Any]) -> Solver:
    """The solver object :func:`solve` uses for ``name`` and ``options``: made once,
    then reused (options that cannot be hashed, such as lists, make a new one)."""
    key = (name, tuple(sorted(options.items())) if options else ())
    try:
        found = _MADE.get(key)
    except TypeError:  # an unhashable option value
        return make_solver(name, **options)
    if found is not None:
        return found
    made = make_solver(name, **options)
    with _MADE_LOCK:
        if len(_MADE) >= _MADE_MAX:
            _MADE.clear()
        return _MADE.setdefault(key, made)


def solve(
    chain: Chain,
    target: Target | ArrayLike,
    solver: str | Solver = "auto",
    *,
    quat: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    data: mujoco.MjData | None = None,
    apply: bool = False,
    **options: Any,
) -> IKResult:
    """Solve IK for ``chain`` toward ``target``.

    Args:
        chain: the kinematic chain.
        target: a :class:`Target` or a position ``(3,)`` [m].
        solver: a solver name (:data:`SOLVERS`; default ``auto``, which picks
            ``closed_form``, ``two_link`` or ``lm`` and records its choice) or a
            solver object.
        quat: target orientation, wxyz ``(4,)``, for a position given as an array.
        q0: start joint values ``(n,)``; default the chain's current ones (those of
            ``data`` when given).
        data: the caller's ``MjData``: its ``qpos`` is read (the model's other joints keep
            their values), and written only when ``apply`` is true and the solve converged.
        apply: write the converged result into ``data`` (and run ``mj_forward``).
        **options: solver options, when ``solver`` is a name.

    Raises:
        HumanoidIKError: a bad target, solver name or option; ``data`` is then unchanged.
    """
    tgt = Target.of(target, quat)
    if not isinstance(solver, (str, Solver)):
        raise SolverError(
            f"solver must be a solver name or a Solver, got {type(solver).__name__}; "
            f"solvers: {', '.join(sorted(SOLVERS))}"
        )
    s = solver_for(solver, options) if isinstance(solver, str) else solver
    result = s.solve(chain, tgt, q0, data=data)
    if apply and data is not None and result.converged:
        chain.apply(result.q, data)
    return result
