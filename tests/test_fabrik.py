"""FABRIK: the two passes on points (lengths kept, base kept, a far target straightens
the chain), the fit of hinge angles to points, and the solver's success on the bundled
arm and on planar chains with joint ranges, never leaving a range."""

from __future__ import annotations

import math

import numpy as np
import pytest

from humanoid_ik import Chain, Target, make_solver
from humanoid_ik.errors import SolverError
from humanoid_ik.experiments.bench import make_targets, run_trials
from humanoid_ik.solvers.fabrik import FABRIK, FABRIKOptions, fit_angles, groups, passes
from tests.test_ccd import LIMITED, planar


def test_passes_keep_lengths_and_base():
    """One iteration: the base stays, every segment keeps its length, and repeated
    iterations put the end on a reachable target (a 3-segment polyline)."""
    p = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [2.5, 0, 0]])
    lengths = np.linalg.norm(np.diff(p, axis=0), axis=1)
    target = np.array([0.8, 1.1, 0.4])
    for _ in range(40):
        p = passes(p, target, lengths)
        np.testing.assert_allclose(p[0], 0.0, atol=0)
        np.testing.assert_allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), lengths, atol=1e-12)
    assert np.linalg.norm(p[-1] - target) < 1e-9


def test_passes_straighten_toward_a_far_target():
    """A target beyond the reach: the chain lies on the line from the base to it."""
    p = np.array([[0.0, 0, 0], [0.0, 1.0, 0], [1.0, 1.0, 0]])
    target = np.array([3.0, 4.0, 0.0])
    out = passes(p, target, np.array([1.0, 1.0]))
    np.testing.assert_allclose(out, [[0, 0, 0], [0.6, 0.8, 0], [1.2, 1.6, 0]], atol=1e-12)


def test_groups_of_the_bundled_arm():
    """The bundled arm: a 3-hinge shoulder, the elbow, a 3-hinge wrist: three points."""
    chain = Chain()
    chain.set_q(chain.q_home)
    assert groups(chain).tolist() == [0, 0, 0, 1, 2, 2, 2]


def test_fit_angles_reproduces_a_pose_from_its_points():
    """The points of an in-range pose: root-to-tip fits from another pose give that pose
    back (the first fit already within 0.2 rad, each later one closer)."""
    chain = planar(1.0, 0.6, "-2.5 2.5", "-2.5 2.5")
    want = np.array([0.7, -1.3])
    chain.set_q(want)
    goal = np.vstack([chain.data.xanchor[chain.joint_ids], chain.position])
    q = np.array([-1.0, 2.0])
    chain.set_q(q)
    misses = []
    for _ in range(20):
        fit_angles(chain, goal, groups(chain), q)
        misses.append(float(np.abs(q - want).max()))
    assert misses[0] < 0.2 and all(b <= a for a, b in zip(misses[:-1], misses[1:], strict=True))
    np.testing.assert_allclose(q, want, atol=1e-9)
    np.testing.assert_allclose(chain.position, goal[-1], atol=1e-9)


def test_fit_angles_stays_in_range():
    """Points that ask for an elbow past its range: the elbow stops at the range end."""
    chain = planar(1.0, 1.0, "-2 2", "0 1")
    chain.set_q([0.0, 0.0])  # straight
    goal = np.array([[0, 0, 0], [1.0, 0, 0], [1.0 + math.cos(-1.2), math.sin(-1.2), 0]])
    q = chain.q
    fit_angles(chain, goal, groups(chain), q)
    assert chain.within_limits(q, tol=0.0) and q[1] == 0.0


def test_bundled_arm_reaches_its_targets():
    """At least 99.5 % of 1000 FK-reachable targets of the bundled right arm within 1 mm,
    every answer inside the ranges."""
    chain = Chain()
    trials = run_trials(chain, make_solver("fabrik"), make_targets(chain, 1000, 0, False))
    assert trials.success.mean() >= 0.995, trials.success.mean()
    assert trials.inside.all()


@pytest.mark.parametrize(("l1", "l2", "r1", "r2"), LIMITED)
def test_limited_planar_chains(l1, l2, r1, r2):
    """At least 99.5 % of 1000 FK-reachable targets within 1 mm, joints in range (the
    chains of test_ccd.py, elbows that bend one way included)."""
    chain = planar(l1, l2, r1, r2)
    trials = run_trials(chain, make_solver("fabrik"), make_targets(chain, 1000, 0, False))
    assert trials.success.mean() >= 0.995, trials.success.mean()
    assert trials.inside.all()


def test_far_target_straightens_the_arm():
    """A target 3 m away from a 2 m arm: not converged, the arm straight toward it, the
    error the 1 m it lacks, the give-up message."""
    chain = planar(1.0, 1.0)
    target = 3.0 * np.array([math.cos(0.4), math.sin(0.4), 0.0])
    res = make_solver("fabrik", restarts=0).solve(chain, target, q0=[0.0, 0.5])
    assert not res.converged and res.message.startswith("no start of 1 converged")
    assert res.position_error == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(res.q, [0.4, 0.0], atol=1e-5)


def test_pattern_moves_reach_a_stretched_arm():
    """A target at 0.9995 of full reach: plain iterations crawl, pattern moves arrive."""
    chain = planar(1.7, 0.9, "-2.5 2.5", "-2.5 2.5")
    target = 0.9995 * 2.6 * np.array([math.cos(1.1), math.sin(1.1), 0.0])
    plain = make_solver("fabrik", pattern_moves=False, restarts=0).solve(chain, target)
    chain.reset()
    fast = make_solver("fabrik", restarts=0).solve(chain, target)
    assert fast.converged and fast.iterations < 60
    assert plain.iterations > fast.iterations
    assert np.linalg.norm(chain.fk(fast.q)[0] - target) < 1e-4


def test_a_restart_says_so():
    """An elbow that bends one way, five iterations a start: the run from q0 stalls
    0.52 m short, a seeded restart arrives, and the message names it."""
    chain = planar(1.0, 0.5, r1="-2 2", r2="0 2.5")
    solver = make_solver("fabrik", max_iterations=5, restarts=3)
    res = solver.solve(chain, np.array([1.2, -0.3, 0.0]), q0=[0.0, 0.0])
    assert res.converged and res.position_error < 1e-4
    assert res.q[1] == pytest.approx(math.acos(1.2**2 + 0.3**2 - 1.25), abs=1e-3)
    assert res.message.startswith("NOTE: this pose comes from restart 2 of 3 (a seeded")
    assert "whose run ended 0.519 m from the target" in res.message


def test_options_and_refusals():
    """Typed options with bounds; a pose target is refused in one line."""
    assert FABRIK().options == FABRIKOptions()
    assert make_solver("fabrik", max_iterations=5).options.max_iterations == 5
    with pytest.raises(SolverError, match="option 'restarts' of solver 'fabrik' must be an"):
        make_solver("fabrik", restarts=5000)
    with pytest.raises(SolverError, match="option 'nudge' unknown for solver 'fabrik'"):
        make_solver("fabrik", nudge=0.5)
    chain = Chain()
    with pytest.raises(SolverError, match="fabrik solves position targets only"):
        make_solver("fabrik").solve(chain, Target([0.3, -0.2, 1.1], [1.0, 0, 0, 0]))
