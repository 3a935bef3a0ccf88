"""The peer benchmark (``benchmarks/peers.py``) on a few targets: real TRAC-IK
(``pytracik``), IKPy, a plain mink loop, roboticstoolbox-python and EAIK on real arms
of example-robot-data, and our solvers by registry name, every answer checked by an
independent MuJoCo FK; dm_control in its own venv where that venv exists.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import SOLVERS, Chain
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.bench import make_targets

ROOT = Path(__file__).resolve().parents[1]
NO_VENV = ROOT / "benchmarks" / "no-such-venv" / "python"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def peers():
    return _load("peers")


@pytest.fixture(scope="module")
def libs(peers):
    return sys.modules["peer_libs"]  # imported by peers.py


def test_check_uses_its_own_fk_and_the_ranges(peers):
    """Answers at the joint values the targets came from pass; 0.01 rad off on one
    joint fails; a joint past its range end is not inside."""
    chain, checker = Chain(), Chain()
    rng = np.random.default_rng(3)
    qs = np.array([chain.random_q(rng) for _ in range(4)])

    targets = []
    for q in qs:
        p, R = chain.fk(q)
        targets.append(Target(p, mat_to_quat(R)))
    ok, inside = peers.check(checker, targets, qs)
    assert ok.all() and inside.all()
    off = qs.copy()
    off[:, 3] += 0.01
    ok, _ = peers.check(checker, targets, off)
    assert not ok.any()
    past = qs.copy()
    past[0, 0] = chain.upper[0] + 0.05
    _, inside = peers.check(checker, targets, past)
    assert inside.tolist() == [False, True, True, True]
    assert np.array_equal(checker.q, checker.q_home)  # left at home


def test_peers_on_the_bundled_arm(peers):
    """Four pose targets on the bundled right arm: every registered solver of ours (lm
    and auto included when registered), TRAC-IK with 50 ms, a plain mink loop, IKPy.
    Our solvers and TRAC-IK reach every target inside the ranges; every row has CPU
    and wall figures; the best of ours has ratio 1; the floor is a few microseconds."""
    pytest.importorskip("pytracik")
    pytest.importorskip("ikpy")
    rows, notes = peers.run(
        ["humanoid"],
        4,
        tasks=["pose"],
        peers=["trac_ik_50ms", "mink_plain", "ikpy"],
        dm_python=NO_VENV,
    )
    by = {r.who: r for r in rows}
    expected_ours = [s for s in peers.OURS if s == "solve_auto" or s in SOLVERS]
    assert [r.who for r in rows if r.ours] == expected_ours
    assert by["two_link"].skipped == "two_link solves position targets only"
    for who in [*expected_ours, "trac_ik_50ms"]:
        if who == "two_link":
            continue
        r = by[who]
        assert r.success == 1.0 and r.inside == 1.0, who
    for r in rows:
        if r.skipped:
            continue
        assert 0 < r.cpu_median_ms <= r.cpu_p95_ms and r.wall_median_ms > 0
        assert 0 <= r.inside <= r.success <= 1
    assert by["trac_ik_50ms"].mean_iterations is None  # TRAC-IK reports none
    assert by["dls"].mean_iterations >= 1 and by["mink_plain"].mean_iterations >= 1
    best = [r for r in rows if r.extra.get("our_best")]
    assert len(best) == 1 and best[0].ours and best[0].over_our_best == 1.0
    floor = by["dls"].extra["floor_us"]
    assert 0.1 < floor < 200
    assert by["dls"].per_iteration_over_floor == pytest.approx(
        by["dls"].cpu_per_iteration_us / floor
    )
    assert by["trac_ik_50ms"].extra["fk_gap"] < 1e-9 and by["ikpy"].extra["fk_gap"] < 1e-9
    text = peers.markdown(rows, peers.ARMS, "head")
    assert "| `trac_ik_50ms` | 100.0 % | 100.0 % |" in text
    assert f"| humanoid | {floor:.2f} |" in text  # the floor row shows the measured floor
    assert notes["versions"]["mujoco"] and notes["left_out"] == {}


def test_position_targets_and_what_is_left_out(peers):
    """Position targets: TRAC-IK is left out with its reason (pytracik solves poses);
    an arm from dm_control without the dm_control venv is left out with a note."""
    rows, notes = peers.run(
        ["humanoid", "jaco"],
        3,
        tasks=["position"],
        peers=["trac_ik_5ms"],
        ours=["dls"],
        dm_python=NO_VENV,
    )
    assert [(r.arm, r.who) for r in rows] == [("humanoid", "dls"), ("humanoid", "trac_ik_5ms")]
    assert rows[0].success == 1.0
    assert rows[1].skipped.startswith("pose targets only")
    assert notes["left_out"] == {"jaco": "dm_control venv missing (see docs/benchmarks.md)"}


@pytest.mark.slow
def test_dm_control_in_its_own_venv(peers):
    """Where the dm_control venv exists (docs/benchmarks.md): two pose targets on the
    Kinova Jaco it ships, solved by qpos_from_site_pose in that venv and checked here."""
    if not peers.DM_PYTHON.exists():
        pytest.skip("no dm_control venv at benchmarks/.venv-dm (docs/benchmarks.md)")
    rows, notes = peers.run(["jaco"], 2, tasks=["pose"], peers=["dm_control"], ours=["dls"])
    dm = rows[-1]
    assert dm.who == "dm_control" and dm.skipped is None
    assert dm.success == 1.0 and dm.mean_iterations >= 1
    assert math.isfinite(dm.cpu_median_ms) and dm.cpu_median_ms > 0
    # the same targets as ours, from the same start
    chain = peers.ARMS["jaco"].chain(peers.dm_package_dir(peers.DM_PYTHON))
    assert len(make_targets(chain, 2, 0, True)) == 2 and rows[0].success == 1.0


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["--models", "humanoid,nope"], "model 'nope' unknown; models: humanoid, robot, jaco"),
        (["--peers", "trac"], "peer 'trac' unknown; peers: trac_ik_5ms, trac_ik_50ms"),
        (["--tasks", "gaze"], "task 'gaze' unknown; tasks: position, pose"),
        (["--n", "0"], "--n must be >= 1, got 0"),
        (["--ours", "lm,fast"], "solver 'fast' unknown; solvers: closed_form, two_link"),
        (["--seeds", "0,x"], "--seeds takes comma-separated integers, got '0,x'"),
    ],
)
def test_bad_arguments_are_one_line(peers, capsys, argv, fragment):
    """A bad argument exits with status 2 and one line naming it and the valid choices,
    before anything runs."""
    with pytest.raises(SystemExit) as exc:
        peers.main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert fragment in err[-1] and "Traceback" not in "".join(err)


def test_a_failing_dm_control_run_is_a_note(peers, tmp_path):
    """A dm_control "venv" whose Python exits with an error leaves a note on the
    dm_control rows instead of stopping the run (here: a script that is not Python)."""
    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\necho 'no dm_control here' >&2\nexit 3\n")
    fake.chmod(0o755)
    results = peers.run_dm_control(fake, [{"arm": "humanoid", "task": "pose"}])
    assert results == {
        ("humanoid", "pose"): {"error": "dm_control run failed (exit 3): no dm_control here"}
    }


def test_libraries_run_interleaved(peers, libs):
    """Block by block, each library in turn: one untimed call on the first target, then
    the block's targets in order; every library answers every target, and each block
    has every library's turn."""
    calls: list[tuple[str, int]] = []

    def lib(name):
        return libs.PeerRun(
            lambda t: (calls.append((name, int(t.position[0]))), (t.position[:2], None))[1]
        )

    targets = [Target(np.array([float(i), 0.0, 0.0])) for i in range(5)]
    out = peers.interleaved({w: lib(w) for w in "abc"}, targets, 2, block=2)
    assert len(calls) == 3 * (3 + 5)  # three blocks (2, 2, 1 targets), one warm-up a turn
    blocks = [calls[0:9], calls[9:18], calls[18:24]]
    for blk, (lo, hi) in zip(blocks, [(0, 2), (2, 4), (4, 5)], strict=True):
        size = 1 + hi - lo
        by_turn = [blk[i : i + size] for i in range(0, len(blk), size)]
        assert sorted(t[0][0] for t in by_turn) == ["a", "b", "c"]
        for t in by_turn:
            assert [x[1] for x in t] == [0, *range(lo, hi)] and len({x[0] for x in t}) == 1
    for who, a in out.items():
        assert a.q[:, 0].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0], who
        assert a.cpu.shape == (5,) and a.iterations is None


def test_rtb_and_eaik_on_a_real_arm_two_seeds(peers):
    """Kinova (6 hinges, three unlimited, others off zero such as [0.82, 5.46]) from
    example-robot-data, three pose targets per seed, seeds 0 and 1: roboticstoolbox's
    ik_LM / ik_NR and EAIK agree with MuJoCo's FK to 1e-9 before timing; the tight
    ik_LM and EAIK with the 2 pi shift reach every target inside the ranges (checked by
    MuJoCo FK); EAIK answers with one call; the tables show both seeds."""
    pytest.importorskip("roboticstoolbox")
    pytest.importorskip("eaik")
    new = ["rtb_lm", "rtb_lm_tight", "rtb_nr_tight", "eaik", "eaik_raw"]
    rows, _ = peers.run(
        ["kinova"], 3, (0, 1), tasks=["pose"], peers=new, ours=["lm", "auto", "solve_auto"]
    )
    assert [(r.who, r.seed) for r in rows] == [
        (w, s) for s in (0, 1) for w in ["lm", "auto", "solve_auto", *new]
    ]
    by = {(r.who, r.seed): r for r in rows}
    for seed in (0, 1):
        for who in new:
            r = by[who, seed]
            assert r.skipped is None and 0 <= r.extra["fk_gap"] < 1e-9, (who, r.extra)
        for who in ["lm", "auto", "solve_auto", "rtb_lm_tight", "rtb_nr_tight", "eaik"]:
            assert by[who, seed].inside == 1.0, (who, seed)
        eaik = by["eaik", seed]
        assert eaik.mean_iterations == 1.0  # one analytic call per target
        assert 0 < eaik.extra["call_cpu_median_ms"] <= eaik.cpu_median_ms
        assert by["rtb_lm", seed].mean_iterations >= 1
    text = peers.markdown(rows, peers.ARMS, "head")
    assert "`kinova`, pose targets (each cell: seed 0 / seed 1):" in text
    assert "| `eaik` | 100.0 / 100.0 % | 100.0 / 100.0 % |" in text
    assert "| Kinova j2s6s200 (6 hinges, 3 unlimited), example-robot-data | 100.0 % |" in text
    assert "`eaik`: its own calls " in text


def test_eaik_shift_brings_answers_into_the_ranges(peers, libs):
    """EAIK gives angles in [-pi, pi]; Kinova's joint 2 has the range [0.82, 5.46], so
    4.0 rad comes back as 4.0 - 2 pi, outside it: the shift brings it back, the raw
    answer has none inside. On 20 Kinova pose targets every ``eaik`` answer is on
    target inside the ranges by MuJoCo's FK, and ``eaik_raw`` misses some."""
    pytest.importorskip("eaik")
    chain, checker = peers.real_chain("kinova", "arm"), peers.real_chain("kinova", "arm")
    lo, hi, start = chain.lower, chain.upper, chain.q_home
    Q = np.array([[0.5, 4.0 - 2 * math.pi, 2.0, -1.0, 2.5, 0.3]])
    assert libs.nearest_in_range(Q, start, lo, hi, shift=False) is None
    shifted = libs.nearest_in_range(Q, start, lo, hi, shift=True)
    assert shifted == pytest.approx([0.5, 4.0, 2.0, -1.0, 2.5, 0.3], abs=1e-12)
    targets = make_targets(chain, 20, 0, True)
    inside = {}
    for shift in (True, False):
        run = libs.setup_eaik(chain, shift, True)
        answers = np.array([run.solve(t)[0] for t in targets])
        ok, within = peers.check(checker, targets, answers)
        inside[shift] = int((ok & within).sum())
    assert inside[True] == 20 and inside[False] < 20, inside


def test_eaik_on_a_7_hinge_arm_locks_one_joint(peers, libs):
    """Talos's left arm (7 hinges): EAIK solves it with joint 1 locked, at the start's
    value first, then that value plus and minus 1, 2, ... steps. A pose reached with
    joint 1 at the start's value takes one call, one with joint 1 two steps above it at
    most four (start, +1, -1, +2); both answers are on target inside the ranges by
    MuJoCo's FK. G1's left arm has no lock EAIK knows: left out, with the reason."""
    pytest.importorskip("eaik")
    chain = peers.real_chain("talos", "left_arm")
    run = libs.setup_eaik(chain, True, True)
    assert run.notes["locked_joint"] == 0 and run.notes["lock_values"] > 10
    assert run.fk_gap < 1e-9
    s0 = float(np.clip(chain.q_home[0], chain.lower[0], chain.upper[0]))
    rng = np.random.default_rng(4)
    targets, most = [], []
    for lock, calls in ((s0, 1), (s0 + 2 * libs.LOCK_STEP, 4)):
        for _ in range(3):
            q = chain.random_q(rng)
            q[0] = lock
            p, R = chain.fk(q)
            targets.append(Target(p, mat_to_quat(R)))
            most.append(calls)
    chain.reset()
    solved = [run.solve(t) for t in targets]
    assert all(c <= m for (_, c), m in zip(solved, most, strict=True)), [c for _, c in solved]
    checker = peers.real_chain("talos", "left_arm")
    ok, inside = peers.check(checker, targets, np.array([q for q, _ in solved]))
    assert ok.all() and inside.all()
    g1 = libs.setup_eaik(peers.real_chain("g1", "left_arm"), True, True)
    assert g1 == "EAIK knows no decomposition of this arm, nor with any one joint locked"
