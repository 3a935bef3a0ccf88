"""The ``subproblem`` solver: exact pose IK of a 6-hinge arm of a family the
subproblems decompose (:mod:`.geometry`), every solution found in C, the ranges applied
with the 2 pi shift, the in-range solution nearest the start returned; a 7-hinge arm
whose first or last joint, held, leaves such six, by a search over that joint."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import BatchResults, IKResult, Status, Target
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.closed_form.numeric import RANGE_TOL
from humanoid_ik.solvers.analytic.subproblem.geometry import subproblem_cache
from humanoid_ik.solvers.base import Solver, on_threads
from humanoid_ik.solvers.jacobian.lm import kernel
from humanoid_ik.solvers.options import SolverOptions

__all__ = ["Subproblem", "SubproblemOptions", "solutions"]

POSE_ONLY = "subproblem solves pose targets only (a position leaves the arm 3 free angles)"


@dataclass(frozen=True)
class SubproblemOptions(SolverOptions):
    """Options of ``subproblem``: the tolerances only (``tol``, ``rot_tol``), which
    decide ``converged``; the answer itself is exact to rounding."""


class Subproblem(Solver):
    """Exact pose IK of a 6-hinge arm by Paden-Kahan subproblems (see
    ``docs/subproblem.md``).

    Applies to a chain with a spherical wrist or shoulder whose other three axes have
    parallel or meeting neighbours, or with three parallel neighbouring axes (the UR
    family): :func:`~.geometry.family_of`. Every joint vector that reaches the target
    (up to 8) is found in C; each angle is moved by a multiple of 2 pi into its range
    (nearest the start where several fit), and the in-range solution nearest the start
    (sum of squared differences) is returned, checked and polished by the arm's own FK
    (a pick that fails the check is dropped for the next).

    A 7-hinge chain whose last (else first) joint, held, leaves six of such a family
    (Panda, Talos's arm) is solved with that joint *searched*: its start value first,
    then in steps of 0.25 rad outwards, both ways in turn, with two bisections back
    towards the start at the first value where a solution of the six fits the ranges,
    and steps of 0.002 rad where the coarse pass found none (``docs/subproblem.md``);
    the in-range solution nearest the start at the value found is the answer. Exact
    where found; not complete: a target reachable only inside a window of the held
    joint narrower than the fine step can be missed.

    Errors: MuJoCo's FK of the answer and its errors, measured in ``lm``'s kernel (its
    chain kinematics, ``mj_kinematics``'s to the last bit; the distance and the angle of
    :func:`~humanoid_ik.core.measures.pose_error`), as ``lm`` measures its own and as a
    batch measures many (:meth:`solve_many`): about 1 us on UR5, where ``set_q`` and
    ``pose_error`` on numpy views cost about 5.

    Statuses: ``converged``; ``unreachable`` for a target no joint vector reaches (the
    start is returned) or one whose every solution leaves the ranges (the solution that
    leaves them least, clipped into them, is returned). ``details``: ``solutions`` (how
    many distinct joint vectors the subproblems give), ``inside`` (how many of them are
    in range) and, on a 7-hinge chain, ``tried`` (the values of the locked joint tried;
    ``solutions`` is then the most at one value, ``inside`` the count at the value
    taken).

    Caches: the chain keeps its family and the compiled arm
    (:class:`~.geometry.SubproblemCache`); :meth:`prepare` builds them.
    """

    name: ClassVar[str] = "subproblem"
    summary: ClassVar[str] = (
        "exact 6-hinge IK by Paden-Kahan subproblems, every solution, in C (7 hinges: one searched)"
    )
    supports_orientation: ClassVar[bool] = True
    Options: ClassVar[type[SolverOptions]] = SubproblemOptions

    def prepare(self, chain: Chain) -> None:
        """Read the chain's geometry and family, build the compiled arm (kept with the chain)."""
        subproblem_cache(chain)

    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        reason = subproblem_cache(chain).reason
        if reason is None and not pose:
            return POSE_ONLY
        return reason

    def __init__(self, **options: Any):
        super().__init__(**options)
        o = self.options
        # the lm kernel's options with no iteration: its measure of a joint vector
        self._measure = (o.tol, o.rot_tol, 1.0, 0.0, 0.0, 0, 1)

    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        quat = target.quat
        if quat is None:
            raise SolverError(POSE_ONLY)
        arm, base = subproblem_cache(chain).current(chain)
        q = np.empty(chain.n)
        found, inside, tried = arm.solve(
            target.position, quat, base, q0, chain.lower, chain.upper, RANGE_TOL, q
        )
        # MuJoCo's FK of the answer and its errors, measured in lm's kernel (as a batch's)
        ok, _its, _cost, ep, er = kernel(chain).descend(
            chain.data.qpos, chain.qpos_adr, chain.dof_adr, chain.ee_kind == "site",
            chain.ee_id, chain.lower, chain.upper, target.position, quat, self._measure, q,
        )  # fmt: skip
        chain.set_q(q)  # the scratch data at the answer
        q.setflags(write=False)  # q is this solve's own array: the result's
        return self.result(chain.n, q, (found, inside, tried), ok, ep, er)

    def result(
        self,
        n: int,
        q: NDArray[np.float64],
        counts: tuple[int, int, int],
        ok: bool,
        ep: float,
        er: float,
        extra: Mapping[str, Any] | None = None,
    ) -> IKResult:
        """The result of an answer ``q`` (read-only, the result's own) of an
        ``n``-hinge chain: ``counts`` the C solve's (found, inside, tried), ``ok`` and
        the errors the kernel's measure of it; ``extra``: more details (``auto``'s)."""
        found, inside, tried = counts
        message = ""
        if inside:
            status = Status.CONVERGED if ok else Status.MAX_ITERATIONS
        elif n == 7:
            status = Status.UNREACHABLE
            message = (
                f"no joint vector found inside the joint ranges at {tried} values of the "
                "searched joint"
            )
        elif found:
            status = Status.UNREACHABLE
            message = f"{found} joint vectors reach the target, none inside the joint ranges"
        else:
            status = Status.UNREACHABLE
            message = "no joint vector reaches the target (beyond the arm's reach)"
        details = {"solutions": found, "inside": inside}
        if n == 7:
            details["tried"] = tried
        if extra:
            details.update(extra)
        converged = status is Status.CONVERGED
        return IKResult.unchecked(
            q, converged, 1, ep, er, status, self.name, message, MappingProxyType(details)
        )

    def batch(
        self,
        n: int,
        q: NDArray[np.float64],
        counts: NDArray[np.float64],
        info: NDArray[np.float64],
        extra: Mapping[str, Any] | None = None,
    ) -> BatchResults:
        """:meth:`solve_many`'s answers ``q`` (read-only), ``counts`` and ``info`` as a
        batch: its arrays at once, each row's :meth:`result` when read (a converged row
        made from a template, with details shared by the rows of equal counts: 0.5 us a
        row, a fifth of :meth:`result`'s)."""
        template = {
            "converged": True, "iterations": 1, "status": Status.CONVERGED,
            "solver": self.name, "message": "",
        }  # fmt: skip
        shared: dict[tuple[int, int, int], Mapping[str, Any]] = {}
        converged = (counts[:, 1] > 0) & (info[:, 0] == 1.0)

        def row(i: int) -> IKResult:
            found, inside, tried = (int(c) for c in counts[i])
            _ok, _its, ep, er = info[i].tolist()
            if not converged[i]:
                return self.result(n, q[i], (found, inside, tried), _ok == 1.0, ep, er, extra)
            key = (found, inside, tried)
            details = shared.get(key)
            if details is None:
                d = {"solutions": found, "inside": inside}
                if n == 7:
                    d["tried"] = tried
                details = shared[key] = MappingProxyType({**d, **(extra or {})})
            r = object.__new__(IKResult)
            r.__dict__.update(
                template, q=q[i], position_error=ep, orientation_error=er, details=details
            )
            return r

        return BatchResults(len(q), row, (q, converged, info[:, 2].copy(), info[:, 3].copy()))

    def solve_many(
        self,
        chain: Chain,
        positions: NDArray[np.float64],
        quats: NDArray[np.float64],
        q0: NDArray[np.float64],
        threads: int = 1,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Many pose targets from the start ``q0`` (inside the ranges), each answer the
        one :meth:`solve` gives, bit for bit: the C solve (``Arm.solve_many``) and the
        kernel's measure (``Kernel.measure``) on ``threads`` threads, each on a
        contiguous part of the targets, the GIL released.

        Returns:
            The answers ``(N, n)``, the C solve's (found, inside, tried) ``(N, 3)`` and
            the measure's (converged, iterations, position error, orientation error)
            ``(N, 4)``.

        The caller holds the robot (:meth:`Chain.claim`) and has synced it.
        """
        arm, base = subproblem_cache(chain).current(chain)
        count, n = len(positions), chain.n
        kernels = [kernel(chain, k) for k in range(threads)]  # built here, not in threads
        q, counts, info = np.empty((count, n)), np.empty((count, 3)), np.empty((count, 4))
        p, qt = np.ascontiguousarray(positions), np.ascontiguousarray(quats)
        fixed = (
            chain.data.qpos.copy(), chain.qpos_adr, chain.dof_adr, chain.ee_kind == "site",
            chain.ee_id, chain.lower, chain.upper,
        )  # fmt: skip

        def run(k: int, lo: int, hi: int) -> None:
            pk, qk, out = p[lo:hi].reshape(-1), qt[lo:hi].reshape(-1), q[lo:hi]
            arm.solve_many(
                pk, qk, base, q0, chain.lower, chain.upper, RANGE_TOL, out.reshape(-1),
                counts[lo:hi].reshape(-1),
            )  # fmt: skip
            kernels[k].measure(
                *fixed, pk, qk, self._measure, np.empty(n), out.reshape(-1),
                info[lo:hi].reshape(-1),
            )  # fmt: skip

        on_threads(count, threads, run)
        return q, counts, info


def solutions(
    chain: Chain, target: Target | ArrayLike, q0: ArrayLike | None = None
) -> list[NDArray[np.float64]]:
    """Every joint vector ``(6,)`` that puts ``chain``'s end frame at the pose
    ``target``, each angle in (-pi, pi] (no range applied); ``q0`` (default: the
    chain's joints) only settles a straight wrist's free angle. On a 7-hinge chain,
    every joint vector ``(7,)`` with the searched joint at its value in ``q0``.

    Raises:
        SolverError: no exact decomposition applies to the chain.
    """
    tgt = Target.of(target)
    if tgt.quat is None:
        raise SolverError(POSE_ONLY)
    arm, base = subproblem_cache(chain).current(chain)
    start = chain.q if q0 is None else np.ascontiguousarray(chain.check_q(q0))
    return [np.array(s) for s in arm.solutions(tgt.position, tgt.quat, base, start)]
