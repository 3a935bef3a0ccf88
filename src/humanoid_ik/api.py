"""One-call IK: ``solve(chain, target, solver=...)`` with the caller's MjData left alone."""

from __future__ import annotations

from typing import Any

import mujoco
from numpy.typing import ArrayLike

from humanoid_ik.chain import Chain
from humanoid_ik.solvers import Solver, make_solver
from humanoid_ik.types import IKResult, Target

__all__ = ["solve"]


def solve(
    chain: Chain,
    target: Target | ArrayLike,
    solver: str | Solver = "dls",
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
        solver: a solver name (``two_link``, ``ccd``, ``jacobian_transpose``,
            ``pseudoinverse``, ``dls``, ``look_at``) or a solver object.
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
    s = make_solver(solver, **options) if isinstance(solver, str) else solver
    if data is not None:
        chain.load(data)
    result = s.solve(chain, tgt, q0)
    if apply and data is not None and result.converged:
        chain.apply(result.q, data)
    return result
