"""CCD: one joint's update (the lecture's worked example 2), the range rule, the
restarts rule and the solver's success on planar two-link chains with joint ranges."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, Target, make_solver
from humanoid_ik.errors import SolverError, TargetError
from humanoid_ik.experiments.bench import make_targets, run_trials
from humanoid_ik.solvers.ccd import CCD, CCDOptions, CCDStep, into_range, step

TOL = 1e-6
PD = np.array([1.0, 2.0, 0.0])  # the lecture's target


def planar(l1: float, l2: float, r1: str = "", r2: str = "", axis2: str = "0 0 1") -> Chain:
    """A planar two-link chain along x (hinges about z), ``r1``/``r2`` its ranges [rad]."""
    lim1 = f'range="{r1}" limited="true"' if r1 else ""
    lim2 = f'range="{r2}" limited="true"' if r2 else ""
    xml = f"""
<mujoco model="planar">
  <compiler angle="radian"/>
  <worldbody>
    <body name="link1">
      <joint name="j1" type="hinge" axis="0 0 1" {lim1}/>
      <geom type="capsule" fromto="0 0 0 {l1} 0 0" size="0.02"/>
      <body name="link2" pos="{l1} 0 0">
        <joint name="j2" type="hinge" axis="{axis2}" {lim2}/>
        <geom type="capsule" fromto="0 0 0 {l2} 0 0" size="0.02"/>
        <site name="tip" pos="{l2} 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
    return Chain(mujoco.MjModel.from_xml_string(xml), "tip")


@pytest.fixture()
def lecture() -> Chain:
    """The lecture's chain: p1 at the origin, p2 = (2, 0, 0), p3 = (3, 0, 0), at q = 0."""
    chain = planar(2.0, 1.0)
    chain.set_q([0.0, 0.0])
    return chain


# ------------------------------------------------------------------ step


def test_step_worked_example(lecture):
    """Worked example 2: joint 2 turns 116.5651 deg, then joint 1 33.4924 deg; p2, p3 as listed."""
    s2 = step(lecture, PD, "j2")
    assert isinstance(s2, CCDStep) and s2.joint == 1
    assert math.degrees(s2.phi) == pytest.approx(116.5651, abs=1e-4)
    assert s2.angle == pytest.approx(s2.phi, abs=1e-15)
    np.testing.assert_allclose(s2.axis, [0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(s2.position, [1.5527864, 0.8944272, 0.0], atol=TOL)
    np.testing.assert_allclose(s2.q, [0.0, s2.phi], atol=1e-15)
    assert np.linalg.norm(PD - s2.position) == pytest.approx(1.2360680, abs=TOL)

    s1 = step(lecture, PD, 0)
    assert s1.joint == 0
    assert math.degrees(s1.phi) == pytest.approx(33.4924, abs=1e-4)
    np.testing.assert_allclose(lecture.data.body("link2").xpos, [1.6679182, 1.1036525, 0], atol=TOL)
    np.testing.assert_allclose(s1.position, [0.8013920, 1.6027840, 0.0], atol=TOL)
    np.testing.assert_allclose(lecture.position, s1.position, atol=0)
    assert np.linalg.norm(PD - s1.position) == pytest.approx(0.4441010, abs=TOL)
    np.testing.assert_allclose(s1.q, lecture.q, atol=0)


def test_step_angle_is_the_lecture_formula(lecture):
    """phi = atan2(|r x e|, r.r + r.e) with r = p - a, e = p_d - p, for both joints."""
    for joint in (1, 0):
        a = lecture.data.xanchor[lecture.joint_ids[joint]].copy()
        p = lecture.position.copy()
        r, e = p - a, PD - p
        want = math.atan2(np.linalg.norm(np.cross(r, e)), r @ r + r @ e)
        assert step(lecture, PD, joint).phi == pytest.approx(want, abs=1e-12)


def test_step_nudge_turns_a_fraction(lecture):
    """With c = 0.1, joint 2 turns 11.65651 deg and p3 = p2 + (cos, sin) of that angle."""
    s = step(lecture, PD, 1, nudge=0.1)
    assert math.degrees(s.phi) == pytest.approx(116.5651, abs=1e-4)
    assert math.degrees(s.angle) == pytest.approx(11.65651, abs=1e-5)
    t = s.angle
    np.testing.assert_allclose(s.position, [2.0 + math.cos(t), math.sin(t), 0.0], atol=1e-12)


def test_step_on_a_tilted_hinge_is_the_best_turn():
    """A hinge not normal to r x e: the projected angle is the turn closest to the target."""
    chain = planar(1.0, 0.8, axis2="0 0.6 0.8")
    chain.set_q([0.3, 0.2])
    q_before = chain.q
    target = np.array([0.4, 0.9, 0.7])
    s = step(chain, target, "j2")
    d_step = np.linalg.norm(s.position - target)
    grid = q_before[1] + np.linspace(-math.pi, math.pi, 20001)
    dists = [np.linalg.norm(chain.fk([q_before[0], t])[0] - target) for t in grid]
    k = int(np.argmin(dists))
    assert d_step <= dists[k] + 1e-12
    assert s.angle == pytest.approx(grid[k] - q_before[1], abs=2 * math.pi / 20000)
    assert abs(s.angle) > 0.1  # a real turn, not a no-op


def test_steps_make_the_solvers_sweeps(lecture):
    """Three sweeps of step (joint 2, joint 1) give the solver's q with max_iterations=3."""
    for _ in range(3):
        for joint in (1, 0):
            s = step(lecture, PD, joint)
    res = make_solver("ccd", max_iterations=3, pattern_moves=False, tol=1e-12).solve(
        lecture, PD, q0=[0.0, 0.0]
    )
    np.testing.assert_allclose(res.q, s.q, atol=0)
    assert res.iterations == 3


def test_step_refuses_bad_input(lecture):
    """An unknown joint, a pose target, a bad nudge or a non-finite target raise."""
    with pytest.raises(SolverError, match="joint 'elbow' not in the chain; joints: j1, j2"):
        step(lecture, PD, "elbow")
    for bad in (2, -1, 1.0, True):
        with pytest.raises(SolverError, match=f"joint {bad!r} not in the chain; indices 0 to 1"):
            step(lecture, PD, bad)
    with pytest.raises(SolverError, match="ccd solves position targets only"):
        step(lecture, Target(PD, [1.0, 0.0, 0.0, 0.0]), 0)
    for nudge in (0.0, 1.5):
        with pytest.raises(SolverError, match="'nudge' of solver 'ccd' must be in \\(0, 1\\]"):
            step(lecture, PD, 0, nudge=nudge)
    with pytest.raises(TargetError, match="not finite"):
        step(lecture, [1.0, math.nan, 0.0], 0)
    np.testing.assert_allclose(lecture.q, [0.0, 0.0], atol=0)


# ------------------------------------------------------------------ ranges


def test_into_range_values():
    """In range: unchanged; else the same pose 2 pi away, or the end nearer on the circle."""
    assert into_range(1.0, -2.5, 2.5) == 1.0
    assert into_range(7.0, -math.inf, math.inf) == 7.0
    assert into_range(4.0, -2.5, 2.5) == pytest.approx(4.0 - 2 * math.pi, abs=1e-15)
    assert into_range(-4.0, -2.5, 2.5) == pytest.approx(2 * math.pi - 4.0, abs=1e-15)
    assert into_range(4.5, -4.0, 4.0) == pytest.approx(4.5 - 2 * math.pi, abs=1e-15)
    assert into_range(-9.0, -1.0, 1.0 + 2 * math.pi) == pytest.approx(-9.0 + 4 * math.pi)
    assert into_range(2.6, -2.5, 2.5) == 2.5  # just past the end: the end
    assert into_range(-3.5, -2.5, 2.5) == 2.5  # -3.5 is 0.28 from 2.5 on the circle
    assert into_range(3.8, -1.0, 1.0) == -1.0  # 1.48 from -1, 2.8 from 1


def test_step_takes_the_in_range_way_round():
    """A turn past the range end that is in range the other way round lands on the target."""
    chain = planar(2.0, 1.0, r2="-2.5 2.5")
    chain.set_q([0.0, 2.0])
    target = np.array([2.0, 0.0, 0.0]) + 0.5 * np.array([math.cos(4.0), math.sin(4.0), 0.0])
    s = step(chain, target, 1)
    assert s.phi == pytest.approx(2.0, abs=1e-12)
    assert s.q[1] == pytest.approx(4.0 - 2 * math.pi, abs=1e-12)
    assert s.angle == pytest.approx(2.0 - 2 * math.pi, abs=1e-12)
    assert np.linalg.norm(s.position - target) == pytest.approx(0.5, abs=1e-12)


def test_step_stops_at_the_nearer_range_end():
    """No in-range way round: the joint stops at the end nearer the best turn on the circle."""
    chain = planar(2.0, 1.0, r2="-1 1")
    chain.set_q([0.0, 0.8])
    target = np.array([2.0, 0.0, 0.0]) + 0.5 * np.array([math.cos(3.8), math.sin(3.8), 0.0])
    s = step(chain, target, 1)
    assert s.phi == pytest.approx(3.0, abs=1e-12) and s.q[1] == -1.0
    # tip and target on circles of radius 1 and 0.5 about the elbow: d^2 = 1.25 - cos(3.8 - a)
    d_lower = np.linalg.norm(s.position - target)
    d_upper = np.linalg.norm(chain.fk([0.0, 1.0])[0] - target)
    assert d_lower == pytest.approx(math.sqrt(1.25 - math.cos(4.8)), abs=1e-12)  # 1.0782
    assert d_upper == pytest.approx(math.sqrt(1.25 - math.cos(2.8)), abs=1e-12)  # 1.4806


# ------------------------------------------------------------------ restarts rule


def test_max_iterations_alone_means_no_restarts():
    """max_iterations without restarts gives restarts = 0; restarts given or defaults kept."""
    assert CCD().options.restarts == 10
    assert CCD(max_iterations=1).options.restarts == 0
    assert make_solver("ccd", max_iterations=50).options.restarts == 0
    assert CCD(max_iterations=50, restarts=3).options.restarts == 3
    assert CCD(restarts=4).options == CCDOptions(restarts=4)


def test_one_sweep_is_the_lectures_sweep(lecture):
    """max_iterations=1 alone: the lecture's one sweep from q0, no random restart."""
    res = make_solver("ccd", max_iterations=1).solve(lecture, PD, q0=[0.0, 0.0])
    assert math.degrees(res.q[1]) == pytest.approx(116.5651, abs=1e-4)
    assert math.degrees(res.q[0]) == pytest.approx(33.4924, abs=1e-4)
    assert res.position_error == pytest.approx(0.4441010, abs=TOL)
    assert res.iterations == 1 and res.status == "max_iterations"
    assert "no start of 1 converged" in res.message and "restart" not in res.message


TRAP_TARGET = np.array([1.2, -0.3, 0.0])


def trapped_chain() -> Chain:
    """Links 1 and 0.5, an elbow that bends one way only (range [0, 2.5]), at home q = 0."""
    return planar(1.0, 0.5, r1="-2 2", r2="0 2.5")


def test_trap_from_q0_is_a_straight_arm():
    """From q0 = 0 the elbow's range end keeps the arm straight: 1.5 - |p_d| = 0.2631 short."""
    chain = trapped_chain()
    res = make_solver("ccd", restarts=0).solve(chain, TRAP_TARGET)
    assert not res.converged
    np.testing.assert_allclose(res.q, [math.atan2(-0.3, 1.2), 0.0], atol=1e-9)
    assert res.position_error == pytest.approx(1.5 - math.hypot(1.2, 0.3), abs=1e-9)
    assert res.message.startswith("no start of 1 converged") and "NOTE" not in res.message


def test_result_from_a_restart_says_so():
    """A pose from a restart is converged and its message names the restart and q0's miss."""
    chain = trapped_chain()
    res = make_solver("ccd").solve(chain, TRAP_TARGET)
    assert res.converged and res.position_error < 1e-4
    # the elbow bent the one way its range allows: cos b = (|p_d|^2 - 1.25) / 1
    assert res.q[1] == pytest.approx(math.acos(1.2**2 + 0.3**2 - 1.25), abs=1e-3)
    assert res.message.startswith("NOTE: this pose comes from restart ")
    assert "of 10 (a seeded random in-range pose, seed 0), not from q0" in res.message
    assert "whose run ended 0.263 m from the target" in res.message


def test_unconverged_result_from_a_restart_says_so():
    """Out of sweeps on every start: the give-up message, then the restart note."""
    chain = trapped_chain()
    res = make_solver("ccd", max_iterations=5, restarts=2).solve(chain, TRAP_TARGET)
    assert not res.converged and res.position_error < 0.01
    assert res.message.startswith("no start of 3 converged")
    assert "; NOTE: this pose comes from restart 2 of 2" in res.message


def test_converged_from_q0_has_no_message(lecture):
    """A solve that converges from q0 leaves the message empty."""
    res = make_solver("ccd", tol=1e-9).solve(lecture, PD, q0=[0.0, 0.0])
    assert res.converged and res.message == ""
    np.testing.assert_allclose(lecture.fk(res.q)[0], PD, atol=1e-8)


# ------------------------------------------------------------------ robustness

LIMITED = [
    (1.0, 1.0, "-2.5 2.5", "-2.5 2.5"),
    (1.0, 0.5, "-2.5 2.5", "-2.5 2.5"),
    (1.2, 0.4, "-2.5 2.5", "-2.5 2.5"),
    (1.7, 0.9, "-2.5 2.5", "-2.5 2.5"),
    (1.0, 0.5, "-2 2", "-2.4 0.1"),
    (0.9, 0.3, "-1 1", "0 2.8"),
]


@pytest.mark.parametrize(("l1", "l2", "r1", "r2"), LIMITED)
def test_limited_planar_chains(l1, l2, r1, r2):
    """At least 99.5 % of 1000 FK-reachable targets within 1 mm, joints in range."""
    chain = planar(l1, l2, r1, r2)
    trials = run_trials(chain, make_solver("ccd"), make_targets(chain, 1000, 0, False))
    assert trials.success.mean() >= 0.995
    assert trials.inside.all()


def test_pattern_moves_reach_a_stretched_arm():
    """A target at 0.9995 of full reach: plain sweeps crawl, pattern moves arrive."""
    chain = planar(1.7, 0.9, "-2.5 2.5", "-2.5 2.5")
    target = 0.9995 * 2.6 * np.array([math.cos(1.1), math.sin(1.1), 0.0])
    plain = make_solver("ccd", pattern_moves=False).solve(chain, target)
    chain.reset()
    fast = make_solver("ccd").solve(chain, target)
    assert fast.converged and fast.message == "" and fast.iterations < 30
    assert not plain.converged and plain.position_error > 1e-3
    assert np.linalg.norm(chain.fk(fast.q)[0] - target) < 1e-4
