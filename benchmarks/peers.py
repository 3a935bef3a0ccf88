"""Our solvers against other IK libraries, on the same targets from the same start.

For each arm and task (``position``, ``pose``), ``--n`` targets at FK of seeded random
in-range joint vectors (``experiments.bench.make_targets``, as ``humanoid-ik bench``),
every solve from the chain's ``home`` pose, solved by:

- ours, by registry name: ``closed_form``, ``two_link``, ``dls``, ``lm``, ``auto``,
  ``mink`` (those registered in ``SOLVERS`` and applicable to the chain and task);
- TRAC-IK (``pytracik``) on a URDF of the chain (``outputs/urdf.py``), with its
  default 5 ms timeout and with 50 ms (pose targets only: pytracik has no
  position-only call);
- a plain ``mink.solve_ik`` loop, mink's public API alone, with the tasks and limits of
  our ``mink`` solver and no restart (``benchmarks/mink_step.py``);
- IKPy on the same URDF;
- dm_control's ``qpos_from_site_pose``, run in its own venv by
  ``benchmarks/dm_control_peer.py`` (targets out, answers back, as JSON).

Every answer is checked by an independent MuJoCo FK (a chain of its own on its own
``MjData``): on target within 1 mm / 0.01 rad (``core/measures.py``) and inside the
joint ranges (to 1e-6 rad, see :data:`RANGE_TOL`). Columns: success, success inside
the ranges, CPU median and p95 per solve (``time.process_time``, which adds the time of
every thread: TRAC-IK runs two), wall median, mean iterations where the library
reports them, and each row's CPU median over our best (the fastest of our solvers within
1 point of our best in-range success).

The floor: per arm, one ``mj_kinematics`` + ``mj_comPos`` + site (or body) Jacobian,
and each solver's CPU per iteration as a multiple of it.

    .venv/bin/python benchmarks/peers.py [--n 200]
        [--models humanoid,robot,jaco,cmu_arm,dm_humanoid] [--quick]
        [--json PATH] [--markdown PATH] [--dm-python benchmarks/.venv-dm/bin/python]

Arms from dm_control (``jaco``, ``cmu_arm``, ``dm_humanoid``) are read from the dm_control
package of that venv; without it they are left out, with a note (see
``docs/benchmarks.md`` for the venv).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import on_target, orientation_error
from humanoid_ik.core.models import bundled_dir, bundled_model_path
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.bench import make_targets, not_reaching
from humanoid_ik.outputs.atomic import write_json, write_text
from humanoid_ik.outputs.urdf import BASE_LINK, chain_urdf
from humanoid_ik.solvers import SOLVERS, make_solver

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mink_step import PlainMinkLoop  # noqa: E402  (the one plain mink loop)
from solvers import ROBOT_ARM  # noqa: E402  (benchmarks/solvers.py: the arm's joints)

HERE = Path(__file__).resolve().parent
DM_PYTHON = HERE / ".venv-dm" / "bin" / "python"
OURS = ("closed_form", "two_link", "dls", "lm", "auto", "mink")
"""Our solvers in the table, those of them that are registered."""
PEERS = ("trac_ik_5ms", "trac_ik_50ms", "mink_plain", "ikpy", "dm_control")
TASKS = ("position", "pose")
RANGE_TOL = 1e-6
"""An answer is inside the joint ranges to this [rad]: pytracik keeps its bounds in
float32, so TRAC-IK's answers at a range end overshoot it by up to about 1e-7 rad."""


@dataclass(frozen=True)
class Arm:
    """One arm: where its MJCF is and which chain of it is solved."""

    label: str
    xml: str
    """``bundled:<path under models/>`` or ``dm_control:<path in its package>``."""
    site: str | None = None
    body: str | None = None
    joints: tuple[str, ...] | None = None

    def path(self, dm_dir: Path | None) -> Path | None:
        kind, rel = self.xml.split(":", 1)
        if kind == "bundled":
            return bundled_model_path() if rel == "humanoid" else bundled_dir("models") / rel
        return None if dm_dir is None else dm_dir / rel

    def chain(self, dm_dir: Path | None) -> Chain:
        path = self.path(dm_dir)
        assert path is not None
        return Chain(path, self.site, self.joints, body=self.body)

    @property
    def effector(self) -> str:
        return self.site or self.body or ""


ARMS: dict[str, Arm] = {
    "humanoid": Arm(
        "bundled humanoid, right arm (7 hinges)", "bundled:humanoid", "right_palm_site"
    ),
    "robot": Arm(
        "models/robot, right arm (7 hinges, offset elbow)",
        "bundled:robot/robot.xml",
        "right_hand_site",
        joints=tuple(ROBOT_ARM),
    ),
    "jaco": Arm(
        "Kinova Jaco, dm_control (6 hinges)",
        "dm_control:third_party/kinova/jaco_arm.xml",
        "wristsite",
    ),
    "cmu_arm": Arm(
        "CMU humanoid right arm, dm_control (7 hinges)",
        "dm_control:suite/humanoid_CMU.xml",
        body="rhand",
        joints=(
            "rhumerusrz",
            "rhumerusry",
            "rhumerusrx",
            "rradiusrx",
            "rwristry",
            "rhandrz",
            "rhandrx",
        ),
    ),
    "dm_humanoid": Arm(
        "dm_control humanoid right arm (3 hinges)", "dm_control:suite/humanoid.xml", "right_hand"
    ),
}


@dataclass
class Answers:
    """One library's answers to a target list."""

    q: NDArray[np.float64]
    """Joint values ``(N, n)`` returned (the start where the library reported failure)."""
    cpu: NDArray[np.float64]
    """CPU time of each solve [s] ``(N,)``."""
    wall: NDArray[np.float64]
    """Wall time of each solve [s] ``(N,)``."""
    iterations: NDArray[np.float64] | None = None
    """Iterations of each solve ``(N,)``, where the library reports them."""


@dataclass
class Row:
    """One library's figures on one arm and task (or why it was left out)."""

    arm: str
    task: str
    who: str
    ours: bool
    skipped: str | None = None
    success: float | None = None
    inside: float | None = None
    cpu_median_ms: float | None = None
    cpu_p95_ms: float | None = None
    wall_median_ms: float | None = None
    mean_iterations: float | None = None
    cpu_per_iteration_us: float | None = None
    per_iteration_over_floor: float | None = None
    over_our_best: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)


# ------------------------------------------------------------------ timing and checking
def timed(
    solve_one: Callable[[Target], tuple[NDArray[np.float64], float | None]],
    targets: Sequence[Target],
    n_joints: int,
) -> Answers:
    """Call ``solve_one`` on every target (after one untimed call, so no lazy import or
    first-call set-up is timed): CPU and wall time of each call."""
    solve_one(targets[0])
    N = len(targets)
    q, cpu, wall, its = np.empty((N, n_joints)), np.empty(N), np.empty(N), np.full(N, np.nan)
    for i, tgt in enumerate(targets):
        w0, c0 = time.perf_counter(), time.process_time()
        qi, it = solve_one(tgt)
        cpu[i], wall[i] = time.process_time() - c0, time.perf_counter() - w0
        q[i] = qi
        if it is not None:
            its[i] = it
    return Answers(q, cpu, wall, None if np.isnan(its).all() else its)


def check(
    checker: Chain, targets: Sequence[Target], q: NDArray[np.float64]
) -> tuple[NDArray, NDArray]:
    """``(on target, inside the ranges to :data:`RANGE_TOL`)`` of each answer, by the
    checker chain's MuJoCo FK (its own model and ``MjData``, at home for the joints off
    the chain)."""
    ok, inside = np.zeros(len(targets), bool), np.zeros(len(targets), bool)
    for i, (tgt, qi) in enumerate(zip(targets, q, strict=True)):
        if not np.all(np.isfinite(qi)):
            continue
        p, R = checker.fk(qi)
        ep = float(np.linalg.norm(p - tgt.position))
        er = None if tgt.quat is None else orientation_error(R, tgt.quat)
        ok[i] = on_target(ep, er)
        inside[i] = checker.within_limits(qi, RANGE_TOL)
    checker.reset()
    return ok, inside


def floor_us(chain: Chain, repeats: int = 5000) -> float:
    """CPU time [us] of one ``mj_kinematics`` + ``mj_comPos`` + end-effector Jacobian."""
    m, d = chain.model, mujoco.MjData(chain.model)
    d.qpos[:] = chain.data.qpos
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    if chain.ee_kind == "site":
        jac = mujoco.mj_jacSite
    else:
        jac = mujoco.mj_jacBody
    kin, com, eid = mujoco.mj_kinematics, mujoco.mj_comPos, chain.ee_id
    best = math.inf
    for _ in range(3):
        c0 = time.process_time()
        for _ in range(repeats):
            kin(m, d)
            com(m, d)
            jac(m, d, jacp, jacr, eid)
        best = min(best, (time.process_time() - c0) / repeats * 1e6)
    return best


# ------------------------------------------------------------------ the libraries
def run_ours(name: str, chain: Chain, targets: Sequence[Target]) -> Answers | str:
    """One of our solvers by registry name, or why it does not apply."""
    solver = make_solver(name)
    reason = not_reaching(solver, chain, targets[0].is_pose)
    if reason is not None:
        return reason
    solver.prepare(chain)

    def one(tgt: Target) -> tuple[NDArray[np.float64], float | None]:
        chain.reset()
        res = solver.solve(chain, tgt)
        return res.q, res.iterations

    out = timed(one, targets, chain.n)
    chain.reset()
    return out


def run_trac_ik(
    chain: Chain, urdf: str, targets: Sequence[Target], timeout: float
) -> Answers | str:
    """TRAC-IK (pytracik, solve type Speed, epsilon 1e-5) with ``timeout`` [s]."""
    if not targets[0].is_pose:
        return "pose targets only (pytracik has no position-only call)"
    try:
        import pytracik
    except ImportError:
        return "pytracik not installed (pip install -e '.[bench-peers]')"
    ik = pytracik.TRAC_IK(BASE_LINK, chain.ee_name, urdf, timeout, 1e-5, pytracik.SolveType.Speed)
    start = chain.q_home.copy()

    def one(tgt: Target) -> tuple[NDArray[np.float64], float | None]:
        assert tgt.quat is not None
        w, x, y, z = tgt.quat
        p = tgt.position
        r = pytracik.ik(ik, start, p[0], p[1], p[2], x, y, z, w)
        return (np.asarray(r[1:], dtype=np.float64) if r[0] >= 0 else start), None

    return timed(one, targets, chain.n)


def run_mink_plain(chain: Chain, targets: Sequence[Target]) -> Answers | str:
    """The plain mink loop of ``benchmarks/mink_step.py`` (our mink solver's defaults)."""
    from humanoid_ik.solvers.mink import MinkOptions

    chain.reset()
    loop = PlainMinkLoop(chain, MinkOptions(), targets[0].is_pose)
    return timed(lambda t: loop.solve(t), targets, chain.n)


def run_ikpy(chain: Chain, urdf: str, targets: Sequence[Target]) -> Answers | str:
    """IKPy (its default optimiser) on the URDF, from the same start."""
    try:
        from ikpy.chain import Chain as IKPyChain
    except ImportError:
        return "ikpy not installed (pip install -e '.[bench-peers]')"
    with tempfile.TemporaryDirectory() as tmp:
        path = write_text(Path(tmp) / "arm.urdf", urdf)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ik = IKPyChain.from_urdf_file(
                str(path),
                base_elements=[BASE_LINK],
                active_links_mask=[False] + [True] * chain.n + [False],
            )
    init = np.concatenate([[0.0], chain.q_home, [0.0]])

    def one(tgt: Target) -> tuple[NDArray[np.float64], float | None]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if tgt.quat is None:
                q = ik.inverse_kinematics(tgt.position, initial_position=init)
            else:
                q = ik.inverse_kinematics(
                    tgt.position,
                    quat_to_mat(tgt.quat),
                    orientation_mode="all",
                    initial_position=init,
                )
        return np.asarray(q[1:-1], dtype=np.float64), None

    return timed(one, targets, chain.n)


def dm_package_dir(python: Path) -> Path | None:
    """dm_control's package folder in its venv, or ``None`` without the venv."""
    if not python.exists():
        return None
    env = {**os.environ, "MUJOCO_GL": "egl"}
    out = subprocess.run(
        [str(python), str(HERE / "dm_control_peer.py"), "--package-dir"],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return Path(out.stdout.strip())


def run_dm_control(python: Path, jobs: list[dict[str, Any]]) -> dict[tuple[str, str], Any]:
    """``qpos_from_site_pose`` on every job in one run of the dm_control venv: answers by
    (arm, task); a failed run gives every job ``{"error": <its last line>}``."""
    with tempfile.TemporaryDirectory() as tmp:
        req, res = Path(tmp) / "request.json", Path(tmp) / "result.json"
        write_json(req, {"jobs": jobs})
        env = {**os.environ, "MUJOCO_GL": "egl"}
        cmd = [str(python), str(HERE / "dm_control_peer.py"), str(req), str(res)]
        done = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or ["no message"])[-1]
            why = f"dm_control run failed (exit {done.returncode}): {last}"
            return {(j["arm"], j["task"]): {"error": why} for j in jobs}
        doc = json.loads(res.read_text())
    return {(r["arm"], r["task"]): r for r in doc["results"]}


def dm_job(
    key: str, arm: Arm, chain: Chain, task: str, targets: Sequence[Target], dm_dir: Path | None
) -> dict:
    """The request of one arm and task for ``dm_control_peer.py``."""
    return {
        "arm": key,
        "task": task,
        "xml": str(arm.path(dm_dir)),
        "site": arm.site or f"{arm.body}_peer_site",
        "site_on_body": arm.body,
        "joints": list(chain.joint_names),
        "start_qpos": chain.data.qpos.tolist(),
        "targets": [
            [t.position.tolist(), None if t.quat is None else t.quat.tolist()] for t in targets
        ],
    }


# ------------------------------------------------------------------ one arm
def summarise(row: Row, ans: Answers, ok: NDArray, inside: NDArray, floor: float) -> Row:
    row.success = float(ok.mean())
    row.inside = float((ok & inside).mean())
    row.cpu_median_ms = float(np.median(ans.cpu) * 1e3)
    row.cpu_p95_ms = float(np.percentile(ans.cpu, 95) * 1e3)
    row.wall_median_ms = float(np.median(ans.wall) * 1e3)
    if ans.iterations is not None:
        row.mean_iterations = float(np.mean(ans.iterations))
        total = float(np.sum(ans.iterations))
        if total > 0:
            row.cpu_per_iteration_us = float(np.sum(ans.cpu)) / total * 1e6
            row.per_iteration_over_floor = row.cpu_per_iteration_us / floor
    return row


def our_best(rows: Sequence[Row]) -> Row | None:
    """The fastest (CPU median) of our rows within 1 point of our best in-range success."""
    ours = [r for r in rows if r.ours and r.inside is not None]
    if not ours:
        return None
    top = max(r.inside for r in ours if r.inside is not None)
    fit = [r for r in ours if r.inside is not None and r.inside >= top - 0.01]
    return min(fit, key=lambda r: r.cpu_median_ms or math.inf)


def bench_arm(
    key: str,
    task: str,
    chain: Chain,
    checker: Chain,
    n: int,
    seed: int,
    peers: Sequence[str],
    ours: Sequence[str],
) -> tuple[list[Row], list[Target]]:
    """Every in-process library on one arm and task (dm_control is added later)."""
    chain.reset()
    targets = make_targets(chain, n, seed, task == "pose")
    urdf = chain_urdf(chain)
    floor = floor_us(chain)
    rows: list[Row] = []
    runs: list[tuple[str, bool, Callable[[], Answers | str]]] = []
    for name in ours:
        runs.append((name, True, lambda name=name: run_ours(name, chain, targets)))
    for peer in peers:
        if peer == "trac_ik_5ms":
            runs.append((peer, False, lambda: run_trac_ik(chain, urdf, targets, 0.005)))
        elif peer == "trac_ik_50ms":
            runs.append((peer, False, lambda: run_trac_ik(chain, urdf, targets, 0.05)))
        elif peer == "mink_plain":
            runs.append((peer, False, lambda: run_mink_plain(chain, targets)))
        elif peer == "ikpy":
            runs.append((peer, False, lambda: run_ikpy(chain, urdf, targets)))
    for who, is_ours, run in runs:
        print(f"  {key} {task}: {who}", file=sys.stderr, flush=True)
        ans = run()
        chain.reset()
        row = Row(key, task, who, is_ours, extra={"floor_us": floor})
        if isinstance(ans, str):
            row.skipped = ans
        else:
            ok, inside = check(checker, targets, ans.q)
            summarise(row, ans, ok, inside, floor)
        rows.append(row)
    return rows, targets


def add_dm_rows(
    rows: list[Row], key: str, task: str, targets: Sequence[Target], checker: Chain, result: Any
) -> None:
    """The dm_control answers of one arm and task, checked here."""
    floor = rows[0].extra["floor_us"]
    row = Row(key, task, "dm_control", False, extra={"floor_us": floor})
    if result is None or "answers" not in result:
        row.skipped = (
            "dm_control venv missing (see docs/benchmarks.md)"
            if result is None
            else result.get("error")
        )
    else:
        a = result["answers"]
        ans = Answers(
            q=np.array([x["q"] for x in a]),
            cpu=np.array([x["cpu_s"] for x in a]),
            wall=np.array([x["wall_s"] for x in a]),
            iterations=np.array([x["steps"] for x in a], dtype=np.float64),
        )
        ok, inside = check(checker, targets, ans.q)
        summarise(row, ans, ok, inside, floor)
    rows.append(row)


def finish(rows: list[Row]) -> None:
    """Each row's CPU median over our best on the same arm and task."""
    for arm, task in {(r.arm, r.task) for r in rows}:
        group = [r for r in rows if r.arm == arm and r.task == task]
        best = our_best(group)
        for r in group:
            if best is not None and r.cpu_median_ms is not None and best.cpu_median_ms:
                r.over_our_best = r.cpu_median_ms / best.cpu_median_ms
            if best is r:
                r.extra["our_best"] = True


# ------------------------------------------------------------------ output
def _f(x: float | None, spec: str, scale: float = 1.0) -> str:
    return "-" if x is None else format(x * scale, spec)


def markdown(rows: Sequence[Row], arms: dict[str, Arm], head: str) -> str:
    lines = [head, ""]
    lines.append(
        "| arm | task | solver | success | in ranges | CPU median [ms] | CPU p95 [ms] | "
        "wall median [ms] | mean iterations | CPU / our best |"
    )
    lines.append("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        name = f"**`{r.who}`**" if r.extra.get("our_best") else f"`{r.who}`"
        if r.skipped:
            continue
        lines.append(
            f"| {r.arm} | {r.task} | {name} | {_f(r.success, '.1f', 100)} % | "
            f"{_f(r.inside, '.1f', 100)} % | {_f(r.cpu_median_ms, '.3f')} | "
            f"{_f(r.cpu_p95_ms, '.3f')} | {_f(r.wall_median_ms, '.3f')} | "
            f"{_f(r.mean_iterations, '.1f')} | {_f(r.over_our_best, '.2f')} |"
        )
    left: dict[tuple[str, str], list[str]] = {}
    for r in rows:
        if r.skipped:
            left.setdefault((r.who, r.skipped), []).append(f"{r.arm} {r.task}")
    if left:
        lines += [
            "",
            "Left out: "
            + "; ".join(f"`{w}` on {', '.join(where)} ({why})" for (w, why), where in left.items())
            + ".",
        ]
    lines += [
        "",
        "Arms: "
        + "; ".join(f"{k}: {arms[k].label}" for k in dict.fromkeys(r.arm for r in rows))
        + ".",
    ]
    lines += ["", floor_table(rows)]
    return "\n".join(lines) + "\n"


def floor_table(rows: Sequence[Row]) -> str:
    """Per arm: the floor [us] and CPU per iteration over it, per solver (both tasks)."""
    whos = list(dict.fromkeys(r.who for r in rows if r.per_iteration_over_floor is not None))
    out = [
        "The floor (one `mj_kinematics` + `mj_comPos` + `mj_jacSite`/`mj_jacBody`, CPU) and "
        "each solver's CPU per iteration as a multiple of it (position / pose):",
        "",
        "| arm | floor [us] | " + " | ".join(f"`{w}`" for w in whos) + " |",
        "|---|---|" + "---|" * len(whos),
    ]
    for arm in dict.fromkeys(r.arm for r in rows):
        group = [r for r in rows if r.arm == arm]
        cells = []
        for w in whos:
            vals = [
                next(
                    (r.per_iteration_over_floor for r in group if r.who == w and r.task == t), None
                )
                for t in TASKS
            ]
            cells.append(" / ".join(_f(v, ".0f") for v in vals))
        out.append(f"| {arm} | {group[0].extra['floor_us']:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for pkg in ("mujoco", "mink", "daqp", "numpy", "pytracik", "ikpy"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = "-"
    return out


# ------------------------------------------------------------------ main
def run(
    models: Sequence[str],
    n: int,
    seed: int = 0,
    tasks: Sequence[str] = TASKS,
    peers: Sequence[str] = PEERS,
    ours: Sequence[str] | None = None,
    dm_python: Path = DM_PYTHON,
) -> tuple[list[Row], dict[str, Any]]:
    """The whole comparison; returns the rows and notes (versions, arms left out)."""
    ours = [s for s in (OURS if ours is None else ours) if s in SOLVERS]
    dm_dir = (
        dm_package_dir(dm_python)
        if "dm_control" in peers or any(ARMS[m].xml.startswith("dm_control:") for m in models)
        else None
    )
    notes: dict[str, Any] = {"versions": versions(), "left_out": {}}
    rows: list[Row] = []
    jobs: list[dict[str, Any]] = []
    pending: list[tuple[str, str, list[Target], Chain]] = []
    for key in models:
        arm = ARMS[key]
        if arm.path(dm_dir) is None:
            notes["left_out"][key] = "dm_control venv missing (see docs/benchmarks.md)"
            continue
        chain, checker = arm.chain(dm_dir), arm.chain(dm_dir)
        for task in tasks:
            arm_rows, targets = bench_arm(key, task, chain, checker, n, seed, peers, ours)
            rows += arm_rows
            if "dm_control" in peers:
                jobs.append(dm_job(key, arm, chain, task, targets, dm_dir))
                pending.append((key, task, targets, checker))
    if jobs:
        results = run_dm_control(dm_python, jobs) if dm_dir is not None else {}
        for key, task, targets, checker in pending:
            group = [r for r in rows if r.arm == key and r.task == task]
            idx = rows.index(group[-1]) + 1
            tail = rows[idx:]
            del rows[idx:]
            add_dm_rows(rows, key, task, targets, checker, results.get((key, task)))
            rows += tail
    finish(rows)
    return rows, notes


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=200, help="targets per arm and task (default 200)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--models", default=",".join(ARMS), help=f"comma-separated, of: {', '.join(ARMS)}"
    )
    p.add_argument("--tasks", default=",".join(TASKS), help="position,pose")
    p.add_argument(
        "--peers", default=",".join(PEERS), help=f"comma-separated, of: {', '.join(PEERS)}"
    )
    p.add_argument("--quick", action="store_true", help="20 targets (a smoke run)")
    p.add_argument("--json", metavar="PATH", help="also write rows and notes as JSON")
    p.add_argument("--markdown", metavar="PATH", help="also write the tables as Markdown")
    p.add_argument("--dm-python", default=str(DM_PYTHON), help="python of the dm_control venv")
    args = p.parse_args(argv)
    models, tasks, peers = args.models.split(","), args.tasks.split(","), args.peers.split(",")
    for what, given, valid in (
        ("model", models, ARMS),
        ("task", tasks, TASKS),
        ("peer", peers, PEERS),
    ):
        for g in given:
            if g not in valid:
                p.error(f"{what} '{g}' unknown; {what}s: {', '.join(valid)}")
    n = 20 if args.quick else args.n
    if n < 1:
        p.error(f"--n must be >= 1, got {n}")
    rows, notes = run(models, n, args.seed, tasks, peers, dm_python=Path(args.dm_python))
    v = notes["versions"]
    head = (
        f"n = {n} targets per arm and task, seed {args.seed}; "
        f"{platform.processor() or platform.machine()}, Python {v['python']}, "
        f"MuJoCo {v['mujoco']}, "
        f"mink {v['mink']}, pytracik {v['pytracik']}, ikpy {v['ikpy']}"
    )
    if notes["left_out"]:
        head += "; left out: " + ", ".join(f"{k} ({w})" for k, w in notes["left_out"].items())
    text = markdown(rows, ARMS, head)
    print(text)
    if args.markdown:
        write_text(args.markdown, text)
    if args.json:
        write_json(
            args.json,
            {"n": n, "seed": args.seed, "notes": notes, "rows": [r.__dict__ for r in rows]},
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
