"""``lm``: the Jacobian it uses, the damped step, joint ranges as a box, restarts, warm
starts, and FK(IK(x)) = x on the bundled, ``models/robot`` and fixture arms."""

from __future__ import annotations

import itertools
import math
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, SolverError, make_solver
from humanoid_ik.core.measures import orientation_error
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Status, Target
from humanoid_ik.experiments.bench import make_targets, run_trials
from humanoid_ik.solvers.jacobian import lm_loop

from .chains import MODELS, SMALL_ARM_XML, chain, fixture
from .test_solvers import ROBOT, ROBOT_ARM

_GAPPED_POSE = ("robot_gapped", True)
TURNED_SITE_XML = SMALL_ARM_XML.replace(
    '<site name="tip" pos="0.05 0 0"/>', '<site name="tip" pos="0.05 0.01 0" euler="0.4 -0.3 1.1"/>'
)
"""The small arm with its tip site turned and moved off the tool's frame."""


def _arms() -> dict[str, Chain]:
    return {
        "bundled": Chain(),
        "robot_arm": Chain(ROBOT, "right_hand_site", ROBOT_ARM),
        "robot_waist_arm": Chain(ROBOT, "right_hand_site"),
        "robot_gapped": Chain(ROBOT, "right_hand_site", ["waist_yaw", "r_sh_pitch", "r_elbow"]),
        "small_arm_body": Chain.from_xml_string(SMALL_ARM_XML, body="tool"),
        "small_arm_turned_site": Chain.from_xml_string(TURNED_SITE_XML, "tip"),
        "three_hinge": fixture("three_hinge_arm"),
    }


@pytest.mark.parametrize("name", ["bundled", "robot_waist_arm", "robot_gapped", "small_arm_body"])
def test_mujoco_jacobian_is_the_hinge_columns(name, rng):
    """The Jacobian lm reads (mj_comPos + mj_jacSite / mj_jacBody) equals the chain's own
    hinge columns J_pos = axis x (p - anchor), J_rot = axis, at random in-range poses."""
    c = _arms()[name]
    for _ in range(5):
        q = c.random_q(rng)
        J = c.jacobian(q)
        anchors, axes = c.joint_axes()
        np.testing.assert_allclose(J[:3], np.cross(axes, c.position - anchors).T, atol=1e-12)
        np.testing.assert_allclose(J[3:], axes.T, atol=1e-12)


def test_jacobian_matches_finite_differences(right_arm, rng):
    """The position rows are the derivative of MuJoCo's FK (central differences)."""
    q = right_arm.random_q(rng)
    J = right_arm.jacobian(q)
    h = 1e-6
    for i in range(right_arm.n):
        dq = np.zeros(right_arm.n)
        dq[i] = h
        fd = (right_arm.fk(q + dq)[0] - right_arm.fk(q - dq)[0]) / (2 * h)
        np.testing.assert_allclose(J[:3, i], fd, atol=1e-8)


@pytest.mark.parametrize(
    ("name", "pose"),
    [(name, pose) for name in _arms() for pose in (False, True) if (name, pose) != _GAPPED_POSE],
)
def test_fk_of_answer_is_the_target(name, pose):
    """FK(lm(x)) = x within the tolerances on seeded reachable targets, every answer
    inside the ranges exactly (no tolerance), every one converged (the three-hinge
    gapped chain has position targets only: three hinges do not fix a pose)."""
    c = _arms()[name]
    solver = make_solver("lm")
    for tgt in make_targets(c, 25, 11, pose):
        c.reset()
        res = solver.solve(c, tgt)
        assert res.converged and res.status is Status.CONVERGED and res.solver == "lm"
        assert c.within_limits(res.q, tol=0.0)
        p, R = c.fk(res.q)
        assert np.linalg.norm(p - tgt.position) < 1e-4
        assert res.position_error == pytest.approx(np.linalg.norm(p - tgt.position), abs=1e-12)
        if pose:
            err = orientation_error(R, tgt.quat)
            assert err < 1e-3 and res.orientation_error == pytest.approx(err, abs=1e-12)
        else:
            assert res.orientation_error is None


def test_one_step_is_the_damped_box_step(right_arm):
    """With no range in the way, one iteration moves q0 by
    dq = (J' W J + lambda I)^-1 J' W e, lambda = error_damping * E + min_damping,
    E = e' W e / 2, W = diag(1, 1, 1, w^2, w^2, w^2) (the module's formula)."""
    c = right_arm
    q0 = np.array([0.4, 0.5, 0.1, 1.2, 0.1, 0.2, 0.0])
    p, R = c.fk([0.5, 0.6, 0.0, 1.3, 0.0, 0.3, 0.1])
    tgt = Target(p, mat_to_quat(R))
    opts = dict(error_damping=0.3, min_damping=1e-3, orientation_weight=0.4)
    c.set_q(q0)
    e = np.empty(6)
    e[:3] = tgt.position - c.position
    rot = np.empty(3)
    mujoco.mju_subQuat(rot, tgt.quat, mat_to_quat(c.rotation))
    e[3:] = c.rotation @ rot
    J = c.jacobian(q0)
    W = np.diag([1, 1, 1, 0.16, 0.16, 0.16])
    lam = 0.3 * (e @ W @ e) / 2 + 1e-3
    dq = np.linalg.solve(J.T @ W @ J + lam * np.eye(7), J.T @ W @ e)
    assert c.within_limits(q0 + dq)  # the box is not active
    res = make_solver("lm", max_iterations=1, restarts=0, tol=0.0, **opts).solve(c, tgt, q0)
    np.testing.assert_allclose(res.q, q0 + dq, atol=1e-10)


def test_error_falls_fast_near_the_target(right_arm):
    """Near a target the step is the Gauss-Newton step: from 0.05 rad away the
    position error falls below 1e-9 m within 5 iterations."""
    c = right_arm
    q_star = np.array([0.6, 0.4, 0.2, 1.1, 0.2, 0.1, 0.0])
    p, _ = c.fk(q_star)
    res = make_solver("lm", tol=1e-9, restarts=0).solve(c, p, q_star + 0.05)
    assert res.converged and res.iterations <= 5 and res.position_error < 1e-9


def test_step_slides_along_a_range_end(right_arm):
    """A target whose pose has a joint at its range end (the elbow straight, 0 rad) is
    reached from a start pushing that joint outward, with no restart: the box keeps the
    elbow in range and the other joints go on."""
    c = right_arm
    q_star = np.array([0.8, 0.3, -0.2, 0.0, 0.3, -0.2, 0.1])  # elbow at its lower end
    p, R = c.fk(q_star)
    res = make_solver("lm", restarts=0).solve(c, Target(p, mat_to_quat(R)), q_star + 0.3)
    assert res.converged and res.iterations < 30
    assert c.within_limits(res.q, tol=0.0) and res.q[3] >= 0.0


def test_unreachable_target_returns_the_closest_pose_in_range(right_arm):
    """A point 5 m away: every start stalls, the status is max_iterations with the
    restarts message, and the answer is the stretched arm inside the ranges."""
    c = right_arm
    res = make_solver("lm", restarts=3).solve(c, [5.0, 0.0, 1.2])
    assert not res.converged and res.status is Status.MAX_ITERATIONS
    assert "no start of 4 converged" in res.message
    assert c.within_limits(res.q, tol=0.0)
    shoulder = c.joint_axes()[0][0]
    p, _ = c.fk(res.q)
    reach = np.linalg.norm(p - shoulder)
    assert res.position_error == pytest.approx(np.linalg.norm(p - [5.0, 0.0, 1.2]), abs=1e-12)
    assert np.linalg.norm([5.0, 0.0, 1.2] - shoulder) - reach < res.position_error + 1e-9


def test_restarts_rescue_a_blocked_start(right_arm):
    """Targets that some start cannot reach without restarts are all reached with them
    (the seed library's nearest poses)."""
    c = right_arm
    targets = make_targets(c, 60, 21, True)
    alone = run_trials(c, make_solver("lm", restarts=0), targets)
    helped = run_trials(c, make_solver("lm"), targets)
    assert helped.success.all()
    assert alone.success.mean() < 1.0  # some need a restart
    assert helped.iterations[~alone.success].min() > 0


def test_warm_start_tracks_a_moving_target(right_arm):
    """Tracking a target moving 2 mm per frame from the previous answer: each frame
    converges in at most 3 iterations and the joints move less than 0.05 rad."""
    c = right_arm
    solver = make_solver("lm")
    q = np.array([0.5, 0.3, 0.1, 1.2, 0.0, 0.1, 0.0])
    p0, R = c.fk(q)
    quat = mat_to_quat(R)
    for k in range(1, 40):
        tgt = Target(p0 + 0.002 * k * np.array([0.0, 0.6, 0.8]), quat)
        res = solver.solve(c, tgt, q)
        assert res.converged and res.iterations <= 3
        assert np.max(np.abs(res.q - q)) < 0.05
        q = res.q


def test_default_start_is_the_chain_current_joints(right_arm):
    """Without q0 lm starts from the chain's current joints: already on target, zero
    iterations."""
    c = right_arm
    q = np.array([0.3, 0.2, 0.1, 0.9, 0.1, 0.1, 0.0])
    p, R = c.fk(q)
    res = make_solver("lm").solve(c, Target(p, mat_to_quat(R)))
    assert res.converged and res.iterations == 0
    np.testing.assert_allclose(res.q, q, atol=1e-12)


def test_answers_never_leave_the_ranges(rng):
    """Property: random targets anywhere in a 3 m box around each arm, reachable or not,
    with and without orientation, from random starts: every lm answer is inside the
    joint ranges exactly, and its reported errors are those of its own FK."""
    solver = make_solver("lm", restarts=2)
    for c in _arms().values():
        centre = c.position.copy()
        for _ in range(15):
            pose = bool(rng.integers(2))
            quat = rng.normal(size=4) if pose else None
            quat = None if quat is None else quat / np.linalg.norm(quat)
            tgt = Target(centre + rng.uniform(-1.5, 1.5, 3), quat)
            res = solver.solve(c, tgt, c.random_q(rng))
            assert c.within_limits(res.q, tol=0.0)
            p, _ = c.fk(res.q)
            assert res.position_error == pytest.approx(np.linalg.norm(p - tgt.position), abs=1e-9)


def test_unlimited_hinges_use_an_unbounded_box():
    """On the worksheet limb (no joint ranges) lm reaches targets anywhere in its shell."""
    from .chains import WORKSHEET_XML

    c = chain(WORKSHEET_XML, "p3")
    assert np.all(np.isinf(c.lower)) and np.all(np.isinf(c.upper))
    for p in ([4.0, 1.0, 0.5], [-2.0, -3.0, 1.0], [0.0, 0.0, 4.5]):
        res = make_solver("lm").solve(c, p, np.zeros(4))
        assert res.converged and res.position_error < 1e-4


def test_work_buffers_follow_the_chain_and_task():
    """One solver object on two chains and both task sizes gives the answers a fresh
    solver gives (its buffers are rebuilt per chain and task size)."""
    a, b = Chain(), Chain(MODELS / "planar_arm.xml", "hand_site")
    shared = make_solver("lm")
    for c, pose in ((a, True), (b, False), (a, False), (a, True)):
        tgt = make_targets(c, 1, 3, pose)[0]
        c.reset()
        got = shared.solve(c, tgt)
        c.reset()
        want = make_solver("lm").solve(c, tgt)
        np.testing.assert_array_equal(got.q, want.q)
        assert got.converged


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("max_iterations", 100_001, "must be an integer >= 0 and <= 100000, got 100001"),
        ("restarts", 1_001, "must be an integer >= 0 and <= 1000, got 1001"),
        ("stall_window", 1, "must be an integer >= 2 and <= 100000, got 1"),
        ("library_seeds", 5_000, "must be an integer >= 0 and <= 4000, got 5000"),
        ("orientation_weight", 1e3, "must be a finite number >= 0 and <= 100, got 1000.0"),
        ("error_damping", 1e7, "must be a finite number >= 0 and <= 1000000, got 10000000.0"),
        ("min_damping", 0.0, "must be a finite number >= 1e-12 and <= 1, got 0.0"),
        ("min_damping", 2.0, "must be a finite number >= 1e-12 and <= 1, got 2.0"),
        ("tol", 2.0, "must be a finite number >= 0 and <= 1, got 2.0"),
    ],
)
def test_option_bounds(option, value, message):
    """Each bounded option names itself, the solver and both bounds in one line."""
    with pytest.raises(SolverError, match=f"option '{option}' of solver 'lm' {message}"):
        make_solver("lm", **{option: value})


def test_iterations_are_bounded_and_counted(right_arm):
    """max_iterations caps each start: with 2 restarts and 3 iterations an unreachable
    target reports 9 iterations in all."""
    res = make_solver("lm", max_iterations=3, restarts=2, stall_window=100).solve(
        right_arm, [3.0, 3.0, 3.0]
    )
    assert res.iterations == 9 and not res.converged
    assert math.isfinite(res.position_error)


def test_follows_a_model_changed_in_place():
    """After the tip site is turned further and a range narrowed on the live model, the
    same solver object reaches a pose target of the new model, inside the new range."""
    c = _arms()["small_arm_turned_site"]
    assert c.model.site_sameframe[c.ee_id] == 0  # MuJoCo reads site_quat on every pass
    solver = make_solver("lm")
    tgt = make_targets(c, 1, 4, True)[0]
    assert solver.solve(c, tgt).converged  # buffers built on the old model
    c.model.site_quat[c.ee_id] = mat_to_quat(
        np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    )
    c.model.jnt_range[c.joint_ids[3]] = [-1.5, -0.5]  # the elbow
    q_new = np.array([0.5, 0.3, 0.1, -1.0, 0.2, 0.1, 0.0])
    p, R = c.fk(q_new)
    c.reset()
    res = solver.solve(c, Target(p, mat_to_quat(R)))
    assert res.converged and -1.5 <= res.q[3] <= -0.5
    p2, R2 = c.fk(res.q)
    assert np.linalg.norm(p2 - p) < 1e-4 and orientation_error(R2, mat_to_quat(R)) < 1e-3


def _far_targets(c: Chain, n: int, rng: np.random.Generator) -> list[Target]:
    """Targets beyond reach (twice as far from the chain's first joint as a reachable
    one) or, for half of them, a reachable position with a random orientation."""
    base = c.data.xanchor[c.joint_ids[0]].copy()
    out = []
    for t in make_targets(c, n, 7, True):
        if len(out) % 2:
            out.append(Target(base + 2.0 * (t.position - base)))
        else:
            q = rng.normal(size=4)
            out.append(Target(t.position, q / np.linalg.norm(q)))
    return out


@pytest.mark.parametrize("name", list(_arms()))
def test_compiled_loop_matches_the_python_loop(name, rng):
    """The compiled loop (solvers/jacobian/_lm_loop.c) gives the Python loop's answers bit
    for bit, iterations and statuses included: reachable position and pose targets
    solved one after the other (each warm-starting from the last), unreachable targets
    (stalls, restarts, the best pose returned) and solves capped with tolerance 0."""
    assert lm_loop.AVAILABLE, lm_loop.REASON  # the suite tests the compiled build
    c = _arms()[name]
    cases = [
        ({}, make_targets(c, 25, 5, False)),
        ({}, make_targets(c, 25, 6, True)),
        ({"restarts": 3}, _far_targets(c, 6, rng)),
        ({"tol": 0.0, "rot_tol": 0.0, "restarts": 1, "max_iterations": 20, "stall_window": 100},
         make_targets(c, 4, 8, True)),
    ]  # fmt: skip
    for options, targets in cases:
        answers = []
        for compiled in (True, False):
            solver = make_solver("lm", **options)
            solver.compiled = compiled
            c.reset()
            answers.append([solver.solve(c, t) for t in targets])
        for got, want in zip(*answers, strict=True):
            np.testing.assert_array_equal(got.q, want.q)
            assert (got.iterations, got.status) == (want.iterations, want.status)
            assert got.position_error == want.position_error
        if "max_iterations" in options:  # tolerance 0: every start runs to its cap
            assert all(r.iterations == 40 for r in answers[0])
        assert all(c.within_limits(r.q, tol=0.0) for r in answers[0])


def test_python_loop_on_request():
    """HUMANOID_IK_LM_LOOP=python runs lm's Python loop, says so, and still solves."""
    code = (
        "from humanoid_ik import Chain, make_solver\n"
        "from humanoid_ik.solvers.jacobian import lm_loop\n"
        "s = make_solver('lm')\n"
        "r = s.solve(Chain(), [0.35, -0.30, 1.15])\n"
        "print(lm_loop.AVAILABLE, s.compiled, r.converged, lm_loop.REASON)\n"
    )
    env = {**os.environ, "HUMANOID_IK_LM_LOOP": "python"}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert out.stdout == "False False True HUMANOID_IK_LM_LOOP=python\n", out.stderr


@pytest.mark.slow
def test_floor_benchmark_reports_both_loops():
    """benchmarks/floor.py prints one row per arm with the floor and lm's per-iteration
    cost in both loops, each with its ratio to that row's floor (speed itself is the
    benchmark's business, not a test's)."""
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, str(root / "benchmarks" / "floor.py"), "--k", "10", "--n", "3"],
        capture_output=True, text=True, timeout=300, cwd=root,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    rows = [
        line for line in out.stdout.splitlines() if line.startswith("| ") and "|---" not in line
    ]
    assert rows[0].startswith("| model | floor | C calls |") and "lm pose, Python loop" in rows[0]
    assert len(rows) == 5 and "not available" not in out.stdout
    for row in rows[1:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        floor = float(cells[1])
        for cell in cells[4:8]:  # "1.37 (0.7x)": lm per iteration, its ratio (both rounded)
            value, ratio = cell.split()
            assert float(ratio.strip("(x)")) == pytest.approx(float(value) / floor, abs=0.1)


def test_seed_library_ranks_by_distance_and_angle(right_arm):
    """The restart poses come nearest first: the ranking equals a brute-force sort of
    distance + 0.3 m/rad x (1 - cos angle) from each pose's own FK, and the poses
    restart_poses hands out alternate library (in that order) and random ones."""
    from humanoid_ik.core.rotations import quat_to_mat
    from humanoid_ik.solvers.jacobian.seeds import restart_poses, seed_library

    c = right_arm
    lib = seed_library(c)
    for tgt in (*make_targets(c, 2, 11, False), *make_targets(c, 2, 12, True)):
        cost = np.linalg.norm(lib.positions - tgt.position, axis=1)
        if tgt.quat is not None:
            R = quat_to_mat(tgt.quat)
            cos = (np.einsum("ij,nij->n", R, lib.rotations) - 1.0) / 2.0
            cost = cost + 0.3 * (1.0 - cos)
        want = np.argsort(cost)[:6]
        got = np.array(list(itertools.islice(lib.ranked(tgt), 6)))
        np.testing.assert_array_equal(got, lib.q[want])
        p, _ = c.fk(got[0])  # the library's FK is MuJoCo's
        np.testing.assert_allclose(p, lib.positions[want[0]], atol=1e-12)
        starts = list(restart_poses(c, c.q, tgt, restarts=5, library_seeds=2, seed=0))
        np.testing.assert_array_equal(starts[1], lib.q[want[0]])
        np.testing.assert_array_equal(starts[3], lib.q[want[1]])
        assert not any(np.array_equal(s, q) for s in starts[5:] for q in lib.q[want[:3]])
        assert all(c.within_limits(s) for s in starts)


def test_threads_on_a_shared_model_match_one_thread():
    """The compiled loop runs without the GIL: two threads, each with its own chain and
    solver on one shared MjModel, give the serial answers bit for bit."""
    from concurrent.futures import ThreadPoolExecutor

    model = Chain().model
    targets = make_targets(Chain(model), 30, 21, True)

    def run(_: int = 0) -> list:
        c, s = Chain(model), make_solver("lm")
        return [s.solve(c, t).q for t in targets]

    serial = run()
    with ThreadPoolExecutor(2) as pool:
        outs = list(pool.map(run, range(2)))
    for out in outs:
        assert len(out) == len(serial)
        for q, q1 in zip(out, serial, strict=True):
            np.testing.assert_array_equal(q, q1)


def test_a_compiled_loop_older_than_its_source_is_not_used(tmp_path):
    """In a checkout, a compiled loop built before the last edit of _lm_loop.c is stale
    (lm then runs its Python loop and --version says why); a wheel has no source."""
    source, compiled = tmp_path / "_lm_loop.c", tmp_path / "_lm_loop.so"
    compiled.write_bytes(b"")
    source.write_text("")
    os.utime(compiled, (1_000, 1_000))
    os.utime(source, (2_000, 2_000))
    assert lm_loop.stale(source, compiled)
    os.utime(compiled, (3_000, 3_000))
    assert not lm_loop.stale(source, compiled)
    assert not lm_loop.stale(tmp_path / "missing.c", compiled)
