"""Awkward chains and targets: one joint, zero-length links, coincident axes, singular
starts, targets at the shoulder, on and beyond the boundary; property-based round trips."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from humanoid_ik import Chain, HumanoidIKError, Target, make_solver
from humanoid_ik.core.rotations import mat_to_quat

from .chains import model

ITERATIVE = ["ccd", "jacobian_transpose", "pseudoinverse", "dls"]
ALL_REACHING = ["two_link", *ITERATIVE]

ONE_JOINT_XML = """
<mujoco><worldbody><body><joint name="j" axis="0 0 1"/><geom size=".1"/>
  <site name="tip" pos="1 0 0"/></body></worldbody></mujoco>
"""

ZERO_LINK_XML = """
<mujoco><worldbody><body>
  <joint name="s1" axis="0 1 0"/><joint name="s2" axis="0 0 1"/><joint name="s3" axis="1 0 0"/>
  <geom size=".05"/>
  <body pos="0 0 0"><joint name="el" axis="0 0 1"/><geom type="capsule" fromto="0 0 0 1 0 0"
    size=".05"/><site name="tip" pos="1 0 0"/></body>
</body></worldbody></mujoco>
"""

COINCIDENT_XML = """
<mujoco><default><joint armature="0.01"/></default><worldbody><body>
  <joint name="a" axis="0 0 1"/><joint name="b" axis="0 0 1"/><geom size=".05"/>
  <body pos="1 0 0"><joint name="c" axis="0 0 1"/><geom size=".05"/>
    <site name="tip" pos="1 0 0"/></body>
</body></worldbody></mujoco>
"""


def _finite_result(chain, res):
    assert np.all(np.isfinite(res.q))
    assert math.isfinite(res.position_error)
    assert chain.within_limits(res.q)


@pytest.mark.parametrize("solver_name", ITERATIVE)
def test_one_joint_chain(solver_name):
    """A single hinge reaches points on its circle and reports the rest, without NaN."""
    chain = Chain(model(ONE_JOINT_XML), "tip")
    on_circle = make_solver(solver_name).solve(chain, [0.0, 1.0, 0.0])
    assert on_circle.converged
    assert on_circle.q[0] == pytest.approx(math.pi / 2, abs=1e-3)
    off = make_solver(solver_name, max_iterations=50, restarts=2).solve(chain, [0.0, 0.0, 1.0])
    _finite_result(chain, off)
    assert not off.converged and off.position_error == pytest.approx(math.sqrt(2), abs=1e-3)
    assert "3 shoulder hinges" in make_solver("two_link").applicable(chain)


@pytest.mark.parametrize("solver_name", ITERATIVE)
def test_zero_length_upper_arm(solver_name):
    """An upper arm of length zero: the iterative solvers reach the unit sphere, two_link
    explains why it cannot apply."""
    chain = Chain(model(ZERO_LINK_XML), "tip")
    res = make_solver(solver_name).solve(chain, [0.0, 0.6, 0.8])
    assert res.converged
    _finite_result(chain, res)
    assert "does not pass through the shoulder" in make_solver("two_link").applicable(chain)


@pytest.mark.parametrize("solver_name", ITERATIVE)
def test_coincident_axes(solver_name):
    """Two hinges on one axis (a rank-deficient Jacobian) still converge in the plane."""
    chain = Chain(model(COINCIDENT_XML), "tip")
    res = make_solver(solver_name).solve(chain, [0.5, 1.2, 0.0])
    assert res.converged
    _finite_result(chain, res)


@pytest.mark.parametrize("solver_name", ALL_REACHING)
@pytest.mark.parametrize("where", ["shoulder", "inner_hole", "boundary", "beyond", "far_beyond"])
def test_awkward_targets_never_raise_or_nan(solver_name, where):
    """At the shoulder, in the inner hole, on and beyond the boundary: a result, never NaN."""
    chain = Chain()
    shell = make_solver("two_link").shell(chain)
    shoulder = np.array([0.0, -0.19, 1.40])
    radius = {
        "shoulder": 0.0,
        "inner_hole": 0.5 * shell.r_min,
        "boundary": shell.r_max,
        "beyond": shell.r_max + 0.05,
        "far_beyond": 100.0,
    }[where]
    target = shoulder + radius * np.array([0.6, 0.0, -0.8])
    solver = make_solver(
        solver_name, **({} if solver_name == "two_link" else {"max_iterations": 60, "restarts": 2})
    )
    res = solver.solve(chain, target)
    _finite_result(chain, res)
    if where in ("shoulder", "inner_hole", "beyond", "far_beyond"):
        assert not res.converged
    if solver_name == "two_link":
        expected = "converged" if where == "boundary" else "unreachable"
        assert res.status == expected


@pytest.mark.parametrize("solver_name", ["ccd", "jacobian_transpose", "pseudoinverse", "dls"])
def test_singular_start_elbow_locked(solver_name):
    """From a straight arm with the elbow at its range end the solvers still converge."""
    chain = Chain()
    q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    p, _ = chain.fk([1.2, 0.4, 0.3, 0.9, 0.0, 0.0, 0.0])
    res = make_solver(solver_name).solve(chain, p, q0=q0)
    assert res.converged
    _finite_result(chain, res)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(st.floats(0.0, 1.0), min_size=7, max_size=7),
    st.sampled_from(["pseudoinverse", "dls"]),
)
def test_property_pose_round_trip(fractions, solver_name):
    """For any pose inside the ranges, FK(IK(FK(q))) matches FK(q) to 1 mm and 0.01 rad,
    given enough seeded restarts (200) for the rare targets in a small basin."""
    chain = _ARM
    q = chain.lower + np.array(fractions) * (chain.upper - chain.lower)
    p, R = chain.fk(q)
    chain.reset()
    res = make_solver(solver_name, restarts=200).solve(chain, Target(p, mat_to_quat(R)))
    assert res.position_error < 1e-3 and res.orientation_error < 1e-2
    assert chain.within_limits(res.q)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3))
def test_property_two_link_round_trip(fractions):
    """For any in-range shoulder and elbow (wrist at home), two_link is exact to 1e-7 m
    (at the straight elbow, acos near -1 costs about 1e-8)."""
    chain = _ARM
    q = chain.q_home.copy()
    f = np.array(fractions)
    q[[0, 1, 3]] = chain.lower[[0, 1, 3]] + f * (chain.upper[[0, 1, 3]] - chain.lower[[0, 1, 3]])
    p, _ = chain.fk(q)
    chain.reset()
    res = make_solver("two_link").solve(chain, p)
    assert res.position_error < 1e-7
    assert chain.within_limits(res.q)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5)),
        min_size=0,
        max_size=5,
    )
)
def test_property_bad_targets_end_in_package_errors(values):
    """Any list of numbers as a target either solves or raises the package's own error."""
    chain = _ARM
    try:
        res = make_solver("dls", max_iterations=20, restarts=0).solve(chain, values)
    except HumanoidIKError:
        return
    assert np.all(np.isfinite(res.q))


_ARM = Chain()


@pytest.mark.slow
def test_long_tracking_run_stays_bounded():
    """3000 warm-started steps of a target that leaves reach and returns: no NaN, inside
    the ranges, reachable targets within 1 mm, Python heap flat after warm-up."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "long_run.py"
    spec = importlib.util.spec_from_file_location("long_run", path)
    long_run = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(long_run)
    r = long_run.run(3000, "dls", heap=True, restarts=3)
    assert r["nan"] == 0 and r["limit_violations"] == 0
    assert r["worst_reachable_error_m"] < 1e-3
    assert r["heap_kib_end"] - r["heap_kib_after_1000"] < 64.0
