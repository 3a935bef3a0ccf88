"""``solve_batch``: many targets of one chain, each answer the one-call ``solve``'s bit
for bit, in this process or on worker processes (real ones, each with its own copy of
the robot), on a real arm (G1's left arm, from example-robot-data)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import Chain, Target, TargetError, load_model, solve, solve_batch
from humanoid_ik.core.limbs import limb_chain
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.subproblem import subproblem_cache
from humanoid_ik.solvers.jacobian.lm import kernel
from tests.chains import fk_poses
from tests.robots import robot_file


@pytest.fixture(scope="module")
def g1_arm() -> Chain:
    """G1's left arm without the waist (7 hinges), its waist turned so that the arm's
    base is not where the model's home puts it (the workers must copy the pose)."""
    chain = Chain(load_model(robot_file("g1")), body="left_rubber_hand")
    arm = Chain(chain.robot, body="left_rubber_hand", joints=chain.joint_names[3:])
    waist = chain.joint_names[:3]
    chain.set_q(np.r_[[0.3, 0.0, 0.1], arm.q_home])
    assert len(waist) == 3 and arm.n == 7
    return arm


@pytest.mark.parametrize("workers", [1, 2])
def test_batch_answers_are_the_single_calls(g1_arm, workers):
    """40 pose targets: each result equals ``solve``'s from the same start (joints, status,
    iterations, errors), on 1 and on 2 processes, and every pose is met."""
    targets = fk_poses(g1_arm, 40, seed=workers)
    q0 = g1_arm.q_home
    batch = solve_batch(g1_arm, targets, "auto", q0=q0, workers=workers)
    assert len(batch) == 40
    for t, got in zip(targets, batch, strict=True):
        want = solve(g1_arm, t, "auto", q0=q0)
        assert got == want  # joints, status, iterations, errors, solver and message
        assert got.details == want.details == {"auto": ("lm",)}
        assert got.converged and got.position_error < 1e-4
    np.testing.assert_array_equal(g1_arm.q, batch[-1].q)  # the scratch data at the last


@pytest.mark.parametrize("workers", [1, 2])
def test_auto_retries_the_pose_targets_lm_missed_in_the_compiled_loop(g1_arm, workers):
    """``auto``'s retry of a pose target ``lm``'s 21 starts missed runs in the compiled
    loop too (:attr:`Auto.retry`): each result equals the one call's, the retried ones
    converged with ``details == {"auto": ("lm", "lm")}``; a position target out of reach
    still goes to the one call (its second opinion is another solver's)."""
    q0 = g1_arm.q_home
    targets = fk_poses(g1_arm, 3000, seed=11)
    first = solve_batch(g1_arm, targets, "lm", q0=q0, workers=2)
    missed = [t for t, r in zip(targets, first, strict=True) if not r.converged]
    assert len(missed) >= 2  # about 1 in 1,000 of G1's targets from home
    mixed = [*targets[:3], *missed[:3], Target([3.0, 0.0, 1.0]), *targets[3:6]]
    batch = solve_batch(g1_arm, mixed, "auto", q0=q0, workers=workers)
    retried = 0
    for t, got in zip(mixed, batch, strict=True):
        want = solve(g1_arm, t, "auto", q0=q0)
        assert got == want and got.details == want.details
        retried += got.details["auto"] == ("lm", "lm") and got.converged
    assert retried == len(missed[:3])
    assert not batch[6].converged  # out of reach
    # the arrays hold the retried and re-solved rows too
    np.testing.assert_array_equal(batch.q, [r.q for r in batch])
    assert (
        batch.converged.tolist()
        == [r.converged for r in batch]
        == [True] * 6 + [False] + [True] * 3
    )
    np.testing.assert_array_equal(batch.position_error, [r.position_error for r in batch])
    np.testing.assert_array_equal(
        batch.orientation_error[:6], [r.orientation_error for r in batch[:6]]
    )
    assert np.isnan(batch.orientation_error[6])


@pytest.mark.parametrize("workers", [1, 2])
def test_the_compiled_loop_gives_the_single_calls_answers(workers):
    """``lm`` on Baxter's left arm (half its targets from home need restarts: the
    library's poses and the random ones, in the compiled loop), pose and position
    targets mixed, and two out of reach (no start converges: solved again by the one
    call, which measures them): every result equals ``solve``'s, on one or two threads."""
    baxter = limb_chain(Robot(load_model(robot_file("baxter"))), "left_arm")
    targets = fk_poses(baxter, 30, seed=5)
    mixed = [t if k % 3 else Target(t.position) for k, t in enumerate(targets)]
    mixed += [Target([3.0, 0.0, 1.0]), Target([0.0, 3.0, 1.0], targets[0].quat)]
    q0 = baxter.q_home
    batch = solve_batch(baxter, mixed, "lm", q0=q0, workers=workers)
    iterations = []
    for t, got in zip(mixed, batch, strict=True):
        want = solve(baxter, t, "lm", q0=q0)
        assert got == want and got.details == want.details
        iterations.append(got.iterations)
    assert [r.converged for r in batch[-2:]] == [False, False]
    assert sum(r.converged for r in batch) == 30 and max(iterations) > 50  # restarts ran


def test_other_solvers_go_to_worker_processes(g1_arm):
    """``dls`` (Python) on 2 worker processes, each with its own copy of the robot: the
    single calls' results."""
    targets = fk_poses(g1_arm, 8, seed=3)
    batch = solve_batch(g1_arm, targets, "dls", q0=g1_arm.q_home, workers=2)
    for t, got in zip(targets, batch, strict=True):
        assert got == solve(g1_arm, t, "dls", q0=g1_arm.q_home)


def test_positions_as_an_array_and_options(g1_arm):
    """Positions ``(N, 3)`` with orientations ``(N, 4)``, and a solver option, as in
    ``solve``; with no ``q0`` every solve starts from the chain's current joints."""
    targets = fk_poses(g1_arm, 5, seed=7)
    p = np.array([t.position for t in targets])
    qt = np.array([t.quat for t in targets])
    g1_arm.set_q(g1_arm.q_home)
    start = g1_arm.q
    batch = solve_batch(g1_arm, p, "lm", quats=qt, max_iterations=50)
    for t, got in zip(targets, batch, strict=True):
        want = solve(g1_arm, t, "lm", q0=start, max_iterations=50)
        np.testing.assert_array_equal(got.q, want.q)
    only_positions = solve_batch(g1_arm, p, "dls", q0=start)
    assert all(r.orientation_error is None and r.converged for r in only_positions)
    assert solve_batch(g1_arm, [], "auto") == []


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        (
            {"workers": -1},
            SolverError,
            r"workers must be an integer >= 0 \(0: one per core\), got -1",
        ),
        ({"workers": 1.5}, SolverError, "workers must be an integer >= 0"),
        (
            {"targets": np.zeros((3, 2))},
            TargetError,
            r"positions must have shape \(N, 3\) \[m\], got \(3, 2\)",
        ),
        ({"quats": np.zeros((2, 4))}, TargetError, r"quats must have shape \(3, 4\) wxyz"),
        ({"solver": "nope"}, SolverError, "solver 'nope' unknown; solvers: auto"),
    ],
)
def test_bad_input_is_one_clear_error(g1_arm, kwargs, error, message):
    """Bad workers, shapes and solver names raise the package's error naming the value."""
    args = {"targets": np.full((3, 3), 0.3), "solver": "auto", **kwargs}
    targets, solver = args.pop("targets"), args.pop("solver")
    with pytest.raises(error, match=message):
        solve_batch(g1_arm, targets, solver, **args)


@pytest.mark.parametrize("workers", [1, 2])
def test_subproblem_batches_give_the_single_calls_answers(workers):
    """``auto`` on UR5 runs ``subproblem`` (exact, 6 hinges) for pose targets: a batch
    solves them all in C (``Arm.solve_many``) and measures them in ``lm``'s kernel
    (``Kernel.measure``), on one or two threads; each result equals the one call's (joints,
    status, message, errors, details), a target beyond reach and one whose solutions all
    leave the ranges included; the robot state ends at the last answer."""
    ur5 = Chain(load_model(robot_file("ur5")), body="tool0")
    targets = fk_poses(ur5, 40, seed=7)
    far = Target([3.0, 0.0, 1.0], targets[0].quat)
    # a pose reachable only with the shoulder outside a narrowed range
    narrow = Chain(load_model(robot_file("ur5")), body="tool0")
    narrow.model.jnt_range[narrow.joint_ids[0]] = [-0.2, 0.2]
    narrow.model.jnt_limited[narrow.joint_ids[0]] = 1
    q_out = np.array([1.5, -1.0, 1.2, -0.5, 0.8, 0.3])
    p, R = ur5.fk(q_out)
    outside = Target(p.copy(), mat_to_quat(R))
    for chain, batch_targets in ((ur5, [*targets, far]), (narrow, [*targets[:5], outside])):
        q0 = chain.q_home
        batch = solve_batch(chain, batch_targets, "auto", q0=q0, workers=workers)
        for t, got in zip(batch_targets, batch, strict=True):
            want = solve(chain, t, "auto", q0=q0)
            assert got == want and got.details == want.details
            assert got.solver == "subproblem" and got.details["auto"] == ("subproblem",)
        np.testing.assert_array_equal(chain.q, batch[-1].q)
        assert not batch[-1].converged and batch[-1].status.value == "unreachable"
    assert all(r.converged for r in solve_batch(ur5, targets, "subproblem", workers=workers))
    # the compiled calls check their buffers
    arm, base = subproblem_cache(ur5).current(ur5)
    q0, lo, hi = ur5.q_home, ur5.lower, ur5.upper
    with pytest.raises(ValueError, match="out must be 12 float64 values"):
        arm.solve_many(np.zeros(6), np.zeros(8), base, q0, lo, hi, 1e-6, np.zeros(5), np.zeros(6))
    with pytest.raises(TypeError, match="solve_many takes 9 arguments"):
        arm.solve_many()
    with pytest.raises(TypeError, match=r"measure\(\) takes 13 arguments, got 0"):
        kernel(ur5).measure()


@pytest.mark.parametrize("workers", [1, 2])
def test_subproblem_batches_of_arrays_stay_arrays(workers):
    """UR5 pose targets as arrays ``(N, 3)`` and ``(N, 4)``, the quaternions a little off
    unit norm (as a user's are): the batch's arrays equal the one calls' results with
    ``Target(position, quat)`` bit for bit (the quaternion normalised the same way),
    and so does each result read from it; a bad row is the error its ``Target`` gives,
    naming the value, before anything is solved."""
    ur5 = Chain(load_model(robot_file("ur5")), body="tool0")
    targets = fk_poses(ur5, 30, seed=3)
    p = np.array([t.position for t in targets])
    qt = np.array([t.quat for t in targets]) * np.linspace(0.9995, 1.0005, 30)[:, None]
    q0 = ur5.q_home
    batch = solve_batch(ur5, p, quats=qt, q0=q0, workers=workers)
    want = [solve(ur5, Target(pi, qi), "auto", q0=q0) for pi, qi in zip(p, qt, strict=True)]
    np.testing.assert_array_equal(batch.q, np.array([w.q for w in want]))
    np.testing.assert_array_equal(batch.position_error, [w.position_error for w in want])
    np.testing.assert_array_equal(batch.orientation_error, [w.orientation_error for w in want])
    assert batch.converged.all() and batch.q.shape == (30, 6) and not batch.q.flags.writeable
    assert batch == want and batch[-1] == want[-1] and batch[3:5] == want[3:5]
    assert (
        batch[7].details
        == want[7].details
        == {"solutions": 8, "inside": 8, "auto": ("subproblem",)}
    )
    with pytest.raises(IndexError, match="result 30 of a batch of 30"):
        batch[30]
    bad_p, bad_q = p.copy(), qt.copy()
    bad_p[4, 1] = np.nan
    with pytest.raises(TargetError, match=r"target position \[.*nan.*\] is not finite"):
        solve_batch(ur5, bad_p, quats=qt, q0=q0)
    bad_q[2] = [2.0, 0.0, 0.0, 0.0]
    with pytest.raises(TargetError, match=r"quaternion \[2.0, 0.0, 0.0, 0.0\] has norm 2"):
        solve_batch(ur5, p, quats=bad_q, q0=q0)


def test_batches_of_results_as_arrays(g1_arm):
    """A batch solved per target (``dls``, position targets) gathers its arrays from its
    results: the orientation error NaN where a target has none."""
    targets = fk_poses(g1_arm, 4, seed=5)
    p = np.array([t.position for t in targets])
    batch = solve_batch(g1_arm, p, "dls", q0=g1_arm.q_home)
    assert batch.q.shape == (4, 7) and np.isnan(batch.orientation_error).all()
    np.testing.assert_array_equal(batch.q[2], batch[2].q)
    np.testing.assert_array_equal(batch.position_error, [r.position_error for r in batch])
    assert batch.converged.tolist() == [r.converged for r in batch] == [True] * 4


@pytest.mark.slow
def test_the_batch_benchmark_runs_every_arm_and_form():
    """``benchmarks/batch.py`` on a few targets: one row per arm, target form and worker
    count (G1's arm and UR5, objects and arrays, 1 and 2), every target solved, and the
    bundled arm's vectorised closed form."""
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, str(root / "benchmarks" / "batch.py"), "--targets", "300"],
        capture_output=True, text=True, timeout=600, cwd=root,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    rows = [r.split(" | ") for r in out.stdout.splitlines()[2:]]
    keys = [(r[0].lstrip("| "), r[2], r[3]) for r in rows]
    want = [(arm, form, w) for arm in ("g1 left arm", "ur5") for form in ("objects", "arrays")
            for w in ("1", "2")]  # fmt: skip
    assert keys == [*want, ("bundled arm", "arrays", "1")]
    assert all(r[4] == "100.0%" and int(r[5].replace(",", "")) > 0 for r in rows)
