"""Elbow pole targets (``Target.pole``): the exact solvers put the elbow in the plane of
the shoulder, the wrist and the pole; the iterative ones turn it toward it; the others
say they ignore it. Every angle is measured here from MuJoCo's own kinematics of the
answer (axes and anchors of a fresh ``MjData``), not with the package's helpers."""

from __future__ import annotations

import math
import warnings
from functools import cache

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, Target, TargetError, make_solver
from humanoid_ik.core.limbs import find_limbs, limb_chain
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import axes_meeting_point, mat_to_quat
from tests.robots import robot_file

ONE_DEGREE = math.radians(1.0)


@cache
def _real(name: str, limb: str) -> Chain:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a home pose outside the ranges (HomeWarning)
        model = load_model(str(robot_file(name)))
    return limb_chain(Robot(model), limb, profile=find_limbs(model))


ARMS = {
    "bundled": Chain,
    "romeo": lambda: _real("romeo", "left_arm"),
    "icub": lambda: _real("icub", "right_arm"),
}


def _points(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shoulder (shoulder axes' meeting point), elbow (elbow hinge anchor) and wrist
    (wrist axes' meeting point) of a 7-hinge arm at ``q``, by MuJoCo FK on new data."""
    m = chain.model
    d = mujoco.MjData(m)
    d.qpos[:] = chain.data.qpos
    d.qpos[chain.qpos_adr] = q
    mujoco.mj_kinematics(m, d)
    ids = chain.joint_ids
    S = axes_meeting_point(d.xanchor[ids[:3]], d.xaxis[ids[:3]], tol=1e-7)
    W = axes_meeting_point(d.xanchor[ids[4:]], d.xaxis[ids[4:]], tol=1e-7)
    assert S is not None and W is not None
    return S, d.xanchor[ids[3]].copy(), W


def _angle(points, pole) -> float:
    """The angle between the half-planes (shoulder, wrist, elbow) and (shoulder, wrist,
    pole) about the shoulder-wrist line."""
    S, E, W = points
    u = (W - S) / np.linalg.norm(W - S)
    a = (E - S) - ((E - S) @ u) * u
    b = (pole - S) - ((pole - S) @ u) * u
    return math.atan2(np.linalg.norm(np.cross(a, b)), a @ b)


def _cases(chain: Chain, n: int, seed: int):
    """``n`` (posture, pole, start): the pole on the elbow's side of a random in-range
    posture, off the elbow along its plane (so poles lie on every side of the arm);
    the start is home with the posture's wrist (a position target holds the wrist)."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = chain.random_q(rng)
        S, E, W = _points(chain, q)
        u = (W - S) / np.linalg.norm(W - S)
        pole = E + rng.uniform(0.2, 1.0) * (E - S) + rng.uniform(-0.3, 0.3) * u
        q0 = chain.clip(chain.q_home).copy()
        q0[4:] = q[4:]
        yield q, pole, q0


@pytest.mark.parametrize("arm", list(ARMS))
@pytest.mark.parametrize(
    ("solver", "pose"), [("closed_form", True), ("closed_form", False), ("two_link", False)]
)
def test_exact_solvers_put_the_elbow_in_the_poles_plane(arm, solver, pose):
    """Where the ranges allow (the posture the pole was taken from is in range), the
    elbow is within 1 degree of the pole's plane, on its side, and the end on target
    to 1e-6 m; the details report the same angle."""
    chain = ARMS[arm]()
    s = make_solver(solver)
    worst = 0.0
    for q, pole, q0 in _cases(chain, 40, seed=3):
        p, R = chain.fk(q)
        res = s.solve(chain, Target(p, mat_to_quat(R) if pose else None, pole=pole), q0)
        assert res.converged, res.message
        got, _ = chain.fk(res.q)
        assert np.linalg.norm(got - p) < 1e-6
        assert chain.within_limits(res.q, tol=1e-9)
        err = _angle(_points(chain, res.q), pole)
        assert err < ONE_DEGREE, (res.details, q)
        assert res.details["pole"] == "honoured"
        assert abs(res.details["pole_error"] - err) < 1e-6
        worst = max(worst, err)
    assert worst < 1e-6  # exact, not merely within a degree


@pytest.mark.parametrize("solver", ["closed_form", "two_link"])
def test_a_pole_that_agrees_changes_nothing(solver):
    """A pole already in the plane of the answer found without it gives that answer."""
    chain = Chain()
    s = make_solver(solver)
    rng = np.random.default_rng(8)
    for _ in range(20):
        p, _ = chain.fk(chain.random_q(rng))
        chain.reset()
        free = s.solve(chain, Target(p))
        S, E, W = _points(chain, free.q)
        chain.reset()
        res = s.solve(chain, Target(p, pole=E + 0.5 * (E - S)))
        assert np.allclose(res.q, free.q, atol=1e-9)
        assert res.details["pole_error"] < 1e-9


def test_poles_on_opposite_sides_turn_the_elbow():
    """The same pose with the pole above, below, ahead and behind the arm: four elbow
    positions, each in its pole's plane, or the nearest feasible swivel, said so."""
    chain = Chain()
    s = make_solver("closed_form")
    p, R = chain.fk(np.array([0.6, 0.4, 0.2, 1.2, 0.1, 0.2, 0.0]))
    S, _, _ = _points(chain, chain.q)
    elbows, said = [], set()
    for side in ([0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0]):
        chain.reset()
        pole = S + np.array(side, dtype=float)
        res = s.solve(chain, Target(p, mat_to_quat(R), pole=pole))
        assert res.converged
        err = _angle(_points(chain, res.q), pole)
        said.add(res.details["pole"])
        if res.details["pole"] == "honoured":
            assert err < 1e-6
        else:
            assert res.details["pole"] == "nearest feasible swivel (joint ranges)"
            assert err > 1e-6
        elbows.append(_points(chain, res.q)[1])
    spread = max(np.linalg.norm(a - b) for a in elbows for b in elbows)
    assert spread > 0.1  # the elbow moved by more than 10 cm between the poles
    assert "honoured" in said


@pytest.mark.parametrize("arm", ["bundled", "romeo"])
@pytest.mark.parametrize("solver", ["lm", "dls", "mink"])
def test_iterative_solvers_turn_the_elbow_toward_the_pole(arm, solver):
    """lm and dls (null-space steps after convergence) and mink (a low-weight task)
    bring the elbow nearer the pole's plane than without a pole, the hand still on
    target; on pose targets of these 7-hinge arms the median is under 1 degree."""
    chain = ARMS[arm]()
    s = make_solver(solver)
    without, with_pole = [], []
    for q, pole, _ in _cases(chain, 16, seed=4):
        p, R = chain.fk(q)
        start = chain.clip(chain.q_home)
        free = s.solve(chain, Target(p, mat_to_quat(R)), start)
        res = s.solve(chain, Target(p, mat_to_quat(R), pole=pole), start)
        if not (free.converged and res.converged):
            continue
        assert np.linalg.norm(chain.fk(res.q)[0] - p) < s.options.tol
        without.append(_angle(_points(chain, free.q), pole))
        with_pole.append(_angle(_points(chain, res.q), pole))
        assert "pole_error" in res.details
    assert len(with_pole) >= 12
    assert np.median(with_pole) < ONE_DEGREE < np.median(without)


@pytest.mark.parametrize("solver", ["ccd", "pseudoinverse", "jacobian_transpose"])
def test_other_solvers_say_they_ignore_a_pole(solver):
    chain = Chain()
    p, _ = chain.fk(chain.random_q(np.random.default_rng(1)))
    res = make_solver(solver).solve(chain, Target(p, pole=[0.0, 0.0, 0.0]))
    assert res.details["pole"] == "ignored"
    assert "pole" not in make_solver(solver).solve(chain, Target(p)).details


def test_bad_poles_are_refused_and_motions_stay_fast():
    with pytest.raises(TargetError, match=r"elbow pole \[nan, 0.0, 0.0\] is not finite"):
        Target([0.3, 0.0, 1.0], pole=[math.nan, 0.0, 0.0])
    with pytest.raises(TargetError, match="elbow pole must have 3 values"):
        Target([0.3, 0.0, 1.0], pole=[1.0, 2.0])
    t = Target([0.3, 0.0, 1.0], pole=[0.0, -1.0, 1.0])
    assert t.pole is not None and not t.pole.flags.writeable
    assert Target.of(t, [1.0, 0.0, 0.0, 0.0]).pole.tolist() == [0.0, -1.0, 1.0]
    fast = Target.from_motion(np.array([0.3, 0.0, 1.0]))
    assert fast.pole is None
    assert Target.from_motion(np.array([0.3, 0.0, 1.0]), pole=np.ones(3)).pole.tolist() == [1.0] * 3
