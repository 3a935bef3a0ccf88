"""Our solvers against other IK libraries, on the same targets from the same start.

For each arm and task (``position``, ``pose``), ``--n`` targets at FK of seeded random
in-range joint vectors (``experiments.bench.make_targets``, as ``humanoid-ik bench``),
every solve from the chain's ``home`` pose, solved by:

- ours, by registry name: ``closed_form``, ``two_link``, ``dls``, ``lm``, ``auto``,
  ``mink`` (and ``subproblem`` when ``--ours`` names it; those registered in
  ``SOLVERS`` and applicable to the chain and task), each solver object made and
  prepared once; and ``solve_auto``, the convenience call
  ``solve(chain, target, "auto", q0=start)`` on every target;
- TRAC-IK (``pytracik``) on a URDF of the chain (``outputs/urdf.py``), with its
  default 5 ms timeout and with 50 ms (pose targets only: pytracik has no
  position-only call);
- a plain ``mink.solve_ik`` loop, mink's public API alone, with the tasks and limits of
  our ``mink`` solver and no restart (``benchmarks/mink_step.py``);
- IKPy on the same URDF;
- roboticstoolbox-python's compiled ``ik_LM`` and ``ik_NR`` (joint limits on; its
  default ``tol`` and a tight one) and EAIK (analytic; with and without the 2 pi shift
  of its answers into the ranges), on the chain's kinematics as MuJoCo has them
  (``benchmarks/peer_libs.py``);
- dm_control's ``qpos_from_site_pose``, run in its own venv by
  ``benchmarks/dm_control_peer.py`` (targets out, answers back, as JSON), on the MJCF
  arms.

Arms: the bundled and dm_control MJCF arms, and seven arms of ``example-robot-data``
from their original URDFs (:data:`REAL_ARMS`). Each peer's FK is compared with
MuJoCo's at a few random joint vectors before anything is timed (to 1e-9; a peer off
by more is left out with its gap). The libraries run **interleaved**: in blocks of
:data:`BLOCK` targets, each library in turn, so a noisy neighbour on the machine slows
every library alike (:func:`interleaved`); ``--seeds`` repeats the whole run on other
targets, in the same process.

Every answer is checked by an independent MuJoCo FK (a chain of its own on its own
``MjData``): on target within 1 mm / 0.01 rad (``core/measures.py``) and inside the
joint ranges (to 1e-6 rad, see :data:`RANGE_TOL`). Columns: success, success inside
the ranges, CPU median and p95 per solve (``time.process_time``, which adds the time of
every thread: TRAC-IK runs two), wall median, mean iterations where the library
reports them, and our CPU median over the row's (``auto``, ``lm``, ``solve()``).

The floor: per arm, one ``mj_kinematics`` + ``mj_comPos`` + site (or body) Jacobian,
and each solver's CPU per iteration as a multiple of it.

    .venv/bin/python benchmarks/peers.py [--n 200] [--seeds 0,1]
        [--models humanoid,robot,jaco,cmu_arm,dm_humanoid,panda,ur5,...] [--quick]
        [--ours lm,auto,solve_auto] [--peers trac_ik_50ms,rtb_lm_tight,eaik,...]
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
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.limbs import limb_chain
from humanoid_ik.core.measures import on_target, orientation_error
from humanoid_ik.core.models import bundled_dir, bundled_model_path, load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.bench import make_targets
from humanoid_ik.outputs.atomic import write_json, write_text
from humanoid_ik.outputs.urdf import chain_urdf
from humanoid_ik.solvers import SOLVERS

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
from peer_libs import FK_TOL, PeerRun, setup_ours, setup_peer  # noqa: E402  (the libraries)
from solvers import ROBOT_ARM  # noqa: E402  (benchmarks/solvers.py: the arm's joints)

from tests.robots import robot_file  # noqa: E402  (example-robot-data's original URDFs)

DM_PYTHON = HERE / ".venv-dm" / "bin" / "python"
OURS = ("closed_form", "two_link", "dls", "lm", "auto", "mink", "solve_auto")
"""Our solvers in the table, those of them that are registered (``solve_auto``: the
``solve()`` call with ``"auto"``)."""
MORE_OURS = ("subproblem",)
"""Ours that ``--ours`` also takes, not in the default table: ``subproblem`` applies to
6-hinge arms of its families (UR5, Kinova) and 7-hinge arms with a joint searched
(Panda, Talos), a row of its reason on every other arm."""
PEERS = (
    "trac_ik_5ms",
    "trac_ik_50ms",
    "mink_plain",
    "ikpy",
    "rtb_lm",
    "rtb_lm_tight",
    "rtb_nr",
    "rtb_nr_tight",
    "eaik",
    "eaik_raw",
    "dm_control",
)
RATIO_TO = ("auto", "lm", "solve_auto")
"""Ours whose CPU median over each row's the tables show."""
LABEL = {"solve_auto": "solve()"}
TASKS = ("position", "pose")
RANGE_TOL = 1e-6
"""An answer is inside the joint ranges to this [rad]: pytracik keeps its bounds in
float32, so TRAC-IK's answers at a range end overshoot it by up to about 1e-7 rad."""


REAL_ARMS: dict[str, tuple[str, str, str]] = {
    "panda": ("panda", "arm", "Franka Panda (7 hinges)"),
    "ur5": ("ur5", "arm", "UR5 (6 hinges)"),
    "kinova": ("kinova", "arm", "Kinova j2s6s200 (6 hinges, 3 unlimited)"),
    "g1_left_arm": ("g1", "left_arm", "Unitree G1, left arm (7 hinges)"),
    "talos_left_arm": ("talos", "left_arm", "Talos, left arm (7 hinges)"),
    "baxter_left_arm": ("baxter", "left_arm", "Baxter, left arm (7 hinges)"),
    "so100": ("so100", "arm", "SO-100 (5 hinges)"),
}
"""Key: (``tests/robots.py`` name, limb, label)."""


def real_chain(robot: str, limb: str) -> Chain:
    """The chain of ``robot``'s ``limb`` (``core.limbs``), on a model of its own."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a home pose outside the ranges, said by load_model
        model = load_model(str(robot_file(robot)))
    return limb_chain(Robot(model), limb)


@dataclass(frozen=True)
class Arm:
    """One arm: where its MJCF is and which chain of it is solved."""

    label: str
    xml: str
    """``bundled:<path under models/>``, ``dm_control:<path in its package>`` or
    ``robot:<tests/robots.py name>`` (example-robot-data's URDF, with ``limb``)."""
    site: str | None = None
    body: str | None = None
    joints: tuple[str, ...] | None = None
    limb: str | None = None

    def path(self, dm_dir: Path | None) -> Path | None:
        kind, rel = self.xml.split(":", 1)
        if kind == "bundled":
            return bundled_model_path() if rel == "humanoid" else bundled_dir("models") / rel
        if kind == "robot":
            return Path(rel)
        return None if dm_dir is None else dm_dir / rel

    @property
    def mjcf(self) -> bool:
        return not self.xml.startswith("robot:")

    def chain(self, dm_dir: Path | None) -> Chain:
        if not self.mjcf:
            assert self.limb is not None
            return real_chain(self.xml.split(":", 1)[1], self.limb)
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
    **{
        key: Arm(f"{label}, example-robot-data", f"robot:{robot}", limb=limb)
        for key, (robot, limb, label) in REAL_ARMS.items()
    },
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
    """One library's figures on one arm, task and seed (or why it was left out)."""

    arm: str
    task: str
    who: str
    ours: bool
    seed: int = 0
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
BLOCK = 10
"""Targets a library solves in a row before the next library's turn."""


def interleaved(
    libs: dict[str, PeerRun], targets: Sequence[Target], n_joints: int, block: int = BLOCK
) -> dict[str, Answers]:
    """Every library on every target, interleaved: block by block of ``block`` targets,
    each library in turn (in an order shuffled each block, seeded), each turn after one
    untimed call on the first target (so no lazy import or first-call set-up is timed,
    and the library's data is in the caches as in a loop of solves, not evicted by the
    library before it). CPU and wall time of each call."""
    N, names = len(targets), list(libs)
    out = {
        who: Answers(np.empty((N, n_joints)), np.empty(N), np.empty(N), np.full(N, np.nan))
        for who in names
    }
    clock, wall, rng = time.process_time, time.perf_counter, np.random.default_rng(0)
    for b0 in range(0, N, block):
        for who in rng.permutation(names):
            lib, a = libs[who], out[who]
            lib.solve(targets[0])
            if lib.call_cpu is not None:
                del lib.call_cpu[-1]
            for i in range(b0, min(b0 + block, N)):
                w0, c0 = wall(), clock()
                qi, it = lib.solve(targets[i])
                c1, w1 = clock(), wall()
                a.cpu[i], a.wall[i], a.q[i] = c1 - c0, w1 - w0, qi
                if it is not None:
                    assert a.iterations is not None
                    a.iterations[i] = it
    for a in out.values():
        if a.iterations is not None and np.isnan(a.iterations).all():
            a.iterations = None
    return out


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
    """Every in-process library on one arm and task, interleaved (dm_control is added
    later); a peer whose FK is off MuJoCo's by more than :data:`FK_TOL` is left out."""
    chain.reset()
    pose = task == "pose"
    targets = make_targets(chain, n, seed, pose)
    urdf = chain_urdf(chain)
    floor = floor_us(chain)
    made: dict[str, PeerRun | str] = {}
    for who in [*ours, *(p for p in peers if p != "dm_control")]:
        print(f"  {key} {task} seed {seed}: {who}", file=sys.stderr, flush=True)
        lib = setup_ours(who, chain, pose) if who in ours else setup_peer(who, chain, urdf, pose)
        if not isinstance(lib, str) and lib.fk_gap is not None and lib.fk_gap > FK_TOL:
            lib = f"its FK is {lib.fk_gap:.1e} off MuJoCo's"
        made[who] = lib
        chain.reset()
    libs = {w: lib for w, lib in made.items() if not isinstance(lib, str)}
    answers = interleaved(libs, targets, chain.n) if libs else {}
    chain.reset()
    rows: list[Row] = []
    for who, lib in made.items():
        row = Row(key, task, who, who in ours, seed, extra={"floor_us": floor})
        if isinstance(lib, str):
            row.skipped = lib
        else:
            ans = answers[who]
            ok, inside = check(checker, targets, ans.q)
            summarise(row, ans, ok, inside, floor)
            if lib.fk_gap is not None:
                row.extra["fk_gap"] = lib.fk_gap
            if lib.call_cpu:
                row.extra["call_cpu_median_ms"] = float(np.median(lib.call_cpu) * 1e3)
            row.extra.update(lib.notes)
        rows.append(row)
    return rows, targets


def add_dm_rows(
    rows: list[Row],
    key: str,
    task: str,
    seed: int,
    targets: Sequence[Target],
    checker: Chain,
    result: Any,
) -> None:
    """The dm_control answers of one arm and task, checked here."""
    floor = rows[0].extra["floor_us"]
    row = Row(key, task, "dm_control", False, seed, extra={"floor_us": floor})
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
    """Each row's CPU median over our best on the same arm, task and seed."""
    for arm, task, seed in {(r.arm, r.task, r.seed) for r in rows}:
        group = [r for r in rows if r.arm == arm and r.task == task and r.seed == seed]
        best = our_best(group)
        for r in group:
            if best is not None and r.cpu_median_ms is not None and best.cpu_median_ms:
                r.over_our_best = r.cpu_median_ms / best.cpu_median_ms
            if best is r:
                r.extra["our_best"] = True


# ------------------------------------------------------------------ output
def _f(x: float | None, spec: str, scale: float = 1.0) -> str:
    return "-" if x is None else format(x * scale, spec)


def _per_seed(vals: Sequence[float | None], spec: str, scale: float = 1.0) -> str:
    """One cell: the value of each seed, ``a / b``."""
    return " / ".join(_f(v, spec, scale) for v in vals)


def _get(rows: Sequence[Row | None], attr: str) -> list[float | None]:
    """``attr`` of each row (``None`` for a missing row)."""
    return [None if r is None else getattr(r, attr) for r in rows]


def _ratio(ours: Row | None, peer: Row | None) -> float | None:
    if ours is None or peer is None or not ours.cpu_median_ms or not peer.cpu_median_ms:
        return None
    return ours.cpu_median_ms / peer.cpu_median_ms


def _name(who: str) -> str:
    return f"`{LABEL.get(who, who)}`"


def arm_table(rows: Sequence[Row], arm: str, task: str, seeds: Sequence[int]) -> list[str]:
    """The table of one arm and task: a row per library, each cell one value per seed."""
    group = [r for r in rows if r.arm == arm and r.task == task]
    whos = list(dict.fromkeys(r.who for r in group if not r.skipped))
    at = {(r.who, r.seed): r for r in group}
    ref = [w for w in RATIO_TO if any((w, s) in at and not at[w, s].skipped for s in seeds)]
    lines = [
        "| library | success | in ranges | CPU median [ms] | CPU p95 [ms] | wall median [ms] "
        "| mean iterations | " + " | ".join(f"{_name(w)} ÷ it" for w in ref) + " |",
        "|---|---|---|---|---|---|---|" + "---|" * len(ref),
    ]
    for who in whos:
        rs = [at.get((who, s)) for s in seeds]
        bold = any(r is not None and r.extra.get("our_best") for r in rs)
        name = f"**{_name(who)}**" if bold else _name(who)
        cells = [
            _per_seed(_get(rs, "success"), ".1f", 100) + " %",
            _per_seed(_get(rs, "inside"), ".1f", 100) + " %",
            _per_seed(_get(rs, "cpu_median_ms"), ".3f"),
            _per_seed(_get(rs, "cpu_p95_ms"), ".3f"),
            _per_seed(_get(rs, "wall_median_ms"), ".3f"),
            _per_seed(_get(rs, "mean_iterations"), ".1f"),
        ]
        cells += [
            _per_seed([_ratio(at.get((w, s)), at.get((who, s))) for s in seeds], ".2f") for w in ref
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def call_notes(rows: Sequence[Row], arm: str, task: str, seeds: Sequence[int]) -> list[str]:
    """A line for each library whose solve adds our work around its calls (EAIK): the
    CPU median of its calls alone, and the joint it locks."""
    out = []
    group = [r for r in rows if r.arm == arm and r.task == task and not r.skipped]
    for who in dict.fromkeys(r.who for r in group if "call_cpu_median_ms" in r.extra):
        rs = [next((r for r in group if r.who == who and r.seed == s), None) for s in seeds]
        call = [None if r is None else r.extra.get("call_cpu_median_ms") for r in rs]
        line = f"{_name(who)}: its own calls {_per_seed(call, '.4f')} ms CPU median per solve"
        first = next(r for r in rs if r is not None)
        if "locked_joint" in first.extra:
            line += (
                f", joint {int(first.extra['locked_joint']) + 1} of {arm} locked "
                f"(up to {int(first.extra['lock_values'])} values)"
            )
        out.append(line + "; the rest of its CPU is the pick of one answer inside the ranges.")
    return out + [""] if out else []


SUMMARY_PEERS = ("trac_ik_50ms", "rtb_lm_tight", "rtb_nr_tight", "eaik")


def summary_table(rows: Sequence[Row], arms: dict[str, Arm], seeds: Sequence[int]) -> list[str]:
    """Pose targets, an arm a line: ``auto`` (success over every seed's targets, CPU
    median and p95 per seed), its CPU median over each main peer's (per seed, with the
    peer's in-range success over every seed), and ``solve()`` over ``auto``."""
    pose = [r for r in rows if r.task == "pose" and not r.skipped]
    keys = list(dict.fromkeys(r.arm for r in pose))
    peers = [p for p in SUMMARY_PEERS if any(r.who == p for r in pose)]
    if not keys or not any(r.who == "auto" for r in pose):
        return []
    lines = [
        "| arm (pose targets) | `auto` in ranges | `auto` CPU median [ms] | `auto` CPU p95 [ms] | "
        + " | ".join(f"`auto` ÷ `{p}` (its in ranges)" for p in peers)
        + " | `solve()` ÷ `auto` |",
        "|---|---|---|---|" + "---|" * (len(peers) + 1),
    ]

    def pooled(who: str, arm: str) -> str:
        rs = [r for r in pose if r.arm == arm and r.who == who and r.inside is not None]
        return "-" if not rs else f"{100 * float(np.mean([r.inside for r in rs])):.1f} %"

    for arm in keys:
        at = {(r.who, r.seed): r for r in pose if r.arm == arm}
        au = [at.get(("auto", s)) for s in seeds]
        cells = [
            pooled("auto", arm),
            _per_seed(_get(au, "cpu_median_ms"), ".3f"),
            _per_seed(_get(au, "cpu_p95_ms"), ".3f"),
        ]
        for p in peers:
            if not any((p, s) in at for s in seeds):
                cells.append("does not apply")
                continue
            ratios = [_ratio(at.get(("auto", s)), at.get((p, s))) for s in seeds]
            cells.append(f"{_per_seed(ratios, '.2f')} ({pooled(p, arm)})")
        cells.append(
            _per_seed(
                [_ratio(at.get(("solve_auto", s)), at.get(("auto", s))) for s in seeds], ".2f"
            )
        )
        lines.append(f"| {arms[arm].label} | " + " | ".join(cells) + " |")
    return lines


def markdown(rows: Sequence[Row], arms: dict[str, Arm], head: str) -> str:
    """The summary (pose targets), a table per arm and task, what was left out, the
    arms, the floor."""
    seeds = sorted({r.seed for r in rows})
    lines = [head, ""]
    summary = summary_table(rows, arms, seeds)
    if summary:
        lines += summary + [""]
    note = " (each cell: seed " + " / seed ".join(map(str, seeds)) + ")" if len(seeds) > 1 else ""
    for arm, task in dict.fromkeys((r.arm, r.task) for r in rows):
        if all(r.skipped for r in rows if r.arm == arm and r.task == task):
            continue
        lines += [f"`{arm}`, {task} targets{note}:", ""]
        lines += arm_table(rows, arm, task, seeds) + [""]
        lines += call_notes(rows, arm, task, seeds)
    left: dict[tuple[str, str], list[str]] = {}
    for r in rows:
        if r.skipped and r.seed == seeds[0]:
            left.setdefault((r.who, r.skipped), []).append(f"{r.arm} {r.task}")
    if left:
        lines += [
            "Left out: "
            + "; ".join(f"`{w}` on {', '.join(where)} ({why})" for (w, why), where in left.items())
            + ".",
            "",
        ]
    lines += [
        "Arms: "
        + "; ".join(f"{k}: {arms[k].label}" for k in dict.fromkeys(r.arm for r in rows))
        + ".",
    ]
    lines += ["", floor_table([r for r in rows if r.seed == seeds[0]])]
    return "\n".join(lines) + "\n"


def floor_table(rows: Sequence[Row]) -> str:
    """Per arm: the floor [us] and CPU per iteration over it, per solver (both tasks)."""
    whos = list(dict.fromkeys(r.who for r in rows if r.per_iteration_over_floor is not None))
    out = [
        "The floor (one `mj_kinematics` + `mj_comPos` + `mj_jacSite`/`mj_jacBody`, CPU) and "
        "each solver's CPU per iteration as a multiple of it (position / pose):",
        "",
        "| arm | floor [us] | " + " | ".join(_name(w) for w in whos) + " |",
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
    for pkg in (
        "mujoco",
        "mink",
        "daqp",
        "numpy",
        "pytracik",
        "ikpy",
        "roboticstoolbox-python",
        "eaik",
        "example-robot-data",
    ):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = "-"
    return out


# ------------------------------------------------------------------ main
def run(
    models: Sequence[str],
    n: int,
    seeds: Sequence[int] = (0,),
    tasks: Sequence[str] = TASKS,
    peers: Sequence[str] = PEERS,
    ours: Sequence[str] | None = None,
    dm_python: Path = DM_PYTHON,
) -> tuple[list[Row], dict[str, Any]]:
    """The whole comparison, once per seed; returns the rows and notes (versions, arms
    left out)."""
    ours = [s for s in (OURS if ours is None else ours) if s == "solve_auto" or s in SOLVERS]
    dm_dir = (
        dm_package_dir(dm_python)
        if "dm_control" in peers or any(ARMS[m].xml.startswith("dm_control:") for m in models)
        else None
    )
    notes: dict[str, Any] = {"versions": versions(), "left_out": {}}
    rows: list[Row] = []
    chains: dict[str, tuple[Chain, Chain]] = {}
    for key in models:
        arm = ARMS[key]
        if arm.path(dm_dir) is None:
            notes["left_out"][key] = "dm_control venv missing (see docs/benchmarks.md)"
            continue
        chains[key] = (arm.chain(dm_dir), arm.chain(dm_dir))
    for seed in seeds:
        jobs: list[dict[str, Any]] = []
        pending: list[tuple[str, str, list[Target], Chain, int]] = []
        for key, (chain, checker) in chains.items():
            for task in tasks:
                arm_rows, targets = bench_arm(key, task, chain, checker, n, seed, peers, ours)
                rows += arm_rows
                if "dm_control" not in peers:
                    continue
                if ARMS[key].mjcf:
                    jobs.append(dm_job(key, ARMS[key], chain, task, targets, dm_dir))
                pending.append((key, task, targets, checker, len(rows)))
        results = run_dm_control(dm_python, jobs) if jobs and dm_dir is not None else {}
        for key, task, targets, checker, end in reversed(pending):
            tail = rows[end:]
            del rows[end:]
            if ARMS[key].mjcf:
                add_dm_rows(rows, key, task, seed, targets, checker, results.get((key, task)))
            else:
                floor = rows[-1].extra["floor_us"]
                rows.append(
                    Row(
                        key,
                        task,
                        "dm_control",
                        False,
                        seed,
                        "MJCF arms only",
                        extra={"floor_us": floor},
                    )
                )
            rows += tail
    finish(rows)
    return rows, notes


def _names(p: argparse.ArgumentParser, what: str, given: str, valid: Sequence[str]) -> list[str]:
    """A comma-separated list of names, each checked against ``valid``."""
    out = given.split(",")
    for g in out:
        if g not in valid:
            p.error(f"{what} '{g}' unknown; {what}s: {', '.join(valid)}")
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=200, help="targets per arm and task (default 200)")
    p.add_argument("--seeds", default="0", help="comma-separated target seeds (default 0)")
    p.add_argument(
        "--models", default=",".join(ARMS), help=f"comma-separated, of: {', '.join(ARMS)}"
    )
    p.add_argument("--tasks", default=",".join(TASKS), help="position,pose")
    p.add_argument(
        "--ours", default=",".join(OURS), help=f"comma-separated, of: {', '.join(OURS + MORE_OURS)}"
    )
    p.add_argument(
        "--peers", default=",".join(PEERS), help=f"comma-separated, of: {', '.join(PEERS)}"
    )
    p.add_argument("--quick", action="store_true", help="20 targets (a smoke run)")
    p.add_argument("--json", metavar="PATH", help="also write rows and notes as JSON")
    p.add_argument("--markdown", metavar="PATH", help="also write the tables as Markdown")
    p.add_argument("--dm-python", default=str(DM_PYTHON), help="python of the dm_control venv")
    args = p.parse_args(argv)
    models = _names(p, "model", args.models, list(ARMS))
    tasks = _names(p, "task", args.tasks, TASKS)
    ours = _names(p, "solver", args.ours, OURS + MORE_OURS)
    peers = _names(p, "peer", args.peers, PEERS)
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        p.error(f"--seeds takes comma-separated integers, got '{args.seeds}'")
    if any(s < 0 for s in seeds):
        p.error(f"--seeds must be >= 0, got '{args.seeds}'")
    n = 20 if args.quick else args.n
    if n < 1:
        p.error(f"--n must be >= 1, got {n}")
    rows, notes = run(models, n, seeds, tasks, peers, ours, dm_python=Path(args.dm_python))
    v = notes["versions"]
    head = (
        f"n = {n} targets per arm and task, seeds {', '.join(map(str, seeds))}, libraries "
        f"interleaved; {platform.processor() or platform.machine()}, Python {v['python']}, "
        f"MuJoCo {v['mujoco']}, mink {v['mink']}, pytracik {v['pytracik']}, ikpy {v['ikpy']}, "
        f"roboticstoolbox-python {v['roboticstoolbox-python']}, eaik {v['eaik']}"
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
            {"n": n, "seeds": seeds, "notes": notes, "rows": [r.__dict__ for r in rows]},
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
