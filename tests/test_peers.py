"""The peer benchmark (``benchmarks/peers.py``) on a few targets: real TRAC-IK
(``pytracik``), IKPy, a plain mink loop and our solvers by registry name, every answer
checked by an independent MuJoCo FK; dm_control in its own venv where that venv exists.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import SOLVERS, Chain
from humanoid_ik.experiments.bench import make_targets

ROOT = Path(__file__).resolve().parents[1]
NO_VENV = ROOT / "benchmarks" / "no-such-venv" / "python"


@pytest.fixture(scope="module")
def peers():
    spec = importlib.util.spec_from_file_location("peers", ROOT / "benchmarks" / "peers.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["peers"] = module
    spec.loader.exec_module(module)
    return module


def test_check_uses_its_own_fk_and_the_ranges(peers):
    """Answers at the joint values the targets came from pass; 0.01 rad off on one
    joint fails; a joint past its range end is not inside."""
    chain, checker = Chain(), Chain()
    rng = np.random.default_rng(3)
    qs = np.array([chain.random_q(rng) for _ in range(4)])
    from humanoid_ik.core.rotations import mat_to_quat
    from humanoid_ik.core.types import Target

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
    expected_ours = [s for s in peers.OURS if s in SOLVERS]
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
    text = peers.markdown(rows, peers.ARMS, "head")
    assert "| humanoid | pose | `trac_ik_50ms` | 100.0 % | 100.0 % |" in text
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
