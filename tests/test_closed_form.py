"""The closed-form 7-DOF arm solver: exact poses, branches, swivel intervals, batch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from humanoid_ik import Chain, SolverError, Target, TargetError, make_solver
from humanoid_ik.cli import main
from humanoid_ik.core.rotations import axes_meeting_point, mat_to_quat, rotation_log
from humanoid_ik.experiments.bench import run_bench
from humanoid_ik.solvers.analytic.closed_form import (
    ClosedForm,
    arm_geometry,
    geometry,
    solutions,
    solve_batch,
    structure_problem,
    swivel_angle,
    swivel_intervals,
)
from humanoid_ik.solvers.analytic.closed_form.geometry import arm_cache, arm_context
from humanoid_ik.solvers.analytic.closed_form.numeric import ARRAYS, FLOATS
from humanoid_ik.solvers.analytic.closed_form.single import Fallback, solve_one
from humanoid_ik.solvers.analytic.closed_form.swivel import decompose, feasible

from .chains import CCD_XML, SMALL_ARM_XML, model

# A 7-hinge arm nobody wrote for the humanoid: other lengths (0.37 / 0.29), an elbow
# offset along its axis (0.04) and off the forearm line (0.03), tilted and negative axes,
# every body frame rotated away from the world, and a tool site off every axis.
ARM_XML = """
<mujoco model="other_arm">
  <compiler angle="radian" autolimits="true"/>
  <worldbody>
    <body name="base" pos="0.2 0.1 0.5" euler="0.4 -0.3 0.7">
      <geom type="box" size="0.05 0.05 0.05"/>
      <body name="upper" pos="0 0 0.1" quat="0.9 0.1 -0.3 0.2">
        <joint name="s1" axis="0 0 1" range="-2.6 2.6"/>
        <joint name="s2" axis="0 1 0" range="-1.9 1.7"/>
        <joint name="s3" axis="0.6 0 0.8" range="-2.2 2.0"/>
        <geom type="capsule" fromto="0 0 0 0.37 0 0" size="0.03"/>
        <body name="fore" pos="0.37 0 0.04">
          <joint name="el" axis="0 0 1" range="-2.5 -0.05"/>
          <geom type="capsule" fromto="0 0 0 0.29 0.03 0" size="0.025"/>
          <body name="hand" pos="0.29 0.03 0" euler="0.2 0.1 -0.3">
            <joint name="w1" axis="1 0 0" range="-2.4 2.4"/>
            <joint name="w2" axis="0 0 -1" range="-1.3 1.1"/>
            <joint name="w3" axis="0 1 0" range="-0.9 1.2"/>
            <geom type="box" pos="0.04 0 0" size="0.03 0.02 0.01"/>
            <site name="tool" pos="0.06 0.01 0.02"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
# The same arm with a wrist whose middle axis leans 17 degrees off the first: the wrist
# cannot reach every rotation, so the swivel circle has stretches where it cannot decompose.
SKEW_XML = ARM_XML.replace('axis="0 0 -1" range="-1.3 1.1"', 'axis="0.3 0 -1" range="-1.3 1.1"')
# Shoulder axes that miss each other by 5 cm, and a wrist whose axes miss each other.
NO_SHOULDER_XML = ARM_XML.replace('<joint name="s2" axis', '<joint name="s2" pos="0.05 0 0" axis')
NO_WRIST_XML = ARM_XML.replace('<joint name="w3" axis', '<joint name="w3" pos="0.02 0 0" axis')

ARMS = {
    "right": lambda: Chain(),
    "left": lambda: Chain(None, "left_palm_site"),
    "other": lambda: Chain(model(ARM_XML), "tool"),
}
PSI = np.linspace(-math.pi, math.pi, 3600, endpoint=False)


def _poses(chain: Chain, n: int, seed: int) -> tuple[list[Target], np.ndarray]:
    """Pose targets at FK of seeded random in-range joint vectors, and those vectors."""
    rng = np.random.default_rng(seed)
    qs = np.array([chain.random_q(rng) for _ in range(n)])
    targets = []
    for q in qs:
        p, R = chain.fk(q)
        targets.append(Target(p, mat_to_quat(R)))
    chain.reset()
    return targets, qs


def _pose_error(checker: Chain, q: np.ndarray, target: Target) -> tuple[float, float]:
    p, R = checker.fk(q)
    return float(np.linalg.norm(p - target.position)), float(
        np.linalg.norm(rotation_log(target.rotation @ R.T))
    )


def _sampled(chain: Chain, target: Target) -> np.ndarray:
    """Brute force: at each of 3600 swivels, does some branch keep every joint in range?"""
    feasible = np.zeros(PSI.size, dtype=bool)
    for b in solutions(chain, target, PSI):
        if b.valid:
            assert chain.within_limits(b.q)
            feasible[np.searchsorted(PSI, b.swivel)] = True
    return feasible


def _inside(intervals, psi: np.ndarray, margin: float = 0.0) -> np.ndarray:
    out = np.zeros(psi.shape, dtype=bool)
    for iv in intervals:
        for shift in (-2 * math.pi, 0.0, 2 * math.pi):
            out |= (psi + shift >= iv.start - margin) & (psi + shift <= iv.end + margin)
    return out


def _near_end(intervals, psi: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    out = np.zeros(psi.shape, dtype=bool)
    for iv in intervals:
        for shift in (-2 * math.pi, 0.0, 2 * math.pi):
            out |= (np.abs(psi + shift - iv.start) < tol) | (np.abs(psi + shift - iv.end) < tol)
    return out


# ----------------------------------------------------------------------------- exactness
@pytest.mark.parametrize("arm", list(ARMS))
def test_round_trip_1000_poses(arm):
    """FK(closed_form(x)) = x to 1e-9 m and 1e-9 rad on 1000 random poses, inside the ranges."""
    chain = ARMS[arm]()
    checker = Chain(chain.model, chain.ee_name)
    targets, _ = _poses(chain, 1000, seed=21)
    solver = make_solver("closed_form")
    for tgt in targets:
        chain.reset()
        res = solver.solve(chain, tgt)
        assert res.status == "converged", res.message
        assert chain.within_limits(res.q)
        ep, er = _pose_error(checker, res.q, tgt)
        assert ep < 1e-9 and er < 1e-9
        assert res.position_error == pytest.approx(ep, abs=1e-12)


def test_round_trip_skewed_wrist():
    """A wrist that cannot reach every rotation: 200 random poses still exact and in range."""
    chain = Chain(model(SKEW_XML), "tool")
    checker = Chain(chain.model, "tool")
    targets, _ = _poses(chain, 200, seed=22)
    for tgt in targets:
        chain.reset()
        res = ClosedForm().solve(chain, tgt)
        assert res.converged and chain.within_limits(res.q)
        ep, er = _pose_error(checker, res.q, tgt)
        assert ep < 1e-9 and er < 1e-9


@pytest.mark.parametrize("arm", ["right", "other"])
def test_recovers_the_posture_at_its_swivel(arm):
    """With the swivel of q preferred and q as start, the solver returns q itself."""
    chain = ARMS[arm]()
    targets, qs = _poses(chain, 200, seed=23)
    for tgt, q in zip(targets, qs, strict=True):
        res = ClosedForm(swivel=swivel_angle(chain, q)).solve(chain, tgt, q0=q)
        np.testing.assert_allclose(res.q, q, atol=1e-8)


def test_gimbal_lock_shoulder():
    """Abduction at pi/2 aligns the outer shoulder axes: the pose is still exact, in range."""
    chain = Chain()
    q = np.array([0.4, math.pi / 2, -0.6, 1.0, 0.2, 0.1, 0.1])
    p, R = chain.fk(q)
    tgt = Target(p, mat_to_quat(R))
    for q0 in (chain.q_home, q):
        res = ClosedForm(swivel=swivel_angle(chain, q)).solve(chain, tgt, q0=q0)
        assert res.converged and chain.within_limits(res.q)
        assert res.position_error < 1e-12 and res.orientation_error < 1e-12
    np.testing.assert_allclose(res.q, q, atol=1e-12)


def test_position_targets_keep_the_wrist():
    """A position target: the wrist keeps its start angles, the palm lands within 1e-9 m."""
    chain = Chain()
    rng = np.random.default_rng(24)
    for _ in range(200):
        q = chain.random_q(rng)
        q[4:] = chain.q_home[4:]
        p, _ = chain.fk(q)
        chain.reset()
        res = ClosedForm().solve(chain, p)
        assert res.converged and res.orientation_error is None
        assert res.position_error < 1e-9 and chain.within_limits(res.q)
        np.testing.assert_array_equal(res.q[4:], chain.q_home[4:])


def test_geometry_is_read_from_mujoco():
    """Shoulder and wrist points are the model's sites; the palm is 0.08 m past the wrist."""
    chain = Chain()
    geo = arm_geometry(chain)
    data = chain.data
    chain.set_q(np.zeros(7))
    np.testing.assert_allclose(geo.shoulder, data.site("right_shoulder_site").xpos, atol=1e-12)
    np.testing.assert_allclose(geo.elbow, data.site("right_elbow_site").xpos, atol=1e-12)
    np.testing.assert_allclose(geo.wrist, data.site("right_wrist_site").xpos, atol=1e-12)
    assert np.linalg.norm(geo.hand_offset) == pytest.approx(0.08, abs=1e-12)
    np.testing.assert_allclose(geo.down, [0.0, 0.0, -1.0])


def test_geometry_follows_a_moving_base():
    """Joints off the chain that move the arm (a free base) refresh the cached geometry."""
    chain = Chain(model(SMALL_ARM_XML), "tip")
    checker = Chain(chain.model, "tip")
    solver = ClosedForm()
    for shift in (0.0, 0.3):
        chain.data.qpos[chain.model.joint("float").qposadr[0]] += shift
        checker.data.qpos[:] = chain.data.qpos
        q = np.array([0.3, -0.4, 0.5, -1.0, 0.2, 0.3, -0.2])
        p, R = checker.fk(q)
        tgt = Target(p, mat_to_quat(R))
        res = solver.solve(chain, tgt)
        assert res.converged
        assert _pose_error(checker, res.q, tgt)[0] < 1e-9


# ----------------------------------------------------------------------------- branches
@pytest.mark.parametrize("arm", ["right", "other"])
def test_every_branch_reaches_the_pose(arm):
    """Every branch at any swivel reaches the pose; the ones called valid are in range."""
    chain = ARMS[arm]()
    checker = Chain(chain.model, chain.ee_name)
    targets, qs = _poses(chain, 30, seed=25)
    rng = np.random.default_rng(26)
    counts = []
    for tgt, q in zip(targets, qs, strict=True):
        psi = np.append(rng.uniform(-math.pi, math.pi, 3), swivel_angle(chain, q))
        branches = solutions(chain, tgt, psi)
        counts.append(len(branches))
        for b in branches:
            ep, er = _pose_error(checker, b.q, tgt)
            assert ep < 1e-9 and er < 1e-9
            assert b.valid == chain.within_limits(b.q)
        # the generating posture is one of the branches at its own swivel
        at_q = [b.q for b in branches if b.swivel == psi[-1]]
        gap = [np.max(np.abs(np.remainder(b - q + math.pi, 2 * math.pi) - math.pi)) for b in at_q]
        assert min(gap) < 1e-8
    assert max(counts) == 4 * 8 or max(counts) == 4 * 4  # 2 (or 1) elbows x 2 x 2 per swivel


def test_position_branches():
    """A position target has up to four branches per swivel, all on the target."""
    chain = Chain()
    p, _ = chain.fk([0.5, 0.3, 0.2, 1.1, *chain.q_home[4:]])
    chain.reset()
    branches = solutions(chain, p, 0.4)
    assert 1 <= len(branches) <= 4
    for b in branches:
        assert np.linalg.norm(chain.fk(b.q)[0] - p) < 1e-9


# ----------------------------------------------------------------------------- intervals
@pytest.mark.parametrize("xml_name", ["right", "other", "skew"])
def test_swivel_intervals_match_sampling(xml_name):
    """Intervals agree with 3600 brute-force swivel samples; each end puts a joint on a limit."""
    if xml_name == "skew":
        chain = Chain(model(SKEW_XML), "tool")
    else:
        chain = ARMS[xml_name]()
    targets, _ = _poses(chain, 8, seed=27)
    for tgt in targets:
        intervals = swivel_intervals(chain, tgt)
        assert intervals  # the generating posture is feasible
        sampled = _sampled(chain, tgt)
        inside = _inside(intervals, PSI)
        mismatch = (sampled != inside) & ~_near_end(intervals, PSI)
        assert not mismatch.any(), PSI[mismatch]
        for iv in intervals:
            assert -math.pi <= iv.start <= iv.end <= iv.start + 2 * math.pi
            if iv.end - iv.start >= 2 * math.pi - 1e-12:
                continue
            for end in (iv.start, iv.end):
                margins = [
                    min(np.min(b.q - chain.lower), np.min(chain.upper - b.q))
                    for b in solutions(chain, tgt, end)
                    if b.valid and b.elbow == iv.elbow
                ]
                assert margins and min(abs(m) for m in margins) < 1e-9


def test_solution_takes_the_closest_feasible_swivel():
    """The solved swivel is the preferred one when feasible, else the nearest interval end."""
    chain = Chain()
    targets, _ = _poses(chain, 40, seed=28)
    rng = np.random.default_rng(29)
    hits_end = 0
    for tgt in targets:
        intervals = swivel_intervals(chain, tgt)
        preferred = float(rng.uniform(-math.pi, math.pi))
        res = ClosedForm(swivel=preferred).solve(chain, tgt)
        got = swivel_angle(chain, res.q)
        if _inside(intervals, np.array([preferred]))[0]:
            assert got == pytest.approx(preferred, abs=1e-9)
            continue
        ends = np.array([e for iv in intervals for e in (iv.start, iv.end)])
        gaps = np.abs(np.remainder(ends - preferred + math.pi, 2 * math.pi) - math.pi)
        nearest = ends[np.argmin(gaps)]
        assert abs(math.remainder(got - nearest, 2 * math.pi)) < 1e-9
        hits_end += 1
    assert hits_end >= 10


# ----------------------------------------------------------------------------- batch
@pytest.mark.parametrize("arm", ["right", "other"])
def test_batch_equals_single(arm):
    """solve_batch on 1000 poses gives the single-target joints (start: the chain's q)."""
    chain = ARMS[arm]()
    targets, _ = _poses(chain, 1000, seed=30)
    P = np.array([t.position for t in targets])
    Q = np.array([t.quat for t in targets])
    q, ok = solve_batch(chain, P, Q)
    assert ok.all() and np.all(np.isfinite(q))
    solver = ClosedForm()
    for i in range(0, 1000, 7):
        chain.reset()
        np.testing.assert_allclose(solver.solve(chain, targets[i]).q, q[i], atol=1e-9)


def test_batch_position_and_options():
    """Batch position targets, a per-target swivel and start: the same as one at a time."""
    chain = Chain()
    rng = np.random.default_rng(31)
    qs = np.array([chain.random_q(rng) for _ in range(50)])
    qs[:, 4:] = chain.q_home[4:]
    P = np.array([chain.fk(q)[0] for q in qs])
    psi = rng.uniform(-math.pi, math.pi, 50)
    q, ok = solve_batch(chain, P, q0=qs, swivel=psi)
    for i in range(50):
        res = ClosedForm(swivel=float(psi[i])).solve(chain, P[i], q0=qs[i])
        assert ok[i] == res.converged
        np.testing.assert_allclose(res.q, q[i], atol=1e-9)


def _one(chain: Chain, target: Target, q0: np.ndarray, swivel: float | None = None):
    """The single-target (float) path on its own, without the solver around it."""
    rot = None if target.rotation is None else target.rotation.tolist()
    q, _ = solve_one(arm_context(chain), target.position.tolist(), rot, q0.tolist(), swivel)
    return np.array(q)


@pytest.mark.parametrize("arm", ["right", "other", "skew"])
def test_single_and_batch_paths_agree(arm):
    """The float path and the vectorised path give the same joints (1e-9) on random
    poses and positions, random starts and random preferred swivels; the float path
    answers every one of them itself (no hand-over to the batch)."""
    chain = Chain(model(SKEW_XML), "tool") if arm == "skew" else ARMS[arm]()
    rng = np.random.default_rng(32)
    targets, qs = _poses(chain, 150, seed=33)
    q0 = np.array([chain.random_q(rng) for _ in range(150)])
    psi = rng.uniform(-math.pi, math.pi, 150)
    P = np.array([t.position for t in targets])
    Q = np.array([t.quat for t in targets])
    for kw in ({}, {"q0": q0}, {"q0": q0, "swivel": psi}):
        q_b, ok = solve_batch(chain, P, Q, **kw)
        assert ok.all()
        for i in range(150):
            start = q0[i] if "q0" in kw else chain.clip(chain.q)
            sw = float(psi[i]) if "swivel" in kw else None
            np.testing.assert_allclose(_one(chain, targets[i], start, sw), q_b[i], atol=1e-9)
    # position targets (the wrist held at the start's angles)
    q_b, ok = solve_batch(chain, P, q0=q0, swivel=psi)
    for i in np.flatnonzero(ok):
        got = _one(chain, Target(P[i]), chain.clip(q0[i]), float(psi[i]))
        np.testing.assert_allclose(got, q_b[i], atol=1e-9)


def test_float_and_array_decompositions_agree():
    """decompose on floats and on arrays is one code: the same numbers (1e-14), and the
    lazy float reading keeps exactly the branches that are inside."""
    chain = Chain(model(SKEW_XML), "tool")
    ctx = arm_context(chain)
    rng = np.random.default_rng(34)
    for tri in (ctx.sh, ctx.wr):
        K = rng.normal(size=(15, 200))
        psi = rng.uniform(-math.pi, math.pi, 200)
        full = decompose(ARRAYS, tri, K, np.cos(psi), np.sin(psi))
        ok = np.broadcast_to(feasible(full), (200,))
        for m in range(200):
            k, c, s = tuple(K[:, m].tolist()), math.cos(psi[m]), math.sin(psi[m])
            one = decompose(FLOATS, tri, k, c, s)
            lazy = decompose(FLOATS, tri, k, c, s, True)
            assert (lazy is not None) == bool(ok[m]) == bool(feasible(one))
            assert one[0] == pytest.approx(full[0][m], abs=1e-14)
            for b in (2, 3):
                inside = bool(np.broadcast_to(full[b][6], (200,))[m])
                assert bool(one[b][6]) == inside
                got = [np.broadcast_to(x, (200,))[m] for x in full[b][:6]]
                np.testing.assert_allclose(one[b][:6], got, atol=1e-14)
                if lazy is not None:
                    assert bool(lazy[b][6]) == inside
                    if inside:
                        assert lazy[b] == one[b]


def test_float_path_hands_over_what_it_does_not_solve():
    """Out of reach, elbow out of range, no feasible swivel, a gimbal lock: the float
    path raises Fallback and the solver answers through the batch."""
    chain = Chain()
    geo = arm_geometry(chain)
    q = np.array([-1.0, 0.0, 1.22, 0.1, 1.4, 1.4, 0.35])
    p, R = chain.fk(q)
    lock = np.array([0.4, math.pi / 2, -0.6, 1.0, 0.2, 0.1, 0.1])
    pl, Rl = chain.fk(lock)
    cases = [
        (Target(geo.shoulder + [3.0, 0.0, 0.0], [1, 0, 0, 0]), None),  # beyond reach
        (Target(geo.shoulder, [1, 0, 0, 0]), None),  # elbow out of range
        (Target(p, mat_to_quat(R @ np.diag([-1.0, -1.0, 1.0]))), None),  # no swivel
        (Target(pl, mat_to_quat(Rl)), swivel_angle(chain, lock)),  # shoulder lock
    ]
    for tgt, sw in cases:
        start = lock if sw is not None else chain.q_home
        with pytest.raises(Fallback):
            _one(chain, tgt, start, sw)
        res = ClosedForm(swivel=sw).solve(chain, tgt, q0=start)
        assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)


def test_caches_live_on_the_chain(monkeypatch):
    """prepare() reads the geometry once and the chain keeps it; solves read nothing
    more; another chain has its own; a moved free base makes one fresh read."""
    reads = []
    real = geometry.read_geometry
    monkeypatch.setattr(geometry, "read_geometry", lambda c: reads.append(c) or real(c))
    chain = Chain(model(SMALL_ARM_XML), "tip")
    solver = ClosedForm()
    solver.prepare(chain)
    assert len(reads) == 1 and arm_cache(chain) is arm_cache(chain)
    q = np.array([0.3, -0.4, 0.5, -1.0, 0.2, 0.3, -0.2])
    p, R = chain.fk(q)
    for _ in range(3):
        assert solver.solve(chain, Target(p, mat_to_quat(R))).converged
    assert len(reads) == 1
    other = Chain(chain.model, "tip")
    assert arm_cache(other) is not arm_cache(chain)
    chain.data.qpos[chain.model.joint("float").qposadr[0]] += 0.2
    arm_context(chain)
    arm_context(chain)
    assert len(reads) == 2


def test_axes_meeting_point():
    """Lines through one point give it; parallel or skew lines give None."""
    S = np.array([0.1, -0.2, 0.3])
    axes = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    anchors = S + np.array([0.5, -1.0, 2.0])[:, None] * axes
    np.testing.assert_allclose(axes_meeting_point(anchors, axes), S, atol=1e-12)
    assert axes_meeting_point(anchors, np.array([axes[0]] * 3)) is None
    assert axes_meeting_point(anchors + [[0.0, 0.0, 0.0], [0.01, 0, 0], [0, 0, 0]], axes) is None


# ----------------------------------------------------------------------------- failures
@pytest.mark.parametrize(
    ("xml", "words"),
    [
        (CCD_XML, "7 hinges"),
        (NO_SHOULDER_XML, "first three hinge axes to meet"),
        (NO_WRIST_XML, "last three hinge axes to meet"),
    ],
)
def test_chains_without_the_structure_are_refused(xml, words):
    """Planar 2-link, shoulder or wrist axes that miss: a reason, an error, a bench skip."""
    site = "p3" if xml is CCD_XML else "tool"
    chain = Chain(model(xml), site)
    reason = ClosedForm().applicable(chain, pose=True)
    assert reason is not None and words in reason
    assert structure_problem(chain) == reason
    with pytest.raises(SolverError, match=words):
        ClosedForm().solve(chain, chain.fk(np.zeros(chain.n))[0])
    with pytest.raises(SolverError, match=words):
        solve_batch(chain, np.zeros((1, 3)))
    for query in (
        lambda: solutions(chain, np.zeros(3), 0.0),
        lambda: swivel_intervals(chain, np.zeros(3)),
        lambda: swivel_angle(chain, np.zeros(chain.n)),
        lambda: arm_geometry(chain),
    ):
        with pytest.raises(SolverError, match=words):
            query()
    ClosedForm().prepare(chain)  # nothing to build, and no error
    report = run_bench(chain, "position", solvers=["closed_form"], n=3)
    assert report.results[0].skipped == reason


def test_elbow_through_the_shoulder_is_refused():
    """An elbow axis through the shoulder point cannot change the reach: refused."""
    xml = ARM_XML.replace('<body name="fore" pos="0.37 0 0.04">', '<body name="fore" pos="0 0 0">')
    reason = structure_problem(Chain(model(xml), "tool"))
    assert reason is not None and "elbow axis" in reason


@pytest.mark.parametrize("arm", ["right", "other"])
def test_unreachable_targets(arm):
    """Beyond reach, at the shoulder, or out of joint range: unreachable, finite, in range."""
    chain = ARMS[arm]()
    geo = arm_geometry(chain)
    far = geo.shoulder + np.array([3.0, 0.0, 0.0])
    cases = [
        (Target(far, [1, 0, 0, 0]), "beyond"),
        (Target(geo.shoulder + geo.hand_offset, [1, 0, 0, 0]), "inner hole"),  # wrist on S
        (far, "beyond"),
        (geo.shoulder, "inner hole"),
    ]
    for tgt, words in cases:
        chain.reset()
        res = ClosedForm().solve(chain, tgt)
        assert res.status == "unreachable" and not res.converged
        assert words in res.message
        assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)
    # stretched toward the far target: the miss is the distance beyond the shell
    chain.reset()
    res = ClosedForm().solve(chain, far)
    assert res.position_error < 3.0


def test_elbow_out_of_range_is_unreachable():
    """A wrist 8 cm from the shoulder needs more elbow than its 2.62 rad: the reason says so."""
    chain = Chain()
    res = ClosedForm().solve(chain, Target(arm_geometry(chain).shoulder, [1, 0, 0, 0]))
    assert res.status == "unreachable" and "elbow angle" in res.message
    assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)


def test_out_of_range_pose_is_unreachable():
    """A hand turned palm-up behind the back needs joints out of range: unreachable, no NaN."""
    chain = Chain()
    q = np.array([-1.0, 0.0, 1.22, 0.1, 1.4, 1.4, 0.35])
    p, R = chain.fk(q)
    R2 = R @ np.diag([-1.0, -1.0, 1.0])  # the hand half a turn about its own axis
    tgt = Target(p, mat_to_quat(R2))
    assert not swivel_intervals(chain, tgt)
    res = ClosedForm().solve(chain, tgt)
    assert res.status == "unreachable" and "no swivel angle" in res.message
    assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)
    q_b, ok = solve_batch(chain, [p, p], [mat_to_quat(R2), mat_to_quat(R)])
    assert ok.tolist() == [False, True] and np.all(np.isfinite(q_b))


def test_unreachable_in_batch_and_solutions():
    """Batch marks far targets not ok without NaN; solutions and intervals are empty."""
    chain = Chain()
    far = np.array([[2.0, -0.2, 1.4], [0.0, -0.19, 1.4]])
    q, ok = solve_batch(chain, far, [[1, 0, 0, 0]] * 2)
    assert not ok.any() and np.all(np.isfinite(q)) and all(chain.within_limits(x) for x in q)
    tgt = Target(far[0], [1, 0, 0, 0])
    assert solutions(chain, tgt, 0.0) == []
    assert swivel_intervals(chain, tgt) == []


# ----------------------------------------------------------------------------- interface
def test_bad_inputs_are_refused():
    """Shapes, NaN, non-unit quaternions, bad starts and swivels name the bad value."""
    chain = Chain()
    with pytest.raises(TargetError, match="shape \\(N, 3\\)"):
        solve_batch(chain, np.zeros(3))
    with pytest.raises(TargetError, match=r"target position \[nan, 0.0, 0.0\] is not finite"):
        solve_batch(chain, [[np.nan, 0, 0]])
    with pytest.raises(TargetError, match="quats must have shape \\(1, 4\\)"):
        solve_batch(chain, [[0.3, -0.2, 1.1]], [1, 0, 0, 0])
    with pytest.raises(TargetError, match=r"quaternion \[nan, 0.0, 0.0, 0.0\] is not finite"):
        solve_batch(chain, [[0.3, -0.2, 1.1]], [[np.nan, 0, 0, 0]])
    with pytest.raises(TargetError, match="has norm 2"):
        solve_batch(chain, [[0.3, -0.2, 1.1]], [[2, 0, 0, 0]])
    with pytest.raises(TargetError, match="q0 must be 7 finite"):
        solve_batch(chain, [[0.3, -0.2, 1.1]], q0=np.zeros(6))
    with pytest.raises(TargetError, match="swivel must be a finite number"):
        solve_batch(chain, [[0.3, -0.2, 1.1]], swivel=[0.1, 0.2])
    with pytest.raises(TargetError, match="swivel must be finite angles"):
        solutions(chain, [0.3, -0.2, 1.1], [[0.1]])
    with pytest.raises(TargetError, match="swivel must be finite angles"):
        solutions(chain, [0.3, -0.2, 1.1], math.inf)
    with pytest.raises(TargetError, match="q0 must be 7 finite"):
        swivel_intervals(chain, [0.3, -0.2, 1.1], q0=[0.0, np.nan, 0, 0, 0, 0, 0])
    with pytest.raises(TargetError, match="not finite"):
        swivel_intervals(chain, [0.3, np.nan, 1.1])
    with pytest.raises(TargetError, match="joint vector must have shape"):
        swivel_angle(chain, np.zeros(3))
    for bad in (True, "up", math.nan):
        with pytest.raises(SolverError, match="'swivel' of solver 'closed_form' must be"):
            make_solver("closed_form", swivel=bad)


def test_cli_solve_and_bench(capsys):
    """`humanoid-ik solve --solver closed_form` converges; the pose bench lists the solver."""
    chain = Chain()
    p, R = chain.fk([0.5, 0.3, 0.2, 1.1, 0.2, 0.3, 0.1])
    quat = mat_to_quat(R)
    code = main(
        [
            "solve",
            "--solver",
            "closed_form",
            "--target",
            ",".join(f"{v:.12f}" for v in p),
            "--quat",
            ",".join(f"{v:.12f}" for v in quat),
            "--option",
            "swivel=0.5",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0 and "solver closed_form: converged" in out
    report = run_bench(chain, "pose", solvers=["closed_form"], n=50, seed=2)
    row = report.results[0]
    assert row.success_rate == 1.0 and row.limit_violations == 0
    assert row.max_position_error_m < 1e-9
