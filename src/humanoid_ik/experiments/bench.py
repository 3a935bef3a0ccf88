"""The benchmark: success rate and time per solve on seeded random reachable targets.

Targets are FK of ``n`` seeded random in-range joint vectors (so every one is reachable
within the ranges); every solve starts from the ``home`` keyframe (or ``qpos0`` moved
inside the ranges). A solve succeeds when the position error is below 1 mm (and the
orientation error below 0.01 rad for ``pose``) with every joint inside its range.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers import SOLVERS, make_solver

__all__ = [
    "BenchRow",
    "BenchReport",
    "run_bench",
    "make_targets",
    "TASKS",
    "POSITION_SUCCESS_M",
    "ORIENTATION_SUCCESS_RAD",
]

TASKS = ("position", "pose")
POSITION_SUCCESS_M = 1e-3
ORIENTATION_SUCCESS_RAD = 1e-2


@dataclass(frozen=True)
class BenchRow:
    """One solver's figures (``None`` everywhere but ``solver`` and ``skipped`` when skipped)."""

    solver: str
    success_rate: float | None
    median_ms: float | None
    p95_ms: float | None
    mean_iterations: float | None
    max_position_error_m: float | None
    limit_violations: int | None
    skipped: str | None = None


@dataclass(frozen=True)
class BenchReport:
    """A whole bench run; ``to_dict`` is the ``--json`` document."""

    model: str
    site: str
    joints: list[str]
    task: str
    n: int
    seed: int
    results: list[BenchRow]

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["results"] = [asdict(r) for r in self.results]
        return d

    def table(self) -> str:
        """The results as a fixed-width text table."""
        head = (
            f"{'solver':<20} {'success':>8} {'median ms':>10} {'p95 ms':>9} "
            f"{'mean iter':>10} {'max err mm':>11} {'limit viol':>10}"
        )
        lines = [head, "-" * len(head)]
        for r in self.results:
            if r.skipped:
                lines.append(f"{r.solver:<20} skipped: {r.skipped}")
                continue
            lines.append(
                f"{r.solver:<20} {100 * r.success_rate:>7.1f}% {r.median_ms:>10.3f} "
                f"{r.p95_ms:>9.3f} {r.mean_iterations:>10.1f} "
                f"{1e3 * r.max_position_error_m:>11.4f} {r.limit_violations:>10d}"
            )
        return "\n".join(lines)


def make_targets(chain: Chain, n: int, seed: int, pose: bool) -> list[Target]:
    """``n`` targets at FK of seeded random in-range joint vectors."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        p, R = chain.fk(chain.random_q(rng))
        out.append(Target(p, mat_to_quat(R) if pose else None))
    chain.reset()
    return out


def run_bench(
    chain: Chain,
    task: str = "position",
    solvers: Sequence[str] | None = None,
    n: int = 500,
    seed: int = 0,
    model_name: str = "",
    progress: Any = None,
) -> BenchReport:
    """Benchmark solvers on one chain.

    Args:
        chain: the chain (its home pose is every solve's start).
        task: ``position`` or ``pose``.
        solvers: names; default every solver (those that do not apply are skipped).
        n: number of targets (>= 1).
        seed: seed of the target generator.
        model_name: how the report names the model.
        progress: optional callable ``(solver, done, n)`` called during the run.

    Raises:
        SolverError: unknown task or solver name, or ``n < 1``.
    """
    if task not in TASKS:
        raise SolverError(f"task '{task}' unknown; tasks: {choices(TASKS)}")
    if n < 1:
        raise SolverError(f"n must be >= 1, got {n}")
    names = list(SOLVERS) if solvers is None else list(solvers)
    for name in names:
        if name not in SOLVERS:
            raise SolverError(f"solver '{name}' unknown; solvers: {choices(SOLVERS)}")
    pose = task == "pose"
    targets = make_targets(chain, n, seed, pose)
    rows = [_bench_one(chain, name, targets, pose, progress) for name in names]
    return BenchReport(model_name, chain.ee_name, list(chain.joint_names), task, n, seed, rows)


def _bench_one(chain: Chain, name: str, targets: list[Target], pose: bool, progress) -> BenchRow:
    solver = make_solver(name)
    reason = solver.applicable(chain, pose)
    if reason is None and not solver.reaches:
        reason = f"{name} aims an axis at a point; it does not move the site onto targets"
    if reason is not None:
        return BenchRow(name, None, None, None, None, None, None, skipped=reason)
    times = np.empty(len(targets))
    iters = np.empty(len(targets))
    max_err, ok, violations = 0.0, 0, 0
    clock = time.perf_counter
    for i, tgt in enumerate(targets):
        chain.reset()
        t0 = clock()
        res = solver.solve(chain, tgt)
        times[i] = clock() - t0
        iters[i] = res.iterations
        inside = chain.within_limits(res.q)
        violations += not inside
        err = res.position_error
        max_err = max(max_err, err)
        rot_err = res.orientation_error
        rot_ok = not pose or (rot_err is not None and rot_err < ORIENTATION_SUCCESS_RAD)
        ok += err < POSITION_SUCCESS_M and rot_ok and inside
        if progress is not None:
            progress(name, i + 1, len(targets))
    chain.reset()
    return BenchRow(
        solver=name,
        success_rate=ok / len(targets),
        median_ms=float(np.median(times) * 1e3),
        p95_ms=float(np.percentile(times, 95) * 1e3),
        mean_iterations=float(np.mean(iters)),
        max_position_error_m=max_err,
        limit_violations=violations,
    )
