"""The mink solver: single-chain IK, both hands + gaze in one QP, limits, collisions,
frozen joints, the gaze and position task Jacobians, the QP step against mink's public
``solve_ik``, the caches in the robot workspace, one solver object shared by two
threads, the options, the private-name adapter, and the errors it raises.

The bundled humanoid's effectors are named here and its collision pairs are read from
``scenes/upper_body_mink.toml``: the solver itself has no robot-specific defaults.

Real mink and daqp throughout, no mocks.
"""

from __future__ import annotations

import ast
import math
import subprocess
import sys
import threading
import warnings
from pathlib import Path
from typing import NamedTuple

import mink
import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray

from humanoid_ik import (
    SOLVERS,
    Chain,
    ChainError,
    NameNotFoundError,
    SolverError,
    Target,
    TargetError,
    make_solver,
    solve,
)
from humanoid_ik.core.limbs import find_limbs, limb_chain
from humanoid_ik.core.measures import axis_vector, gaze_error
from humanoid_ik.core.models import COLLISION_GROUP, load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import mat_to_quat, rotation_log
from humanoid_ik.experiments.bench import make_targets
from humanoid_ik.solvers import mink as mink_solver
from humanoid_ik.solvers.mink import (
    CollisionLimit,
    GazeTask,
    JointRangeLimit,
    JointVelocityLimit,
    MinkOptions,
    MinkSolver,
    PositionTask,
    UpperBodyIK,
    UpperBodyResult,
)
from humanoid_ik.solvers.mink.pairs import limb_collision_pairs
from tests.robots import robot_file

from .chains import SMALL_ARM_XML, model

HANDS = ("right_palm_site", "left_palm_site")
GAZE = "gaze_site"
_BODY = ("torso_collision", "chest_collision", "head_collision")
PAIRS = MinkOptions(
    collision_pairs=[
        [["right_forearm_collision", "right_hand_collision"], _BODY],
        [["left_forearm_collision", "left_hand_collision"], _BODY],
        [["right_hand_collision"], ["left_hand_collision"]],
    ]
).collision_pairs
"""The bundled humanoid's collision pairs, by name (what ``scenes/upper_body_mink.toml``'s
``collision_pairs = "limbs"`` derives)."""


def _upper_body(model=None, **kwargs) -> UpperBodyIK:
    """UpperBodyIK on the bundled humanoid (or ``model``): both hands, the gaze and the
    scene's collision pairs unless ``kwargs`` say otherwise."""
    kwargs.setdefault("hands", HANDS)
    kwargs.setdefault("gaze", GAZE)
    kwargs.setdefault("collision_pairs", PAIRS)
    return UpperBodyIK(Robot() if model is None else model, **kwargs)


class Goal(NamedTuple):
    """The scene runner's multi-effector goal (chain, target, warm start, task)."""

    chain: Chain
    target: Target
    q0: np.ndarray
    task: str


ARM_GEOMS = [
    "right_forearm_collision",
    "right_hand_collision",
    "left_forearm_collision",
    "left_hand_collision",
]
BODY_GEOMS = ["torso_collision", "chest_collision", "head_collision"]


def _targets(chain: Chain, n: int, seed: int, pose: bool) -> list[Target]:
    return make_targets(chain, n, seed, pose)


def _min_distance(m: mujoco.MjModel, d: mujoco.MjData) -> float:
    """Smallest distance [m] of any forearm/hand geom to torso, chest or head, or of
    the two hands to each other (MuJoCo's ``mj_geomDistance``)."""
    ft = np.zeros(6)
    gid = [m.geom(n).id for n in ARM_GEOMS]
    bid = [m.geom(n).id for n in BODY_GEOMS]
    dists = [mujoco.mj_geomDistance(m, d, a, b, 1.0, ft) for a in gid for b in bid]
    dists.append(mujoco.mj_geomDistance(m, d, gid[1], gid[3], 1.0, ft))
    return min(dists)


def _frozen_dofs(m: mujoco.MjModel, chain: Chain) -> np.ndarray:
    return np.setdiff1d(np.arange(m.nv), chain.dof_adr)


# ---------------------------------------------------------------------------- single chain
@pytest.mark.parametrize(
    "make_chain",
    [lambda: Chain(), lambda: Chain(model(SMALL_ARM_XML), "tip")],
    ids=["humanoid", "small_arm"],
)
def test_single_chain_reaches_fk_targets(make_chain):
    """60 reachable position targets: every solution within 1 mm and inside the ranges."""
    chain = make_chain()
    checker = Chain(chain.model, chain.ee_name)
    solver = make_solver("mink")
    for tgt in _targets(chain, 60, seed=21, pose=False):
        chain.reset()
        res = solver.solve(chain, tgt)
        p, _ = checker.fk(res.q)
        assert np.linalg.norm(p - tgt.position) < 1e-3
        assert res.position_error == pytest.approx(np.linalg.norm(p - tgt.position), abs=1e-12)
        assert chain.within_limits(res.q, tol=0.0)
        assert res.converged and res.solver == "mink"


def test_single_chain_reaches_pose_targets():
    """40 reachable pose targets on the right arm: within 1 mm and 0.01 rad, in range."""
    chain = Chain()
    checker = Chain()
    solver = MinkSolver()
    for tgt in _targets(chain, 40, seed=22, pose=True):
        chain.reset()
        res = solver.solve(chain, tgt)
        p, R = checker.fk(res.q)
        assert np.linalg.norm(p - tgt.position) < 1e-3
        assert np.linalg.norm(rotation_log(tgt.rotation @ R.T)) < 1e-2
        assert chain.within_limits(res.q, tol=0.0)


@pytest.mark.parametrize(
    "make_chain",
    [lambda: Chain(), lambda: Chain(model(SMALL_ARM_XML), "tip")],
    ids=["humanoid", "small_arm"],
)
def test_joints_outside_the_chain_stay_exactly(make_chain):
    """Neck, other arm, free base and slide joints keep their values bit for bit."""
    chain = make_chain()
    m = chain.model
    rng = np.random.default_rng(3)
    others = np.setdiff1d(np.arange(m.nq), chain.qpos_adr)
    chain.data.qpos[others] += rng.uniform(-0.3, 0.3, others.size)
    mujoco.mj_normalizeQuat(m, chain.data.qpos)
    before = chain.data.qpos[others].copy()
    solver = MinkSolver()
    for tgt in _targets(chain, 10, seed=4, pose=False):
        chain.data.qpos[others] = before
        res = solver.solve(chain, tgt)
        assert res.converged
        ik = solver.upper_body(chain)
        assert np.array_equal(ik.q[others], before)
        assert np.all(np.abs(ik.last_dq[_frozen_dofs(m, chain)]) < 1e-12)


def test_mink_by_name_in_solve_and_registry():
    """'mink' is registered and works through api.solve with pose targets."""
    assert SOLVERS["mink"] is MinkSolver
    chain = Chain()
    p, R = chain.fk([0.5, 0.3, 0.1, 1.1, 0.2, 0.1, 0.0])
    chain.reset()
    res = solve(chain, p, "mink", quat=mat_to_quat(R))
    assert res.converged and res.position_error < 1e-4 and res.orientation_error < 1e-3


def test_importing_the_package_does_not_import_mink():
    """import humanoid_ik stays light: mink is imported when a mink solver is built."""
    code = "import sys, humanoid_ik; print('mink' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ---------------------------------------------------------------------------- infeasible start
def test_frozen_joint_outside_its_range_does_not_fail():
    """A frozen joint outside its range: the raw mink QP is infeasible, ours solves."""
    chain = Chain()
    m = chain.model
    elbow_l = m.joint("left_elbow_joint")
    neck = m.joint("neck_yaw_joint")
    chain.data.qpos[elbow_l.qposadr[0]] = -0.5  # range [0, 2.62]
    chain.data.qpos[neck.qposadr[0]] = 2.0  # range [-1.4, 1.4]

    # mink's own limit on every joint plus the freeze: no solution
    cfg = mink.Configuration(m, chain.data.qpos.copy())
    task = mink.FrameTask("right_palm_site", "site", position_cost=1.0, orientation_cost=0.0)
    task.set_target(mink.SE3.from_translation(np.array([0.3, -0.3, 1.1])))
    freeze = mink.DofFreezingTask(m, _frozen_dofs(m, chain).tolist())
    with pytest.raises(mink.NoSolutionFound):
        mink.solve_ik(
            cfg, [task], 0.01, "daqp", limits=[mink.ConfigurationLimit(m)], constraints=[freeze]
        )

    before = chain.data.qpos.copy()
    res = MinkSolver().solve(chain, [0.3, -0.3, 1.1])
    assert res.converged
    ik = make_solver("mink").upper_body(chain)
    ik.set_q(before)
    r = ik.step({"right_palm_site": [0.3, -0.3, 1.1]}, 0.01)
    assert r.q[elbow_l.qposadr[0]] == -0.5 and r.q[neck.qposadr[0]] == 2.0
    assert chain.within_limits(r.q[chain.qpos_adr], tol=0.0)


def test_active_joint_outside_its_range_is_moved_inside():
    """An active joint starting outside its range is clipped in before the step."""
    ik = _upper_body()
    q = ik.q_home.copy()
    elbow = ik.model.joint("right_elbow_joint").qposadr[0]
    q[elbow] = -0.4
    ik.set_q(q)
    res = ik.step({"right_palm_site": [0.3, -0.3, 1.1]}, 0.01)
    assert 0.0 <= res.q[elbow] <= 2.62


# ---------------------------------------------------------------------------- tracking
def test_limits_never_violated_over_a_long_tracking_run():
    """2000 steps after targets sweeping through and far beyond the workspace: every
    joint inside its range and every step within the velocity limit."""
    ik = _upper_body(max_velocity=3.0)
    chains = list(ik.chains.values())
    lo = np.concatenate([c.lower for c in chains])
    hi = np.concatenate([c.upper for c in chains])
    adr = np.concatenate([c.qpos_adr for c in chains])
    dt = 0.01
    prev = ik.q[adr]
    at_limit = 0
    for i in range(2000):
        t = i * dt
        right = [
            0.2 + 0.9 * math.sin(1.3 * t),
            -0.3 + 0.9 * math.cos(0.7 * t),
            1.2 + 0.8 * math.sin(t),
        ]
        left = [
            0.2 + 0.9 * math.cos(1.1 * t),
            0.3 + 0.9 * math.sin(0.9 * t),
            1.2 - 0.8 * math.sin(t),
        ]
        gaze = [math.cos(0.5 * t), 2.0 * math.sin(0.5 * t), 1.5 + math.sin(0.3 * t)]
        ik.step({"right_palm_site": right, "left_palm_site": left, "gaze_site": gaze}, dt)
        q = ik.q[adr]
        assert np.all(q >= lo) and np.all(q <= hi), i
        assert np.all(np.abs(q - prev) <= 3.0 * dt + 1e-9), i
        at_limit += int(np.any(np.isclose(q, lo, atol=1e-3) | np.isclose(q, hi, atol=1e-3)))
        prev = q
    assert at_limit > 100  # the run did push joints to their range ends


def test_collisions_avoided_while_pulled_through_the_torso():
    """Targets pulling each hand through the torso: the minimum distance of the forearm
    and hand geoms to torso, chest and head (and hand to hand) stays positive; without
    collision pairs the same run goes through."""

    def run(ik: UpperBodyIK) -> float:
        worst = math.inf
        for i in range(300):
            s = i / 299
            right = [0.45 - 0.75 * s, -0.35 + 0.55 * s, 1.20]
            left = [0.45 - 0.75 * s, 0.35 - 0.55 * s, 1.25]
            ik.step({"right_palm_site": right, "left_palm_site": left, "gaze_site": right}, 0.01)
            worst = min(worst, _min_distance(ik.model, ik.configuration.data))
        return worst

    ik = _upper_body()
    assert _min_distance(ik.model, ik.configuration.data) > 0.05
    worst = run(ik)
    assert worst > 0.0
    assert worst >= 0.5 * ik.options.min_distance - 1e-6
    assert run(_upper_body(collision_pairs=None)) < -0.02


# ---------------------------------------------------------------------------- gaze
def _fd_jacobian(task, cfg: mink.Configuration, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    J = np.empty((3, cfg.nv))
    for i in range(cfg.nv):
        qp, qm = q.copy(), q.copy()
        qp[i] += h
        qm[i] -= h
        cfg.update(qp)
        ep = task.compute_error(cfg)
        cfg.update(qm)
        em = task.compute_error(cfg)
        J[:, i] = (ep - em) / (2 * h)
    cfg.update(q)
    return J


@pytest.mark.parametrize("axis", ["x", "y", "z", (0.2, -0.5, 1.0)])
def test_gaze_jacobian_matches_finite_differences(axis):
    """GazeTask J = -[f]x J_w + (I - d d') J_v / n equals central differences of e, for
    every forward axis."""
    chain = Chain(None, "gaze_site")
    m = chain.model
    cfg = mink.Configuration(m)
    rng = np.random.default_rng(5)
    task = GazeTask(m, "gaze_site", axis=axis)
    for _ in range(5):
        q = m.qpos0.copy()
        q[chain.qpos_adr] = chain.random_q(rng)
        cfg.update(q)
        task.set_target(rng.uniform([0.2, -1, 0.8], [2, 1, 2.5]))
        J = task.compute_jacobian(cfg)
        np.testing.assert_allclose(J, _fd_jacobian(task, cfg, q), atol=1e-7)


@pytest.mark.parametrize("axis", ["x", "y", "z", (0.2, -0.5, 1.0)])
def test_gaze_error_is_f_minus_d_and_matches_the_shared_measure(axis):
    """e = R a - (p* - p) / |p* - p| from MuJoCo FK, |e| = 2 sin(theta / 2) with theta the
    angle of core.measures.gaze_error, and error() is that shared measure."""
    chain = Chain(None, "gaze_site")
    m = chain.model
    cfg = mink.Configuration(m)
    rng = np.random.default_rng(15)
    task = GazeTask(m, "gaze_site", axis=axis)
    a = axis_vector(axis)
    sid = m.site("gaze_site").id
    for _ in range(5):
        q = m.qpos0.copy()
        q[chain.qpos_adr] = chain.random_q(rng)
        cfg.update(q)
        target = rng.uniform([0.2, -1, 0.8], [2, 1, 2.5])
        task.set_target(target)
        p, R = cfg.data.site_xpos[sid], cfg.data.site_xmat[sid].reshape(3, 3)
        d = (target - p) / np.linalg.norm(target - p)
        e = task.compute_error(cfg)
        np.testing.assert_allclose(e, R @ a - d, atol=1e-12)
        shared = gaze_error(p, R, a, target)
        assert task.error(cfg) == pytest.approx(shared, abs=1e-12)
        assert np.linalg.norm(e) == pytest.approx(2 * math.sin(shared.angle / 2), abs=1e-12)


def test_gaze_error_is_the_aim_misalignment():
    """|e| = 2 sin(theta/2), zero when aiming at the target, 2 when aiming away."""
    m = Chain().model
    cfg = mink.Configuration(m)
    cfg.update_from_keyframe("home")
    task = GazeTask(m, "gaze_site")
    p = cfg.data.site_xpos[m.site("gaze_site").id].copy()
    task.set_target(p + [1.0, 0.0, 0.0])
    assert np.linalg.norm(task.compute_error(cfg)) < 1e-12
    task.set_target(p + [-1.0, 0.0, 0.0])
    assert np.linalg.norm(task.compute_error(cfg)) == pytest.approx(2.0)
    task.set_target(p + [1.0, 1.0, 0.0])
    miss, theta = task.error(cfg)
    assert theta == pytest.approx(math.pi / 4)
    assert np.linalg.norm(task.compute_error(cfg)) == pytest.approx(2 * math.sin(math.pi / 8))
    assert miss == pytest.approx(1.0)  # |(1, 1)| sin 45 deg


@pytest.mark.skipif(not hasattr(mink, "LookAtTask"), reason="mink.LookAtTask is new in 1.3")
def test_gaze_gradient_matches_mink_look_at_task():
    """Same error norm as mink's LookAtTask, so the same QP gradient c = -J' W^2 e."""
    chain = Chain(None, "gaze_site")
    m = chain.model
    cfg = mink.Configuration(m)
    rng = np.random.default_rng(6)
    ours = GazeTask(m, "gaze_site", cost=1.0)
    theirs = mink.LookAtTask("gaze_site", "site", axis=(1.0, 0.0, 0.0), cost=1.0)
    for _ in range(5):
        q = m.qpos0.copy()
        q[chain.qpos_adr] = chain.random_q(rng)
        cfg.update(q)
        tgt = rng.uniform([0.2, -1, 0.8], [2, 1, 2.5])
        ours.set_target(tgt)
        theirs.set_target(tgt)
        assert np.linalg.norm(ours.compute_error(cfg)) == pytest.approx(
            np.linalg.norm(theirs.compute_error(cfg))
        )
        np.testing.assert_allclose(
            ours.compute_qp_objective(cfg).c, theirs.compute_qp_objective(cfg).c, atol=1e-12
        )


@pytest.mark.parametrize("point", [[1.0, 0.3, 1.5], [1.0, -0.5, 1.8], [0.5, 0.0, 1.3]])
def test_gaze_converges_to_the_target_direction(point):
    """solve() turns the head until the gaze site's x axis points at the target."""
    ik = _upper_body()
    res = ik.solve({"gaze_site": point})
    assert res.converged and res.iterations < 20
    checker = Chain(None, "gaze_site")
    p, R = checker.fk(res.q[checker.qpos_adr])
    v = np.asarray(point) - p
    assert math.acos(min(1.0, R[:, 0] @ v / np.linalg.norm(v))) < 1e-3


# ---------------------------------------------------------------------------- jointly
def test_one_qp_step_reduces_both_hands_and_gaze_errors():
    """One step with both hands and the gaze lowers all three errors and moves all 16."""
    ik = _upper_body()
    p, R = Chain().fk([0.7, 0.3, 0.2, 1.3, 0.3, 0.2, 0.1])
    targets = {
        "right_palm_site": Target(p, mat_to_quat(R)),
        "left_palm_site": [0.35, 0.3, 1.15],
        "gaze_site": [1.0, -0.3, 1.3],
    }
    r0 = ik.measure(targets)
    assert r0.iterations == 0 and np.array_equal(r0.q, ik.q)
    res = ik.step(targets, 0.05)
    assert isinstance(res, UpperBodyResult) and res.iterations == 1
    for name in targets:
        assert res[name].position_error < r0[name].position_error
        if name != "left_palm_site":
            assert res[name].orientation_error < r0[name].orientation_error
    assert np.all(np.abs(ik.last_dq) > 1e-6)  # every joint took part in the one QP
    full = ik.solve(targets)
    assert full.converged, full.message


def test_absent_targets_freeze_their_chain():
    """A step with the right hand only keeps the left arm and the neck exactly."""
    ik = _upper_body()
    before = ik.q
    res = ik.step({"right_palm_site": [0.3, -0.3, 1.1], "left_palm_site": None}, 0.01)
    moved = np.flatnonzero(res.q != before)
    assert set(moved) <= set(ik.chains["right_palm_site"].qpos_adr)
    assert list(res.effectors) == ["right_palm_site"]


def test_load_and_apply_touch_only_chain_joints():
    """load() reads the caller's qpos; apply() writes the chains' joints and runs FK."""
    ik = _upper_body(hands=("right_palm_site",), gaze=None)
    m = ik.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    d.qpos[0] = 0.4
    ik.load(d)
    ik.solve({"right_palm_site": [0.3, -0.3, 1.1]})
    assert list(ik.chains) == ["right_palm_site"]
    ik.apply(d)
    assert d.qpos[0] == 0.4
    assert np.linalg.norm(d.site("right_palm_site").xpos - [0.3, -0.3, 1.1]) < 1e-4


def test_result_is_read_only():
    """UpperBodyResult: q and the per-effector mapping cannot be changed."""
    ik = _upper_body()
    res = ik.step({"gaze_site": [1.0, 0.0, 1.5]}, 0.01)
    with pytest.raises(ValueError):
        res.q[0] = 1.0
    with pytest.raises(TypeError):
        res.effectors["x"] = res["gaze_site"]  # type: ignore[index]


def test_empty_targets_do_nothing():
    """No targets: no step, nothing moves, a converged empty result."""
    ik = _upper_body()
    before = ik.q
    for res in (ik.step({}, 0.01), ik.solve({"left_palm_site": None})):
        assert res.iterations == 0 and res.converged and not res.effectors
    assert np.array_equal(ik.q, before)


def test_unreachable_target_stops_with_a_reason():
    """A target 3 m away: solve stops (stall or max_iterations) with the reason."""
    ik = _upper_body(max_iterations=30)
    res = ik.solve({"right_palm_site": [3.0, -3.0, 1.0]})
    assert not res.converged and res.status == "max_iterations" and res.message


@pytest.mark.parametrize("restarts, max_iterations", [(0, 5), (2, 40), (20, 200)])
def test_gave_up_message_agrees_with_the_options(capsys, restarts, max_iterations):
    """An unreachable target: ``iterations`` sums every start's QP steps, never more than
    ``(restarts + 1) * max_iterations``, and the note names that sum, the per-start cap
    and the start whose pose is returned, with a count within that cap (the CLI printed
    the sum as "max_iterations after 391 iteration(s)" next to the closest start's own
    "stalled after 17 iterations", as if the documented cap of 200 had been exceeded)."""
    from humanoid_ik.cli import main

    argv = ["solve", "--solver", "mink", "--target=3,-3,1"]
    argv += ["--option", f"restarts={restarts}", "--option", f"max_iterations={max_iterations}"]
    assert main(argv) == 1
    out = capsys.readouterr().out.splitlines()
    head, note = out[0], out[-1]
    total = int(head.split(" after ")[1].split()[0])
    assert head == f"solver mink: max_iterations after {total} iteration(s)"
    assert restarts + 1 <= total <= (restarts + 1) * max_iterations
    assert note.startswith(f"note: no start of {restarts + 1} converged")
    assert f"; {total} iterations in all, at most {max_iterations} per start; start " in note
    start = int(note.split("; start ")[1].split()[0])
    assert 1 <= start <= restarts + 1
    why = note.split("(the closest): ")[1]
    own = int(why.split(" iterations")[0].split()[-1])  # "stalled after k" / "... in k"
    assert 1 <= own <= max_iterations


def _goals(tasks=("reach", "reach", "look_at")) -> list[Goal]:
    m = Chain().model
    sites = ["right_palm_site", "left_palm_site", "gaze_site"]
    chains = [Chain(m, s) for s in sites]
    targets = [Target([0.35, -0.25, 1.1]), Target([0.35, 0.25, 1.15]), Target([1.0, -0.2, 1.4])]
    return [Goal(c, t, c.q_home, k) for c, t, k in zip(chains, targets, tasks, strict=True)]


def test_solve_effectors_moves_hands_and_gaze_together():
    """The runner hook: dt = 0 converges all three; dt > 0 is one rate-limited step."""
    goals = _goals()
    out = MinkSolver(collision_pairs=PAIRS).solve_effectors(goals)
    assert [r.converged for r in out] == [True, True, True]
    for g, r in zip(goals, out, strict=True):
        assert g.chain.within_limits(r.q, tol=0.0)
    p, _ = goals[0].chain.fk(out[0].q)
    assert np.linalg.norm(p - goals[0].target.position) < 1e-4
    solver = MinkSolver(dt=0.01, max_velocity=2.0)
    out = solver.solve_effectors(goals)
    assert all(r.iterations == 1 for r in out)
    for g, r in zip(goals, out, strict=True):
        assert np.all(np.abs(r.q - g.q0) <= 0.02 + 1e-12)
    assert solver.solve_effectors([]) == []


def test_solve_effectors_refuses_bad_goals():
    """Two look_at effectors or an unknown task: a SolverError naming them."""
    with pytest.raises(SolverError, match="one look_at effector"):
        MinkSolver().solve_effectors(_goals(("reach", "look_at", "look_at")))
    with pytest.raises(SolverError, match="task 'wave' .* tasks: look_at, reach"):
        MinkSolver().solve_effectors(_goals(("reach", "wave", "look_at")))


# ---------------------------------------------------------------------------- parts
def test_position_task_jacobian_matches_finite_differences():
    """PositionTask e = p - p*, J = J_v: central differences of e, site and body."""
    m = Chain().model
    cfg = mink.Configuration(m)
    rng = np.random.default_rng(8)
    for name, kind in [("right_palm_site", "site"), ("left_hand_link", "body")]:
        task = PositionTask(m, name, kind)
        task.set_target([0.3, 0.0, 1.0])
        q = m.qpos0 + rng.uniform(-0.5, 0.5, m.nq)
        cfg.update(q)
        pos = (
            cfg.data.site_xpos[m.site(name).id]
            if kind == "site"
            else cfg.data.xpos[m.body(name).id]
        )
        np.testing.assert_allclose(task.compute_error(cfg), pos - [0.3, 0.0, 1.0])
        np.testing.assert_allclose(
            task.compute_jacobian(cfg), _fd_jacobian(task, cfg, q), atol=1e-7
        )


def test_range_and_velocity_limit_rows():
    """Rows gain (q_min - q) <= dq <= gain (q_max - q) and |dq| <= v dt on chosen joints."""
    m = Chain().model
    cfg = mink.Configuration(m)
    q = m.qpos0.copy()
    j = m.joint("right_elbow_joint")
    q[j.qposadr[0]] = 1.0
    cfg.update(q)
    rng_lim = JointRangeLimit(m, [j.id], gain=0.5)
    G, h = rng_lim.compute_qp_inequalities(cfg, 0.01)
    assert G.shape == (2, m.nv) and G[0, j.dofadr[0]] == 1.0 and G[1, j.dofadr[0]] == -1.0
    np.testing.assert_allclose(h, [0.5 * (2.62 - 1.0), 0.5 * (1.0 - 0.0)])
    vel = JointVelocityLimit(m, [j.id], max_velocity=2.0)
    G, h = vel.compute_qp_inequalities(cfg, 0.01)
    np.testing.assert_allclose(h, [0.02, 0.02])
    assert JointRangeLimit(m, []).compute_qp_inequalities(cfg, 0.01).inactive
    assert JointVelocityLimit(m, [], 1.0).compute_qp_inequalities(cfg, 0.01).inactive


def test_collision_rows_are_displacement_bounds():
    """Row -n'(J2 - J1) dq <= gain (d - d_min) whatever dt, and -G dq predicts the
    change of distance to first order."""
    ik = _upper_body()
    m = ik.model
    q = ik.q_home.copy()
    q[ik.chains["right_palm_site"].qpos_adr] = [0.3, -0.2, 0.5, 2.0, 0.0, 0.0, 0.0]
    cfg = mink.Configuration(m, q)
    lim = CollisionLimit(m, PAIRS, gain=0.5, collision_detection_distance=0.3)
    G1, h1 = lim.compute_qp_inequalities(cfg, 0.01)
    G2, h2 = lim.compute_qp_inequalities(cfg, 1.0)
    np.testing.assert_array_equal(h1, h2)
    active = np.flatnonzero(np.isfinite(h1))
    assert active.size > 0
    dmin = lim.minimum_distance_from_collisions
    d0 = lim.last_distances.copy()
    np.testing.assert_allclose(h1[active], 0.5 * (d0[active] - dmin))
    dq = np.random.default_rng(9).normal(size=m.nv) * 1e-5
    cfg.update(q + dq)
    d1 = lim.distances(cfg.data, np.empty(len(d0)))
    np.testing.assert_allclose(d1[active] - d0[active], -G1[active] @ dq, atol=1e-8)


# ---------------------------------------------------------------------------- vs mink
class _PlainTask(mink.Task):
    """One of our tasks seen through mink's public task interface only
    (``compute_error`` and ``compute_jacobian``), so that mink's own generic path, not
    ours, turns it into QP rows."""

    def __init__(self, task: mink.Task):
        super().__init__(cost=task.cost, gain=task.gain, lm_damping=task.lm_damping)
        self.task = task

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        return self.task.compute_error(configuration)

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        return self.task.compute_jacobian(configuration)


def _mink_solve_ik(ik: UpperBodyIK, q: np.ndarray, targets: dict, dt: float) -> np.ndarray:
    """The displacement ``(nv,)`` of ``mink.solve_ik`` from ``q`` on the tasks and limits
    of ``ik.step(targets, dt)``, built from mink's public API: FrameTask, PostureTask,
    ConfigurationLimit, VelocityLimit, CollisionAvoidanceLimit, DofFreezingTask (our
    position and gaze tasks through :class:`_PlainTask`)."""
    m, o = ik.model, ik.options
    tasks: list = []
    for name, value in targets.items():
        if name == "gaze_site":
            gaze = GazeTask(m, name, cost=o.gaze_cost)
            gaze.set_target(value)
            tasks.append(_PlainTask(gaze))
        elif isinstance(value, Target) and value.is_pose:
            frame = mink.FrameTask(
                name,
                "site",
                position_cost=o.position_cost,
                orientation_cost=o.orientation_cost,
                lm_damping=o.lm_damping,
            )
            frame.set_target(mink.SE3(np.concatenate([value.quat, value.position])))
            tasks.append(frame)
        else:
            pos = PositionTask(m, name, cost=o.position_cost, lm_damping=o.lm_damping)
            pos.set_target(value)
            tasks.append(_PlainTask(pos))
    posture = mink.PostureTask(m, cost=o.posture_cost, gain=o.posture_gain)
    posture.set_target(ik.q_home)
    tasks.append(posture)
    joints = [m.joint(j).name for c in ik.chains.values() for j in c.joint_ids]
    limits: list = [
        mink.ConfigurationLimit(m, gain=o.range_gain),
        mink.VelocityLimit(m, dict.fromkeys(joints, o.max_velocity)),
    ]
    if ik.collision_limit is not None:
        limits.append(
            mink.CollisionAvoidanceLimit(
                m,
                PAIRS,
                gain=o.collision_gain,
                minimum_distance_from_collisions=o.min_distance,
                collision_detection_distance=o.detection_distance,
            )
        )
    active = np.concatenate([ik.chains[n].dof_adr for n in targets])
    frozen = np.setdiff1d(np.arange(m.nv), active)
    freeze = [mink.DofFreezingTask(m, frozen.tolist())] if frozen.size else None
    cfg = mink.Configuration(m, q.copy())
    v = mink.solve_ik(cfg, tasks, dt, "daqp", damping=o.damping, limits=limits, constraints=freeze)
    return v * dt


def _case_hands_and_gaze() -> tuple[UpperBodyIK, np.ndarray, dict, float]:
    """Both hands (right pose, left position) and the gaze, with error-scaled damping:
    the velocity limit binds on some joints."""
    ik = _upper_body(collision_pairs=None, lm_damping=0.01)
    q = ik.q_home.copy()
    q[ik.chains["right_palm_site"].qpos_adr] = [0.3, 0.2, 0.1, 1.0, 0.2, 0.1, 0.0]
    q[ik.chains["left_palm_site"].qpos_adr] = [0.2, 0.1, -0.1, 0.8, -0.2, 0.0, 0.1]
    p, R = Chain().fk([0.7, 0.3, 0.2, 1.3, 0.3, 0.2, 0.1])
    targets = {
        "right_palm_site": Target(p, mat_to_quat(R)),
        "left_palm_site": np.array([0.35, 0.3, 1.15]),
        "gaze_site": np.array([1.0, -0.3, 1.3]),
    }
    return ik, q, targets, 0.1


def _case_collisions() -> tuple[UpperBodyIK, np.ndarray, dict, float]:
    """The right hand pulled into the torso: a collision row binds. dt = 1 s, where mink's
    collision bound (divided by dt) and ours (a displacement) agree."""
    ik = _upper_body(max_velocity=1.0)
    q = ik.q_home.copy()
    q[ik.chains["right_palm_site"].qpos_adr] = [0.3, -0.2, 0.5, 2.0, 0.0, 0.0, 0.0]
    targets = {"right_palm_site": np.array([-0.1, 0.0, 1.2])}
    return ik, q, targets, 1.0


def _case_one_chain() -> tuple[UpperBodyIK, np.ndarray, dict, float]:
    """One arm with a pose target (MinkSolver's case); the other joints frozen away
    from home."""
    ik = _upper_body(hands=("right_palm_site",), gaze=None, collision_pairs=None)
    m = ik.model
    q = ik.q_home.copy()
    for name, value in [("left_elbow_joint", 1.2), ("neck_yaw_joint", 0.4)]:
        q[m.joint(name).qposadr[0]] = value
    p, R = Chain().fk([0.5, 0.3, 0.1, 1.1, 0.2, 0.1, 0.0])
    return ik, q, {"right_palm_site": Target(p, mat_to_quat(R))}, 0.1


@pytest.mark.parametrize(
    "case",
    [_case_hands_and_gaze, _case_collisions, _case_one_chain],
    ids=["hands_and_gaze", "collisions", "one_chain"],
)
def test_qp_step_matches_mink_solve_ik(case):
    """UpperBodyIK's QP step (our buffered tasks through the adapter, our limits) finds
    the same displacement, to 1e-8, as mink's public solve_ik on the same tasks and
    limits from the same configuration (daqp both). A mink release that changes the
    private names the adapter uses fails here."""
    ik, q, targets, dt = case()
    ik.set_q(q)
    ik.step(targets, dt)
    ours = ik.last_dq
    theirs = _mink_solve_ik(ik, q, targets, dt)
    np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=1e-8)
    # a step the objective shapes: some bounds bind, not all
    vmax = ik.options.max_velocity * dt
    active = np.concatenate([ik.chains[n].dof_adr for n in targets])
    at_bound = np.isclose(np.abs(ours[active]), vmax, atol=1e-9)
    assert at_bound.any() and not at_bound.all()
    if case is _case_collisions:
        lim = ik.collision_limit
        assert lim is not None
        G, h = lim.compute_qp_inequalities(mink.Configuration(ik.model, q), dt)
        rows = np.isfinite(h)
        assert np.any(np.abs(h[rows] - G[rows] @ ours) < 1e-9)  # a collision row binds


@pytest.mark.parametrize("make", ["position", "gaze"])
@pytest.mark.parametrize("gain, lm_damping", [(1.0, 0.0), (0.4, 0.0), (0.7, 0.05)])
def test_task_rows_are_the_documented_weighting(make, gain, lm_damping):
    """Our tasks' QP rows (one fill, weighted by mink through the adapter) are
    ``(W J, -gain W e, lm_damping |gain W e|^2)`` with ``W = diag(cost)``, as the adapter
    documents, and equal mink's generic rows from compute_error / compute_jacobian."""
    m = Chain().model
    cfg = mink.Configuration(m, m.qpos0 + np.random.default_rng(10).uniform(-0.4, 0.4, m.nq))
    if make == "position":
        task = PositionTask(m, "right_palm_site", cost=2.0, gain=gain, lm_damping=lm_damping)
    else:
        task = GazeTask(m, "gaze_site", axis="z", cost=0.7, gain=gain, lm_damping=lm_damping)
    task.set_target([0.6, -0.2, 1.4])
    e, J, w = task.compute_error(cfg), task.compute_jacobian(cfg), task.cost
    WJ, We, mu = task.compute_qp_residual(cfg)
    np.testing.assert_allclose(WJ, w[:, None] * J, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(We, -gain * w * e, rtol=0.0, atol=1e-15)
    assert mu == pytest.approx(lm_damping * np.sum((gain * w * e) ** 2), rel=1e-12, abs=1e-18)
    for ours, theirs in zip((WJ, We, mu), _PlainTask(task).compute_qp_residual(cfg), strict=True):
        np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=1e-15)


def test_mink_internals_only_in_the_adapter():
    """Outside adapter.py, the mink solver's modules use only mink's top-level public
    names: no ``from mink.sub import``, no ``mink.<private or unexported>``, and no
    ``obj._private`` on anything but ``self`` / ``cls``."""
    root = Path(mink_solver.__file__).parent
    public = {n for n in dir(mink) if not n.startswith("_")}
    bad = []
    for path in sorted(root.rglob("*.py")):
        if path.name == "adapter.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            where = f"{path.relative_to(root)}:{getattr(node, 'lineno', 0)}"
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
                bad += [f"{where} import {n}" for n in names if n.startswith("mink.")]
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mink"):
                bad.append(f"{where} from {node.module} import ...")
            elif isinstance(node, ast.Attribute):
                owner = node.value.id if isinstance(node.value, ast.Name) else None
                if owner == "mink" and node.attr not in public:
                    bad.append(f"{where} mink.{node.attr}")
                private = node.attr.startswith("_") and not node.attr.startswith("__")
                if private and owner not in ("self", "cls"):
                    bad.append(f"{where} .{node.attr}")
    assert bad == []


# ---------------------------------------------------------------------------- caches
def test_prepare_builds_everything_a_timed_solve_uses(monkeypatch):
    """After prepare(chain), solving position and pose targets on that chain builds no
    UpperBodyIK and no QP problem."""
    chain = Chain()
    solver = MinkSolver()
    solver.prepare(chain)
    ik = solver.upper_body(chain)

    def no_build(*args, **kwargs):
        raise AssertionError("set-up work inside a timed solve")

    monkeypatch.setattr("humanoid_ik.solvers.mink.problem.build_problem", no_build)
    monkeypatch.setattr(MinkSolver, "_build", no_build)
    p, R = Chain().fk([0.5, 0.3, 0.1, 1.1, 0.2, 0.1, 0.0])
    assert solver.solve(chain, p).converged
    assert solver.solve(chain, Target(p, mat_to_quat(R))).converged
    assert solver.upper_body(chain) is ik


def test_caches_are_rebuilt_only_for_other_chains_or_goals():
    """The UpperBodyIK lives in the robot's workspace, keyed by the options and the
    chain (end effector, joints) or the goals' chains and tasks: an equal chain of the
    same robot and another solver object with equal options share it; another robot
    state, other options, other goals or a changed model get their own;
    prepare_effectors fills the goals' one. The solver object holds none of them."""
    solver = MinkSolver()
    a, b = Chain(), Chain()
    ik_a = solver.upper_body(a)
    assert solver.upper_body(a) is ik_a
    assert solver.upper_body(Chain(a.robot)) is ik_a  # an equal chain of the same robot
    assert MinkSolver().upper_body(a) is ik_a  # equal options: the same key
    assert solver.upper_body(b) is not ik_a  # another robot state
    assert MinkSolver(max_step=0.1).upper_body(a) is not ik_a
    assert solver.upper_body(Chain(a.robot, "left_palm_site")) is not ik_a
    assert set(vars(solver)) == {"options"}
    a.model.jnt_range[a.joint_ids[0], 0] -= 0.01  # the live model changes: rebuilt
    assert a.sync() and solver.upper_body(a) is not ik_a
    goals = _goals()
    solver.prepare_effectors(goals)
    ik = solver.upper_body_for(goals)
    solver.solve_effectors(goals)
    assert solver.upper_body_for(goals) is ik
    moved = [g._replace(q0=g.chain.q_home + 0.01) for g in goals]
    assert solver.upper_body_for(moved) is ik  # warm starts are inputs, not state
    assert solver.upper_body_for(_goals(("reach", "reach", "reach"))) is not ik


def test_one_solver_object_shared_by_two_threads_gives_the_serial_answers():
    """Two threads, each with its own Chain (its own robot state), ONE MinkSolver
    object, 100 position targets each (FK of seeded random in-range joints): every
    answer equals a serial solve of the same target from the same start on a fresh
    chain (0 wrong)."""
    solver = make_solver("mink")
    n = 100
    cases = []
    for seed in (31, 32):
        rng = np.random.default_rng(seed)
        gen = Chain()
        cases.append([(gen.fk(gen.random_q(rng))[0], gen.random_q(rng)) for _ in range(n)])
    answers: list[list] = [[], []]
    errors: list[BaseException] = []
    barrier = threading.Barrier(2)

    def work(k: int) -> None:
        try:
            chain = Chain()
            barrier.wait()
            for p, q0 in cases[k]:
                res = solver.solve(chain, p, q0)
                answers[k].append((res.q.copy(), res.converged, res.iterations))
        except BaseException as exc:  # reported below, not lost in the thread
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)  # switch threads often: races show up more
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    assert not errors, errors
    assert set(vars(solver)) == {"options"}  # nothing a solve changes lives on the solver
    wrong = 0
    bundled = Chain().model  # loaded once; each reference chain gets a fresh robot state
    for k in range(2):
        assert len(answers[k]) == n
        for (p, q0), (q, converged, iterations) in zip(cases[k], answers[k], strict=True):
            ref = make_solver("mink").solve(Chain(bundled), p, q0)
            same = np.array_equal(q, ref.q) and converged == ref.converged
            wrong += int(not (same and iterations == ref.iterations))
    assert wrong == 0


def test_solve_effectors_claims_the_robot():
    """A goal's robot in use by another solve is refused (one thread per robot state)."""
    goals = _goals()
    goals[0].chain.claim()
    try:
        with pytest.raises(ChainError, match="in use by another thread"):
            MinkSolver().solve_effectors(goals)
    finally:
        goals[0].chain.release()
    assert MinkSolver().solve_effectors(goals)[0].converged  # released after an error too


# ---------------------------------------------------------------------------- options
def test_one_options_system():
    """UpperBodyIK takes MinkOptions (or its fields): the options it runs with are the
    solver's, defaults included, and fields override an options object."""
    ik = _upper_body()
    assert ik.options == MinkOptions(collision_pairs=PAIRS)
    opts = MinkOptions(max_velocity=2.0, lm_damping=0.01)
    ik = _upper_body(options=opts, collision_pairs=None)
    assert ik.options == MinkOptions(max_velocity=2.0, lm_damping=0.01)
    ik = _upper_body(options=opts, max_velocity=3.0)
    assert ik.options.max_velocity == 3.0 and ik.options.lm_damping == 0.01
    solver = MinkSolver(max_step=0.1, collision_pairs=PAIRS)
    assert solver.upper_body(Chain()).options is solver.options
    assert hash(solver.options) == hash(MinkOptions(max_step=0.1, collision_pairs=PAIRS))
    with pytest.raises(SolverError, match="'max_velocity' of solver 'mink' must be .*> 0"):
        MinkOptions(max_velocity=0.0)


def test_collision_pairs_option_shapes():
    """Pairs are normalised to tuples (a group may be one name); a bad shape names the
    index inside collision_pairs; 'collisions' points to its replacement."""
    opts = MinkOptions.parse("mink", {"collision_pairs": [["a", ["b", "c"]]]})
    assert opts.collision_pairs == ((("a",), ("b", "c")),)
    assert MinkOptions(collision_pairs=None).collision_pairs == ()
    for bad, where in [
        ("a", ""),
        ([["a"]], "[0]"),
        ([["a", []]], "[0][1]"),
        ([[["a", 3], "b"]], "[0][0][1]"),
    ]:
        with pytest.raises(SolverError, match=rf"'collision_pairs{re_escape(where)}'"):
            make_solver("mink", collision_pairs=bad)
    with pytest.raises(SolverError, match="replaced by 'collision_pairs'"):
        make_solver("mink", collisions=True)


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def test_removed_names_are_deprecated_aliases():
    """DEFAULT_HANDS, DEFAULT_GAZE, DEFAULT_COLLISION_PAIRS (package) and DEFAULTS,
    check_options (upper_body) still resolve, with a DeprecationWarning; the old pairs
    are the bundled scene's."""
    from humanoid_ik.solvers.mink import upper_body

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert mink_solver.DEFAULT_HANDS == HANDS
        assert mink_solver.DEFAULT_GAZE == GAZE
        assert MinkOptions(collision_pairs=mink_solver.DEFAULT_COLLISION_PAIRS).collision_pairs == (
            PAIRS
        )
        assert upper_body.DEFAULTS["max_velocity"] == MinkOptions().max_velocity
        assert upper_body.check_options({"max_step": 0.1})["max_step"] == 0.1
        assert upper_body.DEFAULT_GAZE == GAZE
    assert len(caught) == 6
    assert all(w.filename == __file__ for w in caught)  # points at the line that used it
    assert all(issubclass(w.category, DeprecationWarning) for w in caught)
    with pytest.raises(AttributeError):
        mink_solver.DEFAULT_POSTURE  # noqa: B018


def test_no_robot_names_in_the_solver():
    """No module of the mink solver holds a name of the bundled humanoid as a value (a
    default): only the deprecated aliases (deprecated.py) do."""
    root = Path(mink_solver.__file__).parent
    bundled = {*HANDS, GAZE, *(n for pair in PAIRS for group in pair for n in group)}
    found = []
    for path in sorted(root.rglob("*.py")):
        if path == root / "deprecated.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value in bundled:
                found.append(f"{path.name}:{node.lineno} {node.value!r}")
    assert found == []


@pytest.mark.parametrize(
    "axis, point",
    [("x", [0.75, 0.10, 1.75]), ("y", [0.30, 0.70, 1.62]), ("z", [0.35, 0.0, 2.3])],
)
def test_forward_axis_is_the_axis_aimed(axis, point):
    """MinkSolver(forward_axis=...) aims that axis of the look_at site at the target."""
    solver = MinkSolver(forward_axis=axis)
    np.testing.assert_array_equal(solver.gaze_axis(), axis_vector(axis))
    chain = Chain(None, "gaze_site")
    goal = Goal(chain, Target(point), chain.q_home, "look_at")
    (res,) = solver.solve_effectors([goal])
    assert res.converged
    chain.set_q(res.q)
    _, angle = gaze_error(chain.position, chain.rotation, axis_vector(axis), np.array(point))
    assert angle < 1e-3 and res.orientation_error == pytest.approx(angle, abs=1e-12)


# ---------------------------------------------------------------------------- errors
def test_unknown_geom_names_are_named_with_the_valid_ones():
    """Unknown collision geoms: the error names each and lists the model's geoms."""
    pairs = [(["right_hand_collision", "palm_geom"], ["torso_collision", "belly"])]
    with pytest.raises(NameNotFoundError) as err:
        _upper_body(collision_pairs=pairs)
    msg = str(err.value)
    assert "'palm_geom'" in msg and "'belly'" in msg and "torso_collision" in msg
    with pytest.raises(SolverError, match=r"'collision_pairs\[0\]' .* two groups"):
        _upper_body(collision_pairs=[(["right_hand_collision"],)])


def test_a_model_with_other_names_works_through_options():
    """Another model: effectors and collision pairs by its own names."""
    m = model(SMALL_ARM_XML)
    ik = UpperBodyIK(m, hands=("tip",), gaze=None, collision_pairs=None)
    chain = Chain(m, "tip")
    p, _ = chain.fk(chain.random_q(np.random.default_rng(1)))
    assert ik.solve({"tip": p}).converged
    with pytest.raises(NameNotFoundError, match="site 'right_palm_site' not in model"):
        UpperBodyIK(m, hands=HANDS)
    with pytest.raises(TypeError, match="hands"):
        UpperBodyIK(m)  # type: ignore[call-arg]  # no default effectors
    with pytest.raises(ChainError, match="needs a model"):
        UpperBodyIK(hands=("tip",))  # no default model either


def test_bad_targets_and_steps_are_refused():
    """Unknown effector, an orientation for the gaze, a bad dt or qpos: clear errors."""
    ik = _upper_body()
    with pytest.raises(TargetError, match="effectors: right_palm_site, left_palm_site"):
        ik.step({"right_hand": [0.3, -0.3, 1.1]}, 0.01)
    with pytest.raises(TargetError, match="looks at a point"):
        ik.step({"gaze_site": Target([1.0, 0.0, 1.5], [1.0, 0.0, 0.0, 0.0])}, 0.01)
    for dt in (0.0, -0.01, math.nan, "fast"):
        with pytest.raises(SolverError, match="dt must be"):
            ik.step({"gaze_site": [1.0, 0.0, 1.5]}, dt)  # type: ignore[arg-type]
    with pytest.raises(TargetError, match="qpos must be"):
        ik.set_q(np.zeros(3))


def test_bad_options_are_refused():
    """Unknown options, non-numbers, out-of-range gains and missing QP solvers."""
    with pytest.raises(SolverError, match="unknown"):
        _upper_body(speed=1.0)
    with pytest.raises(SolverError, match="must be a number"):
        _upper_body(max_velocity="fast")
    with pytest.raises(SolverError, match=r"'range_gain' .* <= 1, got 1.5"):
        _upper_body(range_gain=1.5)
    with pytest.raises(SolverError, match=r"'range_gain' .* > 0 and <= 1, got 0"):
        _upper_body(range_gain=0)
    with pytest.raises(SolverError, match="> 0"):
        _upper_body(max_step=0.0)
    with pytest.raises(SolverError, match=">= 0"):
        _upper_body(posture_cost=-1.0)
    with pytest.raises(SolverError, match="must be the name of a qpsolvers backend"):
        _upper_body(qp_solver=3)
    with pytest.raises(SolverError, match="QP solvers: .*daqp"):
        _upper_body(qp_solver="no_such_qp")
    with pytest.raises(SolverError, match="QP solvers"):
        MinkSolver(qp_solver="no_such_qp").solve(Chain(), [0.3, -0.3, 1.1])


def test_bad_chains_are_refused():
    """Chains on another model, an effector given twice, no effector. (A body as the
    gaze is a head limb's gaze frame: test_upper_body_on_a_real_humanoid.)"""
    with pytest.raises(ChainError, match="another MjModel"):
        UpperBodyIK(Chain().model, hands=(Chain(),))
    with pytest.raises(ChainError, match="given twice"):
        _upper_body(hands=("right_palm_site", "right_palm_site"))
    m = Chain().model
    with pytest.raises(ChainError, match="at least one effector"):
        UpperBodyIK(m, hands=())


def test_task_parts_refuse_bad_input():
    """Zero gaze axis, bad targets, and a task used before its target is set."""
    m = Chain().model
    cfg = mink.Configuration(m)
    with pytest.raises(TargetError, match="non-zero"):
        GazeTask(m, "gaze_site", axis=(0.0, 0.0, 0.0))
    gaze = GazeTask(m, "gaze_site")
    pos = PositionTask(m, "right_palm_site")
    for task in (gaze, pos):
        with pytest.raises(mink.TargetNotSet):
            task.compute_error(cfg)
        with pytest.raises(TargetError, match="3 finite numbers"):
            task.set_target([1.0, math.inf, 0.0])
    with pytest.raises(mink.TargetNotSet):
        gaze.error(cfg)


@pytest.mark.parametrize(
    ("option", "value", "bound"),
    [
        ("max_iterations", 10**9, "<= 100000"),
        ("restarts", 5000, "<= 1000"),
        ("stall_window", 10**6, "<= 100000"),
        ("max_step", 100.0, "<= 6.28319"),
        ("dt", 60.0, "<= 10"),
        ("max_velocity", 1e9, "<= 1000"),
    ],
)
def test_mink_options_have_upper_bounds_named_in_the_error(option, value, bound):
    with pytest.raises(SolverError, match=f"option '{option}' of solver 'mink' .*{bound}"):
        make_solver("mink", **{option: value})


# ---------------------------------------------------------------------------- real humanoids
def _pairs(pairs) -> set[frozenset[frozenset]]:
    """Pairs of geom groups as sets (the order of groups and names aside)."""
    return {frozenset(frozenset(g) for g in pair) for pair in pairs}


def test_limb_pairs_of_the_bundled_humanoid_are_the_scenes():
    """collision_pairs="limbs" on the bundled humanoid derives the pairs its scene lists
    by hand (each forearm and hand against torso, chest and head; hand against hand),
    so the collision limit checks the same geom pairs; any other string is refused
    naming 'limbs'."""
    robot = Robot()
    assert _pairs(limb_collision_pairs(robot.model)) == _pairs(PAIRS)
    derived = _upper_body(robot, collision_pairs="limbs")
    listed = _upper_body(robot)
    assert (
        derived.options.collision_pairs
        == "limbs"
        == MinkOptions.parse("mink", {"collision_pairs": "limbs"}).collision_pairs
    )
    assert _pairs(derived.collision_pairs) == _pairs(PAIRS)
    assert sorted(derived.collision_limit.geom_id_pairs) == sorted(
        listed.collision_limit.geom_id_pairs
    )
    with pytest.raises(SolverError, match=r"'collision_pairs' .* or 'limbs', got 'limb'"):
        make_solver("mink", collision_pairs="limb")


HUMANOID_PAIRS = {
    "g1": (
        {"left_elbow_link_collision", "left_wrist_yaw_link_collision"},
        {"torso_link_collision", "head_link_collision", "pelvis_contour_link_collision"},
        "left_shoulder_yaw_link_collision",
    ),
    "talos": (
        {"arm_left_4_link_collision", "gripper_left_base_link_collision"},
        {"torso_2_link_collision", "head_2_link_collision", "base_link_collision"},
        "arm_left_3_link_collision",
    ),
}
"""Per robot: geoms of the left forearm and hand group, of the torso and head group, and
an upper-arm geom that is in neither (it touches the torso at the shoulder)."""


def _distances(ik: UpperBodyIK) -> NDArray:
    """Every checked geom pair's distance [m] (negative: penetration) at the IK's pose."""
    m, d, ft = ik.model, ik.configuration.data, np.zeros(6)
    return np.array(
        [mujoco.mj_geomDistance(m, d, a, b, 1.0, ft) for a, b in ik.collision_limit.geom_id_pairs]
    )


def _front_targets(ik: UpperBodyIK, hands, gaze, axis, forward) -> dict:
    """Targets both hands and the gaze reach exactly, in front of the robot: the hands
    where they are at a seeded in-range pose half way from home (at least 0.1 m in
    front of their shoulders, every pair at least 3 cm apart), the gaze 1 m along the
    head's axis at such a pose."""
    rng = np.random.default_rng(0)
    d = ik.configuration.data
    for _ in range(200):
        q = ik.q_home.copy()
        for c in [*hands, *([gaze] if gaze else [])]:
            q[c.qpos_adr] = c.q_home + 0.5 * (c.random_q(rng) - c.q_home)
        ik.set_q(q)
        ahead = [float(np.dot(d.xpos[c.ee_id] - d.xanchor[c.joint_ids[0]], forward)) for c in hands]
        if min(ahead) > 0.1 and _distances(ik).min() > 0.03:
            break
    else:
        raise AssertionError("no collision-free pose with both hands in front")
    out = {c.ee_name: d.xpos[c.ee_id].copy() for c in hands}
    if gaze is not None:
        out[gaze.ee_name] = d.xpos[gaze.ee_id] + d.xmat[gaze.ee_id].reshape(3, 3) @ axis
    ik.reset()
    return out


@pytest.mark.parametrize("name", ["g1", "talos"])
def test_upper_body_on_a_real_humanoid(name):
    """G1 and Talos, original URDFs: both hands (the arms' end frames from find_limbs)
    and, on Talos, the gaze (its head limb: two neck joints, gaze frame head_2_link;
    G1's head is fixed, so there the gaze is no task) in one QP per step, with
    collision_pairs="limbs". The derived pairs hold the forearm, hand, torso and head
    collision geoms (not the upper arm, no visual geom). 60 steps of 1/30 s toward
    reachable targets in front of the robot: hands within 1 mm, gaze within 1 deg, no
    joint out of range, no pair penetrating. Then both hands are sent to one point
    between them: the hands stop apart (every pair at a distance >= 0), while without
    the pairs the same steps drive them into each other."""
    model = load_model(robot_file(name))
    profile = find_limbs(model)
    robot = Robot(model)
    hands = [limb_chain(robot, arm, profile=profile) for arm in ("left_arm", "right_arm")]
    head = profile.limb("head")
    gaze = limb_chain(robot, "head", profile=profile) if head.joints else None
    assert (gaze is None) == (name == "g1")
    axis = None if gaze is None else np.array(head.axis)
    ik = UpperBodyIK(robot, hands=hands, gaze=gaze, gaze_axis=axis, collision_pairs="limbs")
    pairs = ik.collision_pairs
    assert _pairs(pairs) == _pairs(limb_collision_pairs(model, profile)) and len(pairs) == 3
    forearm, body, upper = HUMANOID_PAIRS[name]
    assert (
        forearm <= set(pairs[0][0]) and body <= set(pairs[0][1]) and body == body & set(pairs[1][1])
    )
    named = {n for pair in pairs for group in pair for n in group}
    assert upper not in named and not any(n.endswith("_visual") for n in named)
    assert all(model.geom_group[model.geom(n).id] == COLLISION_GROUP for n in named)
    assert len(ik.collision_limit.geom_id_pairs) > 20
    targets = _front_targets(ik, hands, gaze, axis, np.array(profile.forward))
    lowest = np.inf
    for _ in range(60):
        res = ik.step(targets, 1 / 30)
        for c in ik.chains.values():
            q = ik.q[c.qpos_adr]
            assert np.all((q >= c.lower) & (q <= c.upper)), c.ee_name
        lowest = min(lowest, _distances(ik).min())
    for c in hands:
        assert res[c.ee_name].position_error < 1e-3, (c.ee_name, res[c.ee_name])
    if gaze is not None:
        assert res[gaze.ee_name].orientation_error < math.radians(1.0), res[gaze.ee_name]
    assert lowest >= 0.0
    # both hands to the point between them: the pairs keep them apart
    middle = (targets[hands[0].ee_name] + targets[hands[1].ee_name]) / 2
    squeeze = {c.ee_name: middle for c in hands}
    free = UpperBodyIK(robot, hands=hands)
    for solver in (ik, free):
        solver.reset()
        lowest = np.inf
        for _ in range(60):
            solver.step(squeeze, 1 / 30)
            ik.set_q(solver.q)  # measure every derived pair at this pose
            lowest = min(lowest, _distances(ik).min())
        if solver is ik:
            assert lowest >= 0.0, lowest
        else:
            assert lowest < 0.0, lowest  # the test can fail: without pairs they collide
