"""``lm``: the Jacobian it uses, the damped step, joint ranges as a box, restarts, warm
starts, and FK(IK(x)) = x on the bundled, ``models/robot`` and fixture arms."""

from __future__ import annotations

import importlib.machinery
import io
import math
import subprocess
import sys
import threading
from pathlib import Path

import mujoco
import numpy as np
import pytest
from mujoco import minimize

from humanoid_ik import Chain, SolverError, make_solver
from humanoid_ik.core.measures import orientation_error
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.core.types import Status, Target
from humanoid_ik.experiments.bench import make_targets, run_trials
from humanoid_ik.solvers.jacobian import _lm_kernel
from humanoid_ik.solvers.jacobian.lm import KERNEL_KEY, kernel

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


def test_one_solver_object_serves_any_chain_and_task():
    """One solver object on two chains and both task sizes gives the answers a fresh
    solver gives (it holds no buffer: the kernel is the robot state's)."""
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
    assert solver.solve(c, tgt).converged  # the kernel built on the old model
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


# ----------------------------------------------------------------- the oracle
ORACLE_WEIGHT = 0.5
"""lm's default orientation_weight [m/rad]: the oracle weighs the rotation as lm does."""


def _residual(c: Chain, tgt: Target):
    """The task residual for ``mujoco.minimize.least_squares``, computed apart from lm:
    its own MjData (the chain's scratch qpos copied in), MuJoCo's FK, ``p - target`` and
    ``w * log(target^-1 site)``; vectorised over the columns of ``x`` (n, k)."""
    m, d = c.model, mujoco.MjData(c.model)
    d.qpos[:] = c.data.qpos
    quat, rot = np.empty(4), np.empty(3)

    def residual(x: np.ndarray) -> np.ndarray:
        x = x.reshape(c.n, -1)
        out = np.empty((3 if tgt.quat is None else 6, x.shape[1]))
        for k in range(x.shape[1]):
            d.qpos[c.qpos_adr] = x[:, k]
            mujoco.mj_kinematics(m, d)
            out[:3, k] = d.site_xpos[c.ee_id] - tgt.position
            if tgt.quat is not None:
                mujoco.mju_mat2Quat(quat, d.site_xmat[c.ee_id])
                mujoco.mju_subQuat(rot, quat, tgt.quat)
                out[3:, k] = ORACLE_WEIGHT * rot
        return out

    return residual


def _least_squares(c: Chain, tgt: Target, q0: np.ndarray) -> tuple[np.ndarray, float, object]:
    """MuJoCo's own box-bounded Levenberg-Marquardt (finite-difference Jacobian) from
    ``q0`` inside the chain's ranges: its answer and its squared residual ``r' r``."""
    f = _residual(c, tgt)
    x, _ = minimize.least_squares(
        q0.copy(), f, bounds=(c.lower, c.upper), verbose=0, output=io.StringIO()
    )
    r = f(x)[:, 0]
    return x.reshape(-1), float(r @ r), f


@pytest.mark.parametrize("pose", [False, True])
def test_reachable_targets_agree_with_least_squares(pose, rng):
    """Reachable targets on the bundled arm, each from a start 0.3 rad (rms) away from a
    pose that reaches it: lm and mujoco.minimize.least_squares both converge, and the
    oracle's residual at lm's answer is within lm's tolerances (FK from the oracle's own
    MjData)."""
    c = Chain()
    lm = make_solver("lm")
    for _ in range(12):
        q_star = c.random_q(rng)
        p, R = c.fk(q_star)
        tgt = Target(p, mat_to_quat(R) if pose else None)
        q0 = c.clip(q_star + rng.normal(scale=0.3, size=c.n))
        res = lm.solve(c, tgt, q0)
        x, cost, f = _least_squares(c, tgt, q0)
        assert cost < 1e-12  # the oracle converged
        assert res.converged and c.within_limits(res.q, tol=0.0)
        r = f(res.q)[:, 0]
        assert np.linalg.norm(r[:3]) < 1e-4
        if pose:
            assert np.linalg.norm(r[3:]) / ORACLE_WEIGHT < 1e-3
            assert res.orientation_error == pytest.approx(np.linalg.norm(r[3:]) / 0.5, abs=1e-9)
        assert res.position_error == pytest.approx(np.linalg.norm(r[:3]), abs=1e-12)


UNREACHABLE = [
    Target([3.0, 0.0, 1.2]),
    Target([0.2, -1.5, 2.5]),
    Target([-1.0, -1.0, 0.5]),
    Target([3.0, 0.0, 1.2], [0.5, 0.5, 0.5, 0.5]),
    Target([0.2, -1.5, 2.5], [0.0, 1.0, 0.0, 0.0]),
    Target([-1.0, -1.0, 0.5], [0.5, -0.5, 0.5, 0.5]),
]
"""Targets beyond the bundled arm's reach, with and without an orientation."""


@pytest.mark.parametrize("tgt", UNREACHABLE, ids=lambda t: f"{t.position}{'+quat' * t.is_pose}")
def test_unreachable_target_is_no_worse_than_least_squares(tgt):
    """Beyond reach, from the same start (home): lm's best pose has a squared residual
    within 2 % of mujoco.minimize.least_squares' optimum (lm stops on a stall, the
    oracle runs to its own tolerances), inside the ranges, and lm says it missed."""
    c = Chain()
    q0 = c.q.copy()
    res = make_solver("lm").solve(c, tgt, q0)
    _, cost, f = _least_squares(c, tgt, q0)
    r = f(res.q)[:, 0]
    assert not res.converged and c.within_limits(res.q, tol=0.0)
    assert r @ r <= 1.02 * cost
    assert res.position_error == pytest.approx(np.linalg.norm(r[:3]), abs=1e-12)


# ----------------------------------------------------------------- the kernel
def test_the_kernel_is_a_compiled_extension_module():
    """lm's loop is a real CPython extension (an importable module with PyInit, its file
    an extension-suffix file), built against the MuJoCo that is loaded."""
    origin = Path(_lm_kernel.__file__)
    assert any(origin.name.endswith(s) for s in importlib.machinery.EXTENSION_SUFFIXES)
    assert _lm_kernel.MUJOCO_VERSION == mujoco.mj_version()
    assert not (origin.parent / "lm_loop.py").exists()


def test_the_kernel_lives_in_the_robot_state_and_the_solver_holds_none():
    """The kernel is built once per robot state (its workspace, KERNEL_KEY), shared by
    the robot's chains, rebuilt after the live model changed; the solver object holds
    its options only."""
    c = Chain()
    solver = make_solver("lm")
    solver.solve(c, [0.35, -0.30, 1.15])
    k = kernel(c)
    assert c.robot.workspace(KERNEL_KEY, lambda: None) is k
    assert kernel(Chain(c.robot, "left_palm_site")) is k  # another chain of the robot
    solver.solve(c, [0.3, -0.25, 1.1])
    assert kernel(c) is k
    # the options and the kernel's immutable tuple of them, nothing a solve writes
    assert set(vars(solver)) == {"options", "_kernel_options"}
    o = solver.options
    assert solver.kernel_options() == (
        o.tol, o.rot_tol, o.orientation_weight**2, o.error_damping, o.min_damping,
        o.max_iterations, o.stall_window,
    )  # fmt: skip
    c.model.body_pos[c.model.body("right_forearm_link").id] += [0.0, 0.0, 0.01]
    res = solver.solve(c, [0.35, -0.30, 1.15])
    assert kernel(c) is not k  # rebuilt from the changed model
    assert res.converged and np.linalg.norm(c.fk(res.q)[0] - [0.35, -0.30, 1.15]) < 1e-4


def test_joints_off_the_chain_stay_where_the_robot_has_them():
    """On models/robot the arm chain leaves the waist out: with the waist turned in the
    robot state, lm solves for the arm with the waist where it is (the kernel copies the
    robot's qpos) and the scratch data is at the answer."""
    c = Chain(ROBOT, "right_hand_site", ROBOT_ARM)
    waist = c.model.joint("waist_yaw").qposadr[0]
    c.data.qpos[waist] = 0.4
    mujoco.mj_kinematics(c.model, c.data)
    q_star = np.array([0.3, -0.2, 0.1, 0.9, 0.2, 0.1, 0.0])
    p, R = c.fk(q_star)
    c.set_q(c.q_home)
    res = make_solver("lm").solve(c, Target(p, mat_to_quat(R)))
    assert res.converged and c.data.qpos[waist] == 0.4
    np.testing.assert_allclose(c.position, p, atol=1e-4)  # the scratch data at the answer
    np.testing.assert_array_equal(c.q, res.q)


def test_the_kernel_refuses_bad_arguments():
    """A wrong length, dtype or address is a Python error, never a call into MuJoCo."""
    c = Chain()
    k = kernel(c)
    o = (1e-4, 1e-3, 0.25, 0.1, 1e-6, 50, 4)
    args = [c.data.qpos, c.qpos_adr, c.dof_adr, True, c.ee_id, c.lower, c.upper,
            np.zeros(3), None, o, c.q.copy()]  # fmt: skip

    def call(**change):
        a = list(args)
        names = ["qpos", "qadr", "dof", "site", "eid", "lower", "upper", "pos", "quat", "o", "q"]
        for key, value in change.items():
            a[names.index(key)] = value
        return k.descend(*a)

    assert call()[1] >= 0
    with pytest.raises(ValueError, match="qpos must have 16 values"):
        call(qpos=np.zeros(3))
    with pytest.raises(ValueError, match="outside the model"):
        call(qadr=c.qpos_adr + 100)
    with pytest.raises(TypeError, match="int64"):
        call(dof=c.dof_adr.astype(np.float64))
    with pytest.raises(ValueError, match="ee_id"):
        call(eid=10_000)
    with pytest.raises(TypeError, match="writable"):
        q = c.q.copy()
        q.flags.writeable = False
        call(q=q)
    with pytest.raises(ValueError, match="target_quat must have 4 values"):
        call(quat=np.zeros(3))
    with pytest.raises(ValueError, match="Kernel"):
        _lm_kernel.Kernel(b"not a model")
    out = np.empty(2, dtype=np.int64)
    one = np.array([0.0, 0, 0, 1, 1, 1, 1])  # one cell of side 1 at the origin
    cells = np.array([0, 2])

    def nearest(positions, rotations, target_rot=None, length=0.3, grid=one, cells=cells, out=out):
        args = (positions, rotations, grid, cells, np.zeros(3), target_rot, length, out)
        return _lm_kernel.seed_nearest(*args)

    with pytest.raises(ValueError, match="3 values per pose, got 4"):
        nearest(np.zeros(4), np.zeros(9))
    with pytest.raises(ValueError, match="rotations must have 18 values"):
        nearest(np.zeros(6), np.zeros(9), np.zeros(9))
    with pytest.raises(ValueError, match="length must be >= 0"):
        nearest(np.zeros(6), np.zeros(18), length=-1.0)
    with pytest.raises(TypeError, match="int64"):
        nearest(np.zeros(6), np.zeros(18), out=np.empty(2))
    with pytest.raises(ValueError, match="grid must have 7 values"):
        nearest(np.zeros(6), np.zeros(18), grid=np.zeros(6))
    with pytest.raises(ValueError, match=r"cell counts must be whole numbers in \[1, 1024\]"):
        nearest(np.zeros(6), np.zeros(18), grid=np.array([0.0, 0, 0, 1, 1.5, 1, 1]))
    with pytest.raises(ValueError, match="side > 0"):
        nearest(np.zeros(6), np.zeros(18), grid=np.array([0.0, 0, 0, 0, 1, 1, 1]))
    with pytest.raises(ValueError, match="cells must have 2 values"):
        nearest(np.zeros(6), np.zeros(18), cells=np.array([0, 1, 2]))
    with pytest.raises(ValueError, match="cells must run from 0 to the 2 poses"):
        nearest(np.zeros(6), np.zeros(18), cells=np.array([0, 3]))
    assert nearest(np.array([0.0, 0, 2, 0, 0, 1]), np.zeros(18)) == 2
    assert out.tolist() == [1, 0]
    # cells that overlap or run backwards rank wrongly, never read outside the poses
    two = np.array([0.0, 0, 0, 1, 2, 1, 1])
    assert nearest(np.zeros(6), np.zeros(18), grid=two, cells=np.array([0, 5, 2])) == 2
    # the kernel builds hinge and slide columns only: a ball's dof is refused
    ball = Chain.from_xml_string(
        '<mujoco><worldbody><body><joint type="ball"/><geom size=".1"/>'
        '<body pos="0 0 .5"><joint name="h" axis="0 1 0"/><geom size=".1"/>'
        '<site name="tip" pos="0 0 .5"/></body></body></worldbody></mujoco>',
        "tip",
        ["h"],
    )
    kb = kernel(ball)
    with pytest.raises(ValueError, match="not a hinge's or a slide's"):
        kb.descend(ball.data.qpos, ball.qpos_adr, np.array([0]), True, ball.ee_id, ball.lower,
                   ball.upper, np.zeros(3), None, o, ball.q.copy())  # fmt: skip
    ok = kb.descend(ball.data.qpos, ball.qpos_adr, ball.dof_adr, True, ball.ee_id,
                    ball.lower, ball.upper, np.zeros(3), None, o, ball.q.copy())  # fmt: skip
    assert ok[1] >= 0


_PATH_XML = """<mujoco><compiler angle="radian"/><worldbody>
  <body name="base" pos="0.1 0.2 0.8" quat="0.9 0.1 0.2 0.3" {base}>
    {free}<geom size="0.05"/>
    <body name="l1" pos="0 0 0.1">
      <joint name="j1" axis="0 0 1" pos="0.01 0 0" range="-2 2"/><geom size="0.04"/>
      <body name="l2" pos="0 0.05 0.2" euler="0.3 0 0.2">
        <joint name="j2" axis="0 1 0" pos="0 0 0.02" ref="0.4" range="-1.5 1.5"/>
        <joint name="frozen_ball" type="ball" pos="0.01 0 0"/>
        <geom size="0.04"/>
        <body name="l3" pos="0.25 0 0">
          <joint name="frozen_slide" type="slide" axis="1 0 0" range="-0.1 0.1"/>
          <joint name="frozen_hinge" axis="1 0 0"/>
          <joint name="j3" axis="0 0 1" pos="0.02 0.01 0" range="-2 2"/><geom size="0.03"/>
          <body name="l4" pos="0.2 0 0" quat="0.7 0 0.7 0">
            <joint name="j4" axis="0 1 0" range="-2 2"/>
            <joint name="j5" axis="1 0 0" range="-2 2"/>
            <joint name="j6" axis="0 0 1" range="-2 2"/>
            <inertial pos="0.05 0.01 0" quat="0.8 0.6 0 0" mass="0.3"
                      diaginertia="0.001 0.001 0.001"/>
            <site name="at_inertia" pos="0.05 0.01 0" quat="0.8 0.6 0 0"/>
            <site name="tip" pos="0.1 0.02 0.03"/>
          </body>
        </body>
      </body>
    </body>
  </body>
  <body name="other"><joint name="o" axis="0 0 1"/><geom size="0.02" pos="1 0 0"/></body>
</worldbody></mujoco>"""


@pytest.mark.parametrize("base", ["free", "mocap"])
@pytest.mark.parametrize("end", ["tip", "at_inertia", "l4"])
def test_the_kernel_computes_the_path_as_mj_kinematics_does(base, end):
    """The kernel computes only the frames of the bodies on the way to the end effector
    (a floating or a mocap base, a frozen ball joint, slide and hinge among the chain's
    joints, off-centre hinges with a reference angle, a site at its body's
    inertial frame, a body): every pose it reports is measured with MuJoCo's own bits.
    After 0 to 5 iterations, its position error is exactly the one of mj_kinematics at
    the pose it returns (same operations, same order: no tolerance), the orientation
    error to 1e-12."""
    xml = _PATH_XML.format(
        base='mocap="true"' if base == "mocap" else "",
        free="<freejoint/>" if base == "free" else "",
    )
    joints = ["j1", "j2", "j3", "j4", "j5", "j6"]
    site = None if end == "l4" else end
    c = Chain.from_xml_string(xml, site, joints, body="l4" if end == "l4" else None)
    m = c.model
    if end == "at_inertia":
        assert m.site_sameframe[c.ee_id] == mujoco.mjtSameFrame.mjSAMEFRAME_INERTIA
    frozen = {"frozen_ball": [0.9, 0.3, -0.2, 0.1], "frozen_hinge": [0.3], "frozen_slide": [0.05]}
    if base == "free":
        frozen["base"] = [0.3, -0.1, 0.9, 0.8, 0.2, -0.3, 0.4]
    for name, value in frozen.items():
        jid = m.joint(name).id if name != "base" else m.body("base").jntadr[0]
        adr = m.jnt_qposadr[jid]
        c.data.qpos[adr : adr + len(value)] = value
    q_star = np.array([0.4, -0.3, 0.5, 0.6, -0.5, 0.7])
    p, R = c.fk(q_star)
    k = kernel(c)
    check = mujoco.MjData(m)
    for quat in (None, mat_to_quat(R)):
        for iterations in range(6):
            o = (1e-12, 1e-12, 0.25, 0.1, 1e-6, iterations, 4)
            q = c.clip(q_star + 0.3)
            _, _, _, ep, er = k.descend(c.data.qpos, c.qpos_adr, c.dof_adr, site is not None,
                                        c.ee_id, c.lower, c.upper, p, quat, o, q)  # fmt: skip
            check.qpos[:] = c.data.qpos
            check.qpos[c.qpos_adr] = q
            mujoco.mj_kinematics(m, check)
            x = check.site_xpos[c.ee_id] if site else check.xpos[c.ee_id]
            d = [float(x[i] - p[i]) for i in range(3)]
            assert ep == math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            if quat is not None:
                frame = check.site_xmat[c.ee_id] if site else check.xmat[c.ee_id]
                want = orientation_error(frame.reshape(3, 3), quat)
                assert er == pytest.approx(want, abs=1e-12)
    res = make_solver("lm").solve(c, Target(p, mat_to_quat(R)), q0=c.clip(q_star + 0.3))
    assert res.converged  # and the frames it computes take it to the pose


def test_a_kernel_serves_one_thread_at_a_time():
    """Two threads calling one kernel at once: the second is refused (RuntimeError),
    the first finishes; in lm a robot state, and so its kernel, serves one thread."""
    c = Chain()
    k = kernel(c)
    far = np.array([5.0, 0.0, 1.2])
    o = (0.0, 0.0, 0.25, 0.1, 1e-6, 100_000, 100_000)  # a long run without the GIL
    errors: list[BaseException] = []

    def run() -> None:
        try:
            k.descend(c.data.qpos, c.qpos_adr, c.dof_adr, True, c.ee_id, c.lower, c.upper,
                      far, None, o, c.q.copy())  # fmt: skip
        except RuntimeError as exc:
            errors.append(exc)

    threads = [threading.Thread(target=run) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(errors) <= 1  # usually 1; 0 when one call ended before the other began
    assert all("in use by another thread" in str(e) for e in errors)


@pytest.mark.slow
def test_floor_benchmark_reports_the_kernel_against_the_floor():
    """benchmarks/floor.py prints one row per arm with the floor and lm's per-iteration
    cost (its compiled kernel), each with its ratio to that row's floor, and dls's
    (speed itself is the benchmark's business, not a test's)."""
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, str(root / "benchmarks" / "floor.py"), "--k", "10", "--n", "3"],
        capture_output=True, text=True, timeout=300, cwd=root,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    rows = [
        line for line in out.stdout.splitlines() if line.startswith("| ") and "|---" not in line
    ]
    assert rows[0].startswith("| model | floor | C calls |") and "| lm pose |" in rows[0]
    assert "Python loop" not in out.stdout and len(rows) == 5
    for row in rows[1:]:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert len(cells) == 8
        floor = float(cells[1])
        for cell in cells[4:6]:  # "1.37 (0.7x)": lm per iteration, its ratio (both rounded)
            value, ratio = cell.split()
            assert float(ratio.strip("(x)")) == pytest.approx(float(value) / floor, abs=0.1)


@pytest.mark.parametrize("shape", ["cloud", "plane", "line", "point"])
def test_the_seed_ranking_equals_a_full_sort_on_any_library(shape):
    """The grid ranking (``_lm_kernel.seed_nearest``) equals a brute-force sort for
    libraries spread in 3-D, in a plane, on a line and on one point (grids of one cell
    along an axis), for targets inside, near and far outside them, with repeated
    positions (ties in library order) and every count of poses."""
    from humanoid_ik.core.rotations import quat_to_mat
    from humanoid_ik.solvers.jacobian.seeds import grid

    rng = np.random.default_rng(3)
    L = 500
    pos = rng.normal(size=(L, 3)) * [0.4, 0.3, 0.2]
    if shape == "plane":
        pos[:, 2] = 0.7
    elif shape == "line":
        pos[:, 1:] = 0.0
    elif shape == "point":
        pos[:] = [0.1, 0.2, 0.3]
    pos[L // 2 :: 7] = pos[L // 2 - 1]  # repeated positions: equal costs
    rot = np.array([quat_to_mat(q / np.linalg.norm(q)) for q in rng.normal(size=(L, 4))])
    g, cell = grid(pos)
    order = np.argsort(cell, kind="stable")
    pos, rot = pos[order], rot[order]
    cells = np.searchsorted(cell[order], np.arange(int(np.prod(g[4:])) + 1)).astype(np.int64)
    for t in range(40):
        tp = pos[t] + rng.normal(size=3) * (0.0, 0.05, 0.5, 5.0)[t % 4]
        q = rng.normal(size=4)
        R = quat_to_mat(q / np.linalg.norm(q)) if t % 2 else None
        cost = np.linalg.norm(pos - tp, axis=1)
        if R is not None:
            cost = cost + 0.3 * (1.0 - (np.einsum("ij,nij->n", R, rot) - 1.0) / 2.0)
        want = np.argsort(cost, kind="stable")
        for k in (1, 8, 37, L):
            out = np.empty(k, dtype=np.int64)
            r9 = None if R is None else R.reshape(9)
            args = (pos.reshape(-1), rot.reshape(-1), g, cells, tp, r9, 0.3, out)
            assert _lm_kernel.seed_nearest(*args) == k
            np.testing.assert_array_equal(out, want[:k])


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
        want = np.argsort(cost, kind="stable")[:6]
        got = lib.nearest(tgt, 6)
        np.testing.assert_array_equal(got, lib.q[want])
        np.testing.assert_array_equal(lib.nearest(tgt, 1), lib.q[want[:1]])
        assert lib.nearest(tgt, 10_000).shape == lib.q.shape  # all of them, ranked
        np.testing.assert_array_equal(
            lib.nearest(tgt, 10_000), lib.q[np.argsort(cost, kind="stable")]
        )
        # the ranking visits the grid's cells; every pose lies in the cell it is filed in
        low, side, dims = lib.grid[:3], lib.grid[3], lib.grid[4:].astype(int)
        for k in range(int(np.prod(dims))):
            ix, iy, iz = k % dims[0], k // dims[0] % dims[1], k // (dims[0] * dims[1])
            inside = lib.positions[lib.cells[k] : lib.cells[k + 1]] - low
            assert np.all(inside >= np.array([ix, iy, iz]) * side - 1e-12)
            assert np.all(inside <= (np.array([ix, iy, iz]) + 1) * side + 1e-12)
        p, _ = c.fk(got[0])  # the library's FK is MuJoCo's
        np.testing.assert_allclose(p, lib.positions[want[0]], atol=1e-12)
        starts = list(restart_poses(c, c.q, tgt, restarts=5, library_seeds=2, seed=0))
        np.testing.assert_array_equal(starts[1], lib.q[want[0]])
        np.testing.assert_array_equal(starts[3], lib.q[want[1]])
        assert not any(np.array_equal(s, q) for s in starts[5:] for q in lib.q[want[:3]])
        assert all(c.within_limits(s) for s in starts)


def test_random_starts_are_the_seeded_draws_kept_with_the_robot():
    """The random restarts are ``chain.random_q`` from ``default_rng(seed)`` in order,
    drawn once per robot state (a changed model draws them again, inside the new
    ranges), and each start handed out is a copy the solver may overwrite."""
    import copy

    from humanoid_ik.solvers.jacobian.seeds import random_starts, restart_poses

    c = Chain(copy.copy(Chain().model))  # its own model: the test narrows a range
    rng = np.random.default_rng(3)
    want = np.array([c.random_q(rng) for _ in range(4)])
    np.testing.assert_array_equal(random_starts(c, 3, 4), want)
    assert random_starts(c, 3, 4) is random_starts(c, 3, 4)
    starts = list(restart_poses(c, c.q, None, restarts=4, library_seeds=0, seed=3))
    np.testing.assert_array_equal(np.array(starts[1:]), want)
    starts[1][:] = 0.0
    np.testing.assert_array_equal(random_starts(c, 3, 4)[0], want[0])
    j = c.joint_ids[0]
    c.model.jnt_range[j] = (want[0][0] - 0.01, want[0][0] + 0.01)  # the live model narrowed
    c.sync()
    again = random_starts(c, 3, 4)
    assert np.all(np.abs(again[:, 0] - want[0][0]) <= 0.01 + 1e-12)


def test_threads_on_a_shared_model_match_one_thread():
    """The kernel runs without the GIL: two threads, each with its own chain (and so its
    own robot state and kernel) on one shared MjModel, sharing one solver object, give
    the serial answers bit for bit."""
    from concurrent.futures import ThreadPoolExecutor

    model = Chain().model
    targets = make_targets(Chain(model), 30, 21, True)
    shared = make_solver("lm")

    def run(_: int = 0) -> list:
        c = Chain(model)
        return [shared.solve(c, t).q for t in targets]

    serial = run()
    with ThreadPoolExecutor(2) as pool:
        outs = list(pool.map(run, range(2)))
    for out in outs:
        assert len(out) == len(serial)
        for q, q1 in zip(out, serial, strict=True):
            np.testing.assert_array_equal(q, q1)


@pytest.mark.slow
def test_seed_ranking_benchmark_checks_every_ranking():
    """benchmarks/seed_ranking.py prints, per arm, the library's grid, the CPU median and
    p95 of a ranking, and how many rankings differ from a full sort: none."""
    root = Path(__file__).resolve().parents[1]
    script = str(root / "benchmarks" / "seed_ranking.py")
    out = subprocess.run(
        [sys.executable, script, "--n", "6", "--arms", "baxter,ur5"],
        capture_output=True, text=True, timeout=300, cwd=root,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    rows = out.stdout.splitlines()
    assert [r.split()[0] for r in rows] == ["baxter", "ur5"]
    for row in rows:
        assert row.split()[1] == "4000" and "CPU median" in row and " us, p95 " in row
        assert row.endswith("0 of 6 rankings unlike a full sort")


def test_the_compiled_restarts_follow_the_documented_starts():
    """``lm``'s restarts run in C (``Kernel.restart``); a loop of ``descend`` over
    ``LM.starts`` (``seeds.restart_poses``: the library's nearest poses alternating with
    random ones) with the best pose by ``iterate.pose_cost`` gives the same answers, bit
    for bit: on Baxter's left arm from home (most pose targets restart) and on position
    targets, including two out of reach (every start runs)."""
    from humanoid_ik import load_model
    from humanoid_ik.core.limbs import limb_chain
    from humanoid_ik.core.robot import Robot
    from humanoid_ik.solvers.iterate import Best, pose_cost
    from tests.chains import fk_poses
    from tests.robots import robot_file

    arm = limb_chain(Robot(load_model(robot_file("baxter"))), "left_arm")
    solver = make_solver("lm")
    targets = fk_poses(arm, 24, seed=3)
    targets += [Target(t.position) for t in targets[:6]]
    targets += [Target([3.0, 0.0, 1.0]), Target([0.0, 3.0, 1.0], targets[0].quat)]
    q0, k, restarted, missed = arm.q_home, kernel(arm), 0, 0
    for target in targets:
        got = solver.solve(arm, target, q0)
        best, iterations, want, used = Best(q0), 0, None, 0
        for q in solver.starts(arm, q0.copy(), target):
            ok, its, _c, ep, er = k.descend(
                arm.data.qpos, arm.qpos_adr, arm.dof_adr, arm.ee_kind == "site", arm.ee_id,
                arm.lower, arm.upper, target.position, target.quat, solver.kernel_options(), q,
            )  # fmt: skip
            iterations, used = iterations + its, used + 1
            if ok:
                want = q
                break
            best.offer(q, pose_cost(ep, er))
        np.testing.assert_array_equal(got.q, best.q if want is None else want)
        assert got.iterations == iterations and got.converged == (want is not None)
        restarted += used > 1
        missed += want is None
    assert restarted >= 10 and missed == 2
    # its arguments are checked like solve's
    problem = (
        arm.data.qpos, arm.qpos_adr, arm.dof_adr, arm.ee_kind == "site", arm.ee_id, arm.lower,
        arm.upper,
        np.zeros(3), None, solver.kernel_options(), q0.copy(), None,
    )  # fmt: skip
    randoms = np.zeros(20 * arm.n)
    with pytest.raises(TypeError, match=r"restart\(\) takes 17 arguments, got 0"):
        k.restart()
    with pytest.raises(ValueError, match=r"library_seeds and restarts must be in \[0, 4000\]"):
        k.restart(*problem, None, -1, randoms, 20, math.inf)
    with pytest.raises(ValueError, match="randoms must have 140 values"):
        k.restart(*problem, None, 0, randoms[:7], 20, math.inf)
    with pytest.raises(TypeError, match="library must be None or"):
        k.restart(*problem, (1, 2), 8, randoms, 20, math.inf)
    with pytest.raises(ValueError, match="mocap_pos must have 0 values"):
        k.set_mocap(np.zeros(3), np.zeros(4))
