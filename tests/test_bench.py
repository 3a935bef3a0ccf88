"""The benchmark: rows per solver, skips with reasons, the JSON document."""

from __future__ import annotations

import json

import numpy as np
import pytest

from humanoid_ik import Chain, SolverError
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
    assert set(doc) == {"model", "site", "joints", "task", "n", "seed", "results"}
    assert set(doc["results"][0]) == {
        "solver",
        "success_rate",
        "median_ms",
        "p95_ms",
        "mean_iterations",
        "max_position_error_m",
        "limit_violations",
        "skipped",
    }
    assert doc["model"] == "m.xml" and doc["n"] == 5


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
    with pytest.raises(SolverError, match="solver 'fabrik' unknown; solvers: "):
        run_bench(chain, solvers=["fabrik"])
    with pytest.raises(SolverError, match="n must be an integer >= 1 and <= 1000000, got 0"):
        run_bench(chain, n=0)
    with pytest.raises(SolverError, match="n must be an integer >= 1 and <= 1000000, got 10000001"):
        run_bench(chain, n=10_000_001)
    with pytest.raises(SolverError, match="seed must be an integer >= 0, got -1"):
        run_bench(chain, n=2, seed=-1)
