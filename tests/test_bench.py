"""The benchmark: rows per solver, skips with reasons, the JSON document."""

from __future__ import annotations

import json

import numpy as np
import pytest

from humanoid_ik import Chain, SolverError
from humanoid_ik.cli.app import main
from humanoid_ik.experiments.bench import make_targets, run_bench

from .chains import CCD_XML, model


def test_position_bench_on_humanoid():
    """Every reaching solver runs; look_at is skipped with its reason; dls reaches all."""
    report = run_bench(Chain(), "position", n=20, seed=3)
    rows = {r.solver: r for r in report.results}
    assert rows["look_at"].skipped and "does not move the site" in rows["look_at"].skipped
    for name in ("ccd", "jacobian_transpose", "pseudoinverse", "dls"):
        r = rows[name]
        assert r.skipped is None
        assert r.success_rate == 1.0
        assert r.limit_violations == 0
        assert r.max_position_error_m < 1e-3
        assert 0 < r.median_ms <= r.p95_ms
    assert report.joints[3] == "right_elbow_joint"


def test_pose_bench_skips_position_only_solvers():
    """For pose targets two_link and ccd are listed as skipped."""
    report = run_bench(Chain(), "pose", solvers=["two_link", "ccd", "dls"], n=10, seed=1)
    rows = {r.solver: r for r in report.results}
    assert rows["two_link"].skipped == "two_link solves position targets only"
    assert rows["ccd"].skipped == "ccd solves position targets only"
    assert rows["dls"].success_rate == 1.0


def test_bench_json_document(tmp_path):
    """to_dict has the documented keys and survives json."""
    report = run_bench(Chain(), "position", solvers=["dls"], n=5, seed=0, model_name="m.xml")
    doc = json.loads(json.dumps(report.to_dict()))
    assert set(doc) == {
        "model",
        "site",
        "effector",
        "joints",
        "task",
        "n",
        "seed",
        "results",
        "repeat",
    }
    assert set(doc["results"][0]) == {
        "solver",
        "success_rate",
        "median_ms",
        "p95_ms",
        "mean_iterations",
        "max_position_error_m",
        "limit_violations",
        "skipped",
        "cpu_median_ms",
        "cpu_p95_ms",
        "median_ms_range",
        "cpu_median_ms_range",
        "chosen",
    }
    assert doc["model"] == "m.xml" and doc["n"] == 5 and doc["repeat"] == 1
    assert doc["results"][0]["chosen"] == {"dls": 5}


def test_targets_are_seeded_and_reachable():
    """The same seed gives the same targets; each is FK of an in-range pose."""
    chain = Chain()
    a = make_targets(chain, 5, 9, pose=True)
    b = make_targets(chain, 5, 9, pose=True)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.position, y.position)
        np.testing.assert_array_equal(x.quat, y.quat)
    np.testing.assert_allclose(chain.q, chain.q_home)


def test_chain_without_arm_structure_skips_closed_form():
    """On a planar 2-link chain closed_form is skipped with the structural reason (two_link
    solves it in closed form since it handles planar shoulders)."""
    report = run_bench(Chain(model(CCD_XML), "p3"), "position", ["closed_form", "two_link"], n=3)
    skipped, solved = report.results
    assert "needs 7 hinges" in skipped.skipped and "the chain has 2 joint(s)" in skipped.skipped
    assert solved.skipped is None and solved.success_rate == 1.0


def test_bench_errors():
    """Unknown task and solver names and n < 1 are refused, naming the valid choices."""
    chain = Chain()
    with pytest.raises(SolverError, match="task 'orientation' unknown; tasks: pose, position"):
        run_bench(chain, "orientation")
    with pytest.raises(SolverError, match="solver 'nosuch' unknown; solvers: "):
        run_bench(chain, solvers=["nosuch"])
    with pytest.raises(SolverError, match="n must be an integer >= 1 and <= 1000000, got 0"):
        run_bench(chain, n=0)
    with pytest.raises(SolverError, match="n must be an integer >= 1 and <= 1000000, got 10000001"):
        run_bench(chain, n=10_000_001)
    with pytest.raises(SolverError, match="seed must be an integer >= 0, got -1"):
        run_bench(chain, n=2, seed=-1)
    with pytest.raises(SolverError, match="repeat must be an integer >= 1 and <= 100, got 0"):
        run_bench(chain, n=2, repeat=0)
    with pytest.raises(SolverError, match="repeat must be an integer >= 1 and <= 100, got 101"):
        run_bench(chain, n=2, repeat=101)
    with pytest.raises(
        SolverError, match="n \\* repeat must be at most 1000000, got 500000 \\* 3 = 1500000"
    ):
        run_bench(chain, n=500_000, repeat=3)


def test_cpu_time_and_repeat_spread():
    """Every row has CPU medians next to wall medians; with repeat 3 the reported median
    lies inside the spread of the three runs' medians, and success is that of one run."""
    report = run_bench(Chain(), "pose", solvers=["lm", "dls"], n=8, seed=4, repeat=3)
    assert report.repeat == 3
    for r in report.results:
        assert r.success_rate == 1.0 and r.limit_violations == 0
        lo, hi = r.median_ms_range
        assert 0 < lo <= r.median_ms <= hi
        c_lo, c_hi = r.cpu_median_ms_range
        assert 0 < c_lo <= r.cpu_median_ms <= c_hi
        assert r.cpu_p95_ms > 0
        assert r.chosen == {r.solver: 8}
    lines = report.table().splitlines()
    assert "cpu ms" in lines[0] and lines[0].count("(min-max)") == 2
    lo, hi = report.results[0].median_ms_range
    assert f"({lo:.3f}-{hi:.3f})" in lines[2]


def test_auto_row_records_its_choice():
    """The auto row counts the solvers that answered: closed_form on the bundled arm for
    pose targets (all of them), and the same success as closed_form."""
    report = run_bench(Chain(), "pose", solvers=["auto", "closed_form"], n=12, seed=5)
    auto, closed = report.results
    assert auto.chosen == {"closed_form": 12} and closed.chosen == {"closed_form": 12}
    assert auto.success_rate == closed.success_rate == 1.0
    assert "closed_form 12" in report.table().splitlines()[2]


def test_cli_bench_repeat(capsys):
    """`bench --repeat 2` prints the repeat and both spreads; --repeat 0 and 101 exit 2
    with the bound in one line."""
    code = main(["bench", "--solvers", "lm", "--n", "4", "--repeat", "2"])
    out = capsys.readouterr().out
    assert code == 0 and "repeat 2" in out.splitlines()[0]
    assert out.splitlines()[1].count("(min-max)") == 2
    for bad in ("0", "101"):
        code = main(["bench", "--solvers", "lm", "--n", "4", "--repeat", bad])
        err = capsys.readouterr().err
        assert code == 2 and "--repeat" in err and bad in err and len(err.splitlines()) == 1
