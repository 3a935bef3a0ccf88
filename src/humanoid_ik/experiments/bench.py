"""The benchmark: success rate and time per solve on seeded random reachable targets.

Targets are FK of ``n`` seeded random in-range joint vectors (so every one is reachable
within the ranges); every solve starts from the ``home`` keyframe (or ``qpos0`` moved
inside the ranges). A solve succeeds when the position error is below 1 mm (and the
orientation error below 0.01 rad for ``pose``) with every joint inside its range.

Each solve is timed twice: wall time (``time.perf_counter``) and the process's CPU time
(``time.process_time``), which other work on a shared machine disturbs less. With
``repeat`` K > 1 the same targets are solved K times; the medians reported are the
median of the K runs' medians, with the smallest and largest beside them (the spread).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.checks import MAX_TARGETS
from humanoid_ik.core.measures import on_target
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import TARGET_KINDS, Target
from humanoid_ik.errors import SolverError, choices
from humanoid_ik.solvers import SOLVERS, Solver, make_solver

__all__ = [
    "MAX_REPEAT",
    "BenchRow",
    "BenchReport",
    "run_bench",
    "make_targets",
    "Trials",
    "not_reaching",
    "run_trials",
]


MAX_REPEAT = 100
"""Most runs over the same targets in one bench (``--repeat``)."""


@dataclass(frozen=True)
class BenchRow:
    """One solver's figures (``None`` everywhere but ``solver`` and ``skipped`` when skipped).

    Times are per solve [ms]: ``median_ms`` and ``p95_ms`` wall time, ``cpu_median_ms``
    and ``cpu_p95_ms`` process CPU time; over ``repeat`` runs, the median of the runs'
    medians, the 95th percentiles of the first run, and the spread of the medians in
    ``median_ms_range`` and ``cpu_median_ms_range`` (smallest, largest). ``chosen``
    counts the solvers that produced the answers (``auto`` records its choice; any
    other solver names itself).
    """

    solver: str
    success_rate: float | None
    median_ms: float | None
    p95_ms: float | None
    mean_iterations: float | None
    max_position_error_m: float | None
    limit_violations: int | None
    skipped: str | None = None
    cpu_median_ms: float | None = None
    cpu_p95_ms: float | None = None
    median_ms_range: tuple[float, float] | None = None
    cpu_median_ms_range: tuple[float, float] | None = None
    chosen: dict[str, int] | None = None


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
    repeat: int = 1
    effector: str = "site"
    """What ``site`` names: a ``site`` or a ``body`` (a URDF link)."""

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["results"] = [asdict(r) for r in self.results]
        return d

    def table(self) -> str:
        """The results as a fixed-width text table (with ``repeat`` > 1, each median
        followed by the range of the runs' medians)."""
        spread = self.repeat > 1
        head = (
            f"{'solver':<20} {'success':>8} {'median ms':>10} "
            + (f"{'(min-max)':>15} " if spread else "")
            + f"{'cpu ms':>8} "
            + (f"{'(min-max)':>15} " if spread else "")
            + f"{'p95 ms':>9} {'mean iter':>10} {'max err mm':>11} {'limit viol':>10}"
        )
        lines = [head, "-" * len(head)]
        for r in self.results:
            if r.skipped:
                lines.append(f"{r.solver:<20} skipped: {r.skipped}")
                continue
            line = (
                f"{r.solver:<20} {_cell(r.success_rate, '>7.1f', 100)}% "
                f"{_cell(r.median_ms, '>10.3f')} "
                + (f"{_range(r.median_ms_range):>15} " if spread else "")
                + f"{_cell(r.cpu_median_ms, '>8.3f')} "
                + (f"{_range(r.cpu_median_ms_range):>15} " if spread else "")
                + f"{_cell(r.p95_ms, '>9.3f')} "
                f"{_cell(r.mean_iterations, '>10.1f')} "
                f"{_cell(r.max_position_error_m, '>11.4f', 1e3)} "
                f"{_cell(r.limit_violations, '>10d')}"
            )
            if r.chosen and set(r.chosen) != {r.solver}:
                line += "  " + ", ".join(f"{k} {v}" for k, v in r.chosen.items())
            lines.append(line)
        return "\n".join(lines)


def _range(pair: tuple[float, float] | None) -> str:
    """``(low-high)`` of a spread of medians [ms], or ``-``."""
    return "-" if pair is None else f"({pair[0]:.3f}-{pair[1]:.3f})"


def _cell(value: float | None, spec: str, scale: float = 1.0) -> str:
    """``value * scale`` formatted with ``spec`` (an int unscaled keeps its type), or
    ``-`` when there is no value."""
    if value is None:
        return "-"
    return format(value if scale == 1.0 else value * scale, spec)


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
    repeat: int = 1,
) -> BenchReport:
    """Benchmark solvers on one chain.

    Args:
        chain: the chain (its home pose is every solve's start).
        task: ``position`` or ``pose``.
        solvers: names; default every solver (those that do not apply are skipped).
        n: number of targets, 1 to :data:`~humanoid_ik.core.checks.MAX_TARGETS`.
        seed: seed of the target generator (>= 0).
        model_name: how the report names the model.
        progress: optional callable ``(solver, done, total)`` called during the run
            (``total`` is ``n * repeat``).
        repeat: runs over the same targets, 1 to :data:`MAX_REPEAT` (the spread of
            the medians; ``n * repeat`` at most :data:`~humanoid_ik.core.checks.MAX_TARGETS`).

    Raises:
        SolverError: unknown task or solver name, ``n``, ``seed`` or ``repeat`` out of
            range.
    """
    if task not in TARGET_KINDS:
        raise SolverError(f"task '{task}' unknown; tasks: {choices(TARGET_KINDS)}")
    checks = (("n", n, 1, MAX_TARGETS), ("seed", seed, 0, None), ("repeat", repeat, 1, MAX_REPEAT))
    for name, value, low, high in checks:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise SolverError(f"{name} must be an integer, got {value!r}")
        if value < low or (high is not None and value > high):
            upper = "" if high is None else f" and <= {high}"
            raise SolverError(f"{name} must be an integer >= {low}{upper}, got {value!r}")
    names = list(SOLVERS) if solvers is None else list(solvers)
    for name in names:
        if name not in SOLVERS:
            raise SolverError(f"solver '{name}' unknown; solvers: {choices(SOLVERS)}")
    if n * repeat > MAX_TARGETS:
        raise SolverError(
            f"n * repeat must be at most {MAX_TARGETS}, got {n} * {repeat} = {n * repeat}"
        )
    pose = task == "pose"
    targets = make_targets(chain, n, seed, pose)
    rows = [_bench_one(chain, name, targets, pose, progress, repeat) for name in names]
    joints = list(chain.joint_names)
    return BenchReport(
        model_name, chain.ee_name, joints, task, n, seed, rows, repeat, chain.ee_kind
    )


class Trials(NamedTuple):
    """One solver's answers to a list of targets, one entry per target."""

    times: NDArray[np.float64]
    """Wall time of each solve [s] ``(n,)``."""
    cpu_times: NDArray[np.float64]
    """Process CPU time of each solve [s] ``(n,)`` (``time.process_time``)."""
    iterations: NDArray[np.float64]
    """Iterations of each solve ``(n,)``."""
    position_errors: NDArray[np.float64]
    """Position error of each answer [m] ``(n,)``."""
    orientation_errors: NDArray[np.float64]
    """Orientation error of each answer [rad] ``(n,)`` (NaN for position targets)."""
    inside: NDArray[np.bool_]
    """Each answer within the joint ranges ``(n,)``."""
    success: NDArray[np.bool_]
    """On target (:func:`~humanoid_ik.core.measures.on_target`) and inside ``(n,)``."""
    solvers: list[str]
    """The solver that produced each answer (``IKResult.solver``; ``auto``'s choice)."""


def not_reaching(solver: Solver, chain: Chain, pose: bool) -> str | None:
    """Why ``solver`` cannot be benchmarked on reaching ``chain``'s targets, or ``None``."""
    reason = solver.applicable(chain, pose)
    if reason is None and not solver.reaches:
        reason = f"{solver.name} aims an axis at a point; it does not move the site onto targets"
    return reason


def run_trials(
    chain: Chain,
    solver: Solver,
    targets: Sequence[Target],
    progress: Callable[[int], None] | None = None,
) -> Trials:
    """Solve every target from the chain's home pose: THE benchmark loop (the bench and
    the sweeps' target sets both run it). The chain is left at home.

    Args:
        chain: the chain.
        solver: the solver (see :func:`not_reaching` for whether it applies).
        targets: the targets.
        progress: called with the number of targets done after each solve.
    """
    solver.prepare(chain)  # per-chain set-up is not part of any solve's time
    n = len(targets)
    times, cpu, iters = np.empty(n), np.empty(n), np.empty(n)
    errs, rot_errs = np.empty(n), np.full(n, np.nan)
    inside, ok = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
    names: list[str] = []
    clock, cpu_clock = time.perf_counter, time.process_time
    for i, tgt in enumerate(targets):
        chain.reset()
        c0 = cpu_clock()
        t0 = clock()
        res = solver.solve(chain, tgt)
        times[i] = clock() - t0
        cpu[i] = cpu_clock() - c0
        names.append(res.solver)
        iters[i] = res.iterations
        errs[i] = res.position_error
        rot = res.orientation_error
        if rot is not None:
            rot_errs[i] = rot
        inside[i] = chain.within_limits(res.q)
        if tgt.is_pose and rot is None:
            ok[i] = False
        else:
            ok[i] = inside[i] and on_target(res.position_error, rot if tgt.is_pose else None)
        if progress is not None:
            progress(i + 1)
    chain.reset()
    return Trials(times, cpu, iters, errs, rot_errs, inside, ok, names)


def _bench_one(
    chain: Chain, name: str, targets: list[Target], pose: bool, progress: Any, repeat: int
) -> BenchRow:
    solver = make_solver(name)
    reason = not_reaching(solver, chain, pose)
    if reason is not None:
        return BenchRow(name, None, None, None, None, None, None, skipped=reason)
    n = len(targets)
    runs = []
    for k in range(repeat):
        tick = None
        if progress is not None:
            tick = lambda done, k=k: progress(name, k * n + done, n * repeat)  # noqa: E731
        runs.append(run_trials(chain, solver, targets, tick))
    tr = runs[0]
    wall = [float(np.median(r.times) * 1e3) for r in runs]
    cpu = [float(np.median(r.cpu_times) * 1e3) for r in runs]
    chosen: dict[str, int] = {}
    for s in tr.solvers:
        chosen[s] = chosen.get(s, 0) + 1
    return BenchRow(
        solver=name,
        success_rate=float(tr.success.mean()),
        median_ms=float(np.median(wall)),
        p95_ms=float(np.percentile(tr.times, 95) * 1e3),
        mean_iterations=float(np.mean(tr.iterations)),
        max_position_error_m=float(tr.position_errors.max()),
        limit_violations=int((~tr.inside).sum()),
        cpu_median_ms=float(np.median(cpu)),
        cpu_p95_ms=float(np.percentile(tr.cpu_times, 95) * 1e3),
        median_ms_range=(min(wall), max(wall)),
        cpu_median_ms_range=(min(cpu), max(cpu)),
        chosen=dict(sorted(chosen.items())),
    )
