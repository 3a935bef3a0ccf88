"""FK(IK(x)) = x for every solver on the humanoid's right arm and on an inline arm."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import Chain, SolverError, Target, TargetError, make_solver, solve
from humanoid_ik.core.rotations import mat_to_quat, rotation_log
from humanoid_ik.solvers import SOLVERS

from .chains import SMALL_ARM_XML, model

N = 500
REACHING = ["two_link", "ccd", "jacobian_transpose", "pseudoinverse", "dls", "lm", "auto"]
ROBOT = Path(__file__).resolve().parents[1] / "models" / "robot" / "robot.xml"
ROBOT_ARM = [
    "r_sh_pitch",
    "r_sh_roll",
    "r_sh_yaw",
    "r_elbow",
    "r_wr_roll",
    "r_wr_pitch",
    "r_wr_yaw",
]
ARMS = {
    "humanoid_right": lambda: Chain(),
    "small_arm": lambda: Chain(model(SMALL_ARM_XML), "tip"),
    "robot_right": lambda: Chain(ROBOT, "right_hand_site", ROBOT_ARM),
}


def _targets(chain: Chain, n: int, seed: int, pose: bool, keep_wrist: bool = False):
    """FK of seeded random in-range joint vectors (wrist at home for two_link)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = chain.random_q(rng)
        if keep_wrist:
            q[4:] = chain.q_home[4:]
        p, R = chain.fk(q)
        out.append(Target(p, mat_to_quat(R) if pose else None))
    return out


def _check_round_trips(chain: Chain, solver_name: str, targets, pose: bool):
    solver = make_solver(solver_name)
    checker = Chain(chain.model, chain.ee_name, chain.joint_names)
    worst_p, worst_r = 0.0, 0.0
    for tgt in targets:
        chain.reset()
        res = solver.solve(chain, tgt)
        assert np.all(np.isfinite(res.q))
        assert chain.within_limits(res.q), (solver_name, res.q)
        p, R = checker.fk(res.q)  # FK from a separate MjData
        worst_p = max(worst_p, float(np.linalg.norm(p - tgt.position)))
        assert res.position_error == pytest.approx(np.linalg.norm(p - tgt.position), abs=1e-12)
        if pose:
            worst_r = max(worst_r, float(np.linalg.norm(rotation_log(tgt.rotation @ R.T))))
    return worst_p, worst_r


@pytest.mark.parametrize("arm", list(ARMS))
@pytest.mark.parametrize(
    "solver_name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n in ("ccd", "jacobian_transpose") else n
        for n in REACHING
    ],
)
def test_round_trip_position(arm, solver_name):
    """500 reachable position targets: every solution within 1 mm and inside the ranges."""
    chain = ARMS[arm]()
    targets = _targets(chain, N, seed=11, pose=False, keep_wrist=solver_name == "two_link")
    worst_p, _ = _check_round_trips(chain, solver_name, targets, pose=False)
    assert worst_p < 1e-3


@pytest.mark.parametrize("arm", list(ARMS))
@pytest.mark.parametrize("solver_name", ["pseudoinverse", "dls", "lm", "auto"])
def test_round_trip_pose(arm, solver_name):
    """500 reachable pose targets: within 1 mm and 0.01 rad, inside the ranges."""
    chain = ARMS[arm]()
    worst_p, worst_r = _check_round_trips(chain, solver_name, _targets(chain, N, 12, True), True)
    assert worst_p < 1e-3
    assert worst_r < 1e-2


@pytest.mark.slow
def test_round_trip_pose_jacobian_transpose():
    """The transpose method reaches pose targets (slowly); it may miss only near the
    straight-elbow singularity, where its convergence crawls: 100 targets, right arm."""
    chain = Chain()
    rng = np.random.default_rng(13)
    solver = make_solver("jacobian_transpose")
    misses = []
    for _ in range(100):
        q = chain.random_q(rng)
        p, R = chain.fk(q)
        chain.reset()
        res = solver.solve(chain, Target(p, mat_to_quat(R)))
        assert chain.within_limits(res.q)
        if not (res.position_error < 1e-3 and res.orientation_error < 1e-2):
            misses.append(q[3])
    assert len(misses) <= 3
    assert all(elbow < 0.05 for elbow in misses)


@pytest.mark.parametrize("solver_name", ["jacobian_transpose", "pseudoinverse", "dls"])
def test_converges_from_singular_start(solver_name):
    """From a straight arm (elbow at its 0 limit, a singular pose) the solvers converge."""
    chain = Chain()
    q0 = np.zeros(7)
    p, _ = chain.fk([0.6, 0.3, 0.2, 1.2, 0.1, 0.2, 0.1])
    res = make_solver(solver_name).solve(chain, p, q0=q0)
    assert res.converged and res.position_error < 1e-4
    assert np.all(np.isfinite(res.q))


def test_error_decreases_dls():
    """Each DLS iteration from home lowers the error, quadratically near the target."""
    chain = Chain()
    p, _ = chain.fk([0.8, 0.4, -0.3, 1.4, 0.2, 0.3, 0.1])
    errors = []
    for k in range(1, 8):
        chain.reset()
        res = make_solver("dls", max_iterations=k, restarts=0, tol=1e-12).solve(chain, p)
        errors.append(res.position_error)
    assert all(b < a for a, b in zip(errors, errors[1:], strict=False))
    assert errors[-3] < 1e-3 and errors[-1] < 1e-9


def test_nullspace_bias_pulls_toward_home():
    """With a null-space gain the redundant arm ends closer to home on every target."""
    chain = Chain()
    both = 0
    for tgt in _targets(chain, 40, 14, pose=False):
        chain.reset()
        plain = make_solver("dls", restarts=0).solve(chain, tgt)
        chain.reset()
        biased = make_solver("dls", restarts=0, nullspace_gain=0.2).solve(chain, tgt)
        if plain.converged and biased.converged:
            both += 1
            assert np.linalg.norm(biased.q - chain.q_home) < np.linalg.norm(plain.q - chain.q_home)
    assert both >= 25


@pytest.mark.parametrize("solver_name", ["ccd", "jacobian_transpose", "pseudoinverse", "dls"])
def test_unreachable_target_never_nan(solver_name):
    """A target 2 m away ends as max_iterations with finite joints inside the ranges."""
    chain = Chain()
    res = make_solver(solver_name, max_iterations=300, restarts=1).solve(chain, [2.0, -0.2, 1.4])
    assert res.status == "max_iterations" and not res.converged
    assert np.all(np.isfinite(res.q)) and chain.within_limits(res.q)
    # the arm stretches toward it: within 0.1 m of the 1.37 m miss of a straight arm
    assert res.position_error == pytest.approx(2.0 - 0.63, abs=0.1)


def test_two_link_unreachable_points_at_target():
    """two_link beyond reach: status unreachable, the distance reported, arm aimed at it."""
    chain = Chain()
    target = np.array([1.5, -0.19, 1.40])
    res = make_solver("two_link").solve(chain, target)
    assert res.status == "unreachable" and not res.converged
    shell = make_solver("two_link").shell(chain)
    assert f"{1.5 - shell.r_max:.6g} m beyond" in res.message
    chain.set_q(res.q)
    shoulder = chain.data.site("right_shoulder_site").xpos.copy()
    hand = chain.position.copy()
    direction = (hand - shoulder) / np.linalg.norm(hand - shoulder)
    np.testing.assert_allclose(direction, [1.0, 0.0, 0.0], atol=1e-9)
    assert res.position_error == pytest.approx(1.5 - shell.r_max, abs=1e-9)


@pytest.mark.parametrize("r_scale", [0.0, 0.5])
def test_two_link_inner_hole(r_scale):
    """A target at the shoulder or inside the inner hole is unreachable, without NaN."""
    chain = Chain()
    tl = make_solver("two_link")
    shell = tl.shell(chain)
    target = np.array([0.0, -0.19, 1.40]) + np.array([r_scale * shell.r_min, 0.0, 0.0])
    res = tl.solve(chain, target)
    assert res.status == "unreachable" and "inner hole" in res.message
    assert np.all(np.isfinite(res.q))


def test_two_link_on_the_boundary():
    """A target exactly at r_max is reached with the elbow straight."""
    chain = Chain()
    tl = make_solver("two_link")
    shell = tl.shell(chain)
    target = np.array([0.0, -0.19, 1.40]) + shell.r_max * np.array([0.6, 0.0, 0.8])
    res = tl.solve(chain, target)
    assert res.converged and res.position_error < 1e-9


def test_look_at_aims_the_gaze():
    """look_at turns the neck so the gaze site's x axis points at the target."""
    chain = Chain(None, "gaze_site")
    target = np.array([0.8, -0.5, 1.2])
    res = make_solver("look_at").solve(chain, target)
    assert res.converged and res.orientation_error < 1e-6
    p, R = chain.fk(res.q)
    d = (target - p) / np.linalg.norm(target - p)
    assert float(R[:, 0] @ d) == pytest.approx(1.0, abs=1e-12)
    assert res.position_error < 1e-6


def test_look_at_behind_is_out_of_range():
    """A target behind the head needs more neck yaw than the range allows: not converged."""
    chain = Chain(None, "gaze_site")
    res = make_solver("look_at").solve(chain, [-1.0, 0.0, 1.6])
    assert not res.converged and "joint ranges" in res.message
    assert chain.within_limits(res.q)


def test_look_at_rotation_degenerate_up():
    """When forward is parallel to up another up is picked and the frame stays orthonormal."""
    from humanoid_ik import look_at

    R = look_at([0, 0, 0], [0, 0, 2], up=[0, 0, 1])
    np.testing.assert_allclose(R[:, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    with pytest.raises(TargetError, match="coincides"):
        look_at([1, 1, 1], [1, 1, 1])
    with pytest.raises(TargetError, match="forward axis 'w' unknown"):
        look_at([0, 0, 0], [1, 0, 0], forward_axis="w")


def test_solver_options_are_checked():
    """Unknown options, wrong types, and out-of-range values name the option."""
    with pytest.raises(
        SolverError, match="solver 'nope' unknown; solvers: auto, ccd, closed_form, dls"
    ):
        make_solver("nope")
    with pytest.raises(SolverError, match="option 'damp' unknown for solver 'dls'; options: "):
        make_solver("dls", damp=1)
    with pytest.raises(SolverError, match="'damping' of solver 'dls' must be a number"):
        make_solver("dls", damping="big")
    with pytest.raises(SolverError, match="must be a finite number >= 0"):
        make_solver("dls", damping=-1.0)
    with pytest.raises(SolverError, match="'max_iterations' .* must be an integer"):
        make_solver("dls", max_iterations=2.5)
    with pytest.raises(SolverError, match="'nudge' of solver 'ccd' must be in \\(0, 1\\]"):
        make_solver("ccd", nudge=1.5)
    with pytest.raises(SolverError, match="'method' of solver 'two_link' is 'euler'; choices"):
        make_solver("two_link", method="euler")
    with pytest.raises(SolverError, match="'tol' of solver 'dls' must be a number, got \\[1, 2\\]"):
        make_solver("dls", tol=[1, 2])
    with pytest.raises(SolverError, match="'restarts' of solver 'dls' must be a number"):
        make_solver("dls", restarts=True)


def test_position_only_solvers_refuse_pose_targets():
    """two_link, ccd and look_at refuse orientation targets with the reason."""
    chain = Chain()
    tgt = Target([0.3, -0.2, 1.1], [1, 0, 0, 0])
    for name in ("two_link", "ccd"):
        with pytest.raises(SolverError, match=f"{name} solves position targets only"):
            make_solver(name).solve(chain, tgt)


def test_two_link_takes_a_planar_arm_and_refuses_no_shoulder():
    """A planar two-hinge chain is solved exactly; a single hinge is refused with why."""
    from .chains import CCD_XML, chain

    planar = chain(CCD_XML, "p3")
    assert make_solver("two_link").applicable(planar) is None
    res = make_solver("two_link").solve(planar, [1.0, 2.0, 0.0], q0=[0.0, 0.0])
    assert res.converged and res.position_error < 1e-12
    np.testing.assert_allclose(planar.fk(res.q)[0], [1.0, 2.0, 0.0], atol=1e-12)
    one = chain(
        """<mujoco><worldbody><body><joint name="j" axis="0 0 1"/><geom size=".1"/>
        <site name="tip" pos="1 0 0"/></body></worldbody></mujoco>""",
        "tip",
    )
    reason = make_solver("two_link").applicable(one)
    assert reason is not None and "1, 2 or 3 shoulder hinges" in reason


def test_targets_are_checked():
    """NaN, wrong shapes, zero and non-unit quaternions are refused with the value."""
    with pytest.raises(TargetError, match="not finite"):
        Target([0.0, math.nan, 0.0])
    with pytest.raises(TargetError, match="3 values"):
        Target([0.0, 1.0])
    with pytest.raises(TargetError, match="zero norm"):
        Target([0, 0, 0], [0, 0, 0, 0])
    with pytest.raises(TargetError, match="norm 2; expected a unit quaternion"):
        Target([0, 0, 0], [2, 0, 0, 0])
    with pytest.raises(TargetError, match="beyond 1e\\+06 m"):
        Target([0, 1e300, 0])
    with pytest.raises(TargetError, match="4 values"):
        Target([0, 0, 0], [1, 0, 0])
    t = Target([0, 0, 0], [0.7071, 0, 0, 0.7071])
    assert np.linalg.norm(t.quat) == pytest.approx(1.0, abs=1e-15)


TIGHT_XML = """
<mujoco><compiler angle="radian" autolimits="true"/><worldbody><body>
  <joint name="s1" axis="0 1 0" range="-0.3 0.3"/><joint name="s2" axis="0 0 1" range="-0.3 0.3"/>
  <joint name="s3" axis="1 0 0" range="-0.3 0.3"/>
  <geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/>
  <body pos="1 0 0"><joint name="el" axis="0 0 1" range="-2 2"/>
    <geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/><site name="tip" pos="1 0 0"/></body>
</body></worldbody></mujoco>
"""

SKEW_XML = """
<mujoco><compiler angle="radian"/><worldbody><body>
  <joint name="s1" axis="0 1 0"/><joint name="s2" axis="0 0 1" pos="0.2 0 0"/>
  <joint name="s3" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/>
  <body pos="1 0 0"><joint name="el" axis="1 0 0"/>
    <geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/><site name="tip" pos="1 0 0"/></body>
</body></worldbody></mujoco>
"""


def test_two_link_out_of_joint_ranges():
    """A target inside the shell but behind tight shoulder ranges: unreachable, in range."""
    chain = Chain(model(TIGHT_XML), "tip")
    res = make_solver("two_link").solve(chain, [-1.5, 0.0, 0.0])
    assert res.status == "unreachable" and "inside the joint ranges" in res.message
    assert chain.within_limits(res.q) and np.all(np.isfinite(res.q))


def test_two_link_structure_reasons():
    """Shoulder axes that do not meet, and an elbow on the arm's line, are named."""
    skew = Chain(model(SKEW_XML), "tip")
    assert "meet at one point" in make_solver("two_link").applicable(skew)
    aligned = Chain(model(SKEW_XML.replace('pos="0.2 0 0"', "")), "tip")
    assert "does not pass through the shoulder" in make_solver("two_link").applicable(aligned)
    with pytest.raises(SolverError, match="meet at one point"):
        make_solver("two_link").solve(skew, [1.0, 1.0, 0.0])


def test_look_at_refuses_orientation_targets():
    """look_at aims an axis: a pose target is refused with the reason."""
    chain = Chain(None, "gaze_site")
    with pytest.raises(SolverError, match="look_at aims an axis at a point"):
        make_solver("look_at").solve(chain, Target([1, 0, 1.6], [1, 0, 0, 0]))


def test_bad_up_and_quaternion_values():
    """A zero up vector and a NaN quaternion are refused with the value."""
    from humanoid_ik import look_at

    with pytest.raises(TargetError, match="up vector \\[0.0, 0.0, 0.0\\] has zero length"):
        look_at([0, 0, 0], [1, 0, 0], up=[0, 0, 0])
    with pytest.raises(TargetError, match="quaternion .* is not finite"):
        Target([0, 0, 0], [1, 0, math.inf, 0])


def test_result_status_is_checked():
    """IKResult refuses a status outside converged / max_iterations / unreachable."""
    from humanoid_ik import IKResult

    with pytest.raises(ValueError, match="status 'done' unknown; statuses: converged"):
        IKResult(np.zeros(2), True, 1, 0.0, None, "done")


@pytest.mark.parametrize(
    ("solver", "option", "value", "message"),
    [
        ("ccd", "max_iterations", 100_001, "an integer >= 0 and <= 100000, got 100001"),
        ("ccd", "restarts", 1_001, "an integer >= 0 and <= 1000, got 1001"),
        ("ccd", "stall_window", 10**9, "an integer >= 0 and <= 100000, got 1000000000"),
        ("closed_form", "swivel", 7.0, "a finite number >= -6.28319 and <= 6.28319, got 7.0"),
        ("closed_form", "swivel", -7.0, "a finite number >= -6.28319 and <= 6.28319, got -7.0"),
        ("dls", "library_seeds", 4_001, "an integer >= 0 and <= 4000, got 4001"),
        ("mink", "rot_tol", 4.0, "a finite number >= 0 and <= 3.14159, got 4.0"),
        *[
            (name, "tol", 1.5, "a finite number >= 0 and <= 1, got 1.5")
            for name in ("two_link", "closed_form", "ccd", "look_at", "mink", "auto", "lm")
        ],
        *[
            (name, "rot_tol", 1e308, "a finite number >= 0 and <= 3.14159, got 1e+308")
            for name in ("two_link", "closed_form", "dls")
        ],
    ],
)
def test_option_bounds(solver, option, value, message):
    """A value past an option's bound is refused in one line naming the option, the
    solver and both bounds."""
    with pytest.raises(SolverError, match=f"option '{option}' of solver '{solver}' must be ") as e:
        make_solver(solver, **{option: value})
    assert str(e.value).endswith(message) and "\n" not in str(e.value)


@pytest.mark.parametrize(
    ("solver", "options"),
    [
        ("ccd", {"max_iterations": 100_000, "restarts": 1_000, "stall_window": 100_000}),
        ("closed_form", {"swivel": -2 * math.pi, "tol": 1.0, "rot_tol": math.pi}),
        ("two_link", {"tol": 0.0, "rot_tol": math.pi}),
        ("dls", {"library_seeds": 4_000, "nullspace_gain": 1.0}),
    ],
)
def test_option_bounds_are_inclusive(solver, options):
    """Each bound itself is accepted and kept."""
    s = make_solver(solver, **options)
    for key, value in options.items():
        assert getattr(s.options, key) == value


def test_bounds_merge_along_the_options_classes():
    """Every solver's options carry tol and rot_tol bounds; a family adds its own, a
    subclass entry winning (lm's stall_window has a lower bound of 2)."""
    from humanoid_ik.solvers import SOLVERS

    for cls in SOLVERS.values():
        b = cls.Options.bounds()
        assert b["tol"] == (0.0, 1.0) and b["rot_tol"] == (0.0, math.pi)
    assert SOLVERS["dls"].Options.bounds()["restarts"] == (0, 1_000)
    assert SOLVERS["lm"].Options.bounds()["stall_window"] == (2, 100_000)
    assert "swivel" in SOLVERS["closed_form"].Options.bounds()


def test_cli_option_past_a_bound_is_one_line(capsys):
    """`solve --solver ccd --option restarts=5000` exits 2 with the bound in one line."""
    from humanoid_ik.cli.app import main

    code = main(
        ["solve", "--target", "0.3,-0.2,1.1", "--solver", "ccd", "--option", "restarts=5000"]
    )
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "option 'restarts' of solver 'ccd' must be an integer >= 0 and <= 1000, got 5000" in err


def test_no_solver_leaves_the_ranges(rng):
    """Property: every solver, on random targets in a 3 m box around the bundled arm's
    hand (reachable or not, pose targets for those that take them), from random starts,
    answers inside the joint ranges exactly."""
    from humanoid_ik.solvers import SOLVERS

    chain = Chain()
    centre = chain.position.copy()
    cases = [(chain.random_q(rng), centre + rng.uniform(-1.5, 1.5, 3)) for _ in range(4)]
    quat = mat_to_quat(chain.rotation)
    for name, cls in SOLVERS.items():
        has_restarts = "restarts" in {f.name for f in dataclasses.fields(cls.Options)}
        options = {"restarts": 1} if has_restarts else {}  # quick: one restart
        solver = make_solver(name, **options)
        for q0, p in cases:
            for pose in (False, True):
                tgt = Target(p, quat if pose else None)
                if solver.applicable(chain, pose) is not None:
                    continue
                res = solver.solve(chain, tgt, q0)
                assert chain.within_limits(res.q, tol=0.0), (name, pose, res.q)


@pytest.mark.parametrize(
    ("q0", "got"),
    [
        (np.full(7, 0.1 + 1j), "complex numbers: [(0.1+1j), (0.1+1j)"),
        (np.zeros(7, complex), "complex numbers: [0j, 0j"),  # no imaginary part: still refused
        (["0.1"] * 7, "text: ['0.1', '0.1'"),
        (np.array(["0"] * 7), "text: ['0', '0'"),
        ([True] * 7, "true/false values: [true, true"),
        ([0.1, None, 0, 0, 0, 0, 0], "objects that are not real numbers: [0.1, None, 0"),
        ("0000000", "text: '0000000'"),
    ],
)
@pytest.mark.parametrize("solver_name", sorted(SOLVERS))
def test_a_start_that_is_not_real_numbers_is_refused(solver_name, q0, got):
    """``solve(..., q0=...)``: text, booleans, complex numbers (NumPy would turn them into
    reals, a complex one with only a warning) are one TargetError line, for every solver;
    so are the wrong length and NaN. The robot state is left as it was. (``subproblem``
    solves pose targets of 6 hinges: the bundled arm's first six, a pose target.)"""
    chain = Chain()
    target: Target | list[float] = [0.3, -0.25, 1.15]
    if solver_name == "subproblem":
        chain = Chain(joints=chain.joint_names[:6])
        chain.set_q(np.full(6, 0.2))
        target = Target(chain.position.copy(), mat_to_quat(chain.rotation.copy()))
        chain.reset()
        q0 = q0 if isinstance(q0, str) else q0[:6]  # a string is refused before its length
    n = chain.n
    before = chain.data.qpos.copy()
    with pytest.raises(TargetError) as info:
        solve(chain, target, solver_name, q0=q0)
    message = str(info.value)
    assert message.startswith(f"joint vector must be {n} real numbers (rad), got {got}")
    assert "\n" not in message and len(message) < 160
    np.testing.assert_array_equal(chain.data.qpos, before)
    short, nan = [0.1] * (n - 1), [math.nan] * n
    for bad, said in ((short, rf"shape \({n},\), got \({n - 1},\)"), (nan, "not finite")):
        with pytest.raises(TargetError, match=said):
            solve(chain, target, solver_name, q0=bad)
    # a float64 array of the right shape takes a shorter way in: the same refusals
    for bad in (np.full(n, math.nan), np.r_[np.zeros(n - 1), -math.inf]):
        with pytest.raises(TargetError, match="is not finite"):
            solve(chain, target, solver_name, q0=bad)
    np.testing.assert_array_equal(chain.data.qpos, before)
    # real numbers of any NumPy kind are taken: ints, float32, an object array of numbers
    for good in (list(range(n)), np.zeros(n, np.float32), np.zeros(n, object)):
        assert solve(chain, target, solver_name, q0=good).q.shape == (n,)
    # finite values whose sum overflows are a start, moved into the ranges; the caller's
    # array is not the one clipped
    huge = np.full(n, 1e308)
    solve(chain, target, solver_name, q0=huge)
    np.testing.assert_array_equal(huge, np.full(n, 1e308))


_MOCAP_ARM = """<mujoco><compiler angle="radian"/><worldbody>
<body name="base" mocap="true" pos="0 0 0.5">
  <body name="l1"><joint name="j1" axis="0 0 1" range="-3 3"/><geom size=".05"/>
    <body name="l2" pos="0 0 0.1"><joint name="j2" axis="0 1 0" range="-3 3"/><geom size=".05"/>
      <body name="l3" pos="0.3 0 0"><joint name="j3" axis="0 1 0" range="-3 3"/><geom size=".05"/>
        <site name="tip" pos="0.3 0 0"/></body></body></body></body>
</worldbody></mujoco>"""


def test_every_solver_follows_a_moved_mocap_base():
    """An arm below a mocap body that the caller's MjData moved 1 m: each solver that
    applies to its position targets reaches a target near the moved base, its error is
    MuJoCo's FK of the answer with the moved base, and a target reachable only from
    the model's own base pose is not reported converged (``lm``'s compiled loop and the
    ``mink`` QP's own MjData once solved on the model's mocap pose: ``lm`` reported such a
    target converged, 1 m off). ``closed_form`` and ``subproblem`` do not apply to 3
    hinges; their arms' base is read from the robot state (``tests/test_real_arms.py``)."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(_MOCAP_ARM)
    d = mujoco.MjData(m)
    d.mocap_pos[0] = [1.0, 0.0, 0.5]
    mujoco.mj_forward(m, d)
    checked = []
    for name in sorted(SOLVERS):
        chain = Chain(m, "tip")
        solver = make_solver(name)
        if not solver.reaches or solver.applicable(chain) is not None:
            continue
        for target, reachable in (([1.3, 0.2, 0.7], True), ([0.3, 0.2, 0.7], False)):
            res = solver.solve(chain, target, data=d)
            truth = mujoco.MjData(m)
            truth.qpos[:] = d.qpos
            truth.mocap_pos[:] = d.mocap_pos
            truth.qpos[chain.qpos_adr] = res.q
            mujoco.mj_kinematics(m, truth)
            error = float(np.linalg.norm(truth.site_xpos[0] - target))
            assert res.position_error == pytest.approx(error, abs=1e-9), name
            if reachable:
                assert res.converged, name
            if not reachable:
                assert not res.converged and error > 0.1, name
        checked.append(name)
    assert checked == [
        "auto", "ccd", "dls", "fabrik", "jacobian_transpose", "lm", "mink", "pseudoinverse",
        "two_link",
    ]  # fmt: skip


_MOCAP_SRS_ARM = """<mujoco><compiler angle="radian"/><worldbody>
<body name="base" mocap="true" pos="0 0 0.8">
  <body name="s1"><joint name="s1" axis="0 0 1" range="-2.5 2.5"/><geom size=".04"/>
  <body name="s2"><joint name="s2" axis="0 1 0" range="-2.5 2.5"/><geom size=".04"/>
  <body name="s3"><joint name="s3" axis="1 0 0" range="-2.5 2.5"/><geom size=".04"/>
  <body name="upper" pos="0.3 0 0"><joint name="e" axis="0 1 0" range="-2.5 0.05"/>
    <geom size=".04"/>
  <body name="w1" pos="0.3 0 0"><joint name="w1" axis="1 0 0" range="-2.5 2.5"/>
    <geom size=".03"/>
  <body name="w2"><joint name="w2" axis="0 1 0" range="-2.5 2.5"/><geom size=".03"/>
  <body name="w3"><joint name="w3" axis="0 0 1" range="-2.5 2.5"/><geom size=".03"/>
    <site name="hand" pos="0.1 0 0"/>
  </body></body></body></body></body></body></body>
</body></worldbody></mujoco>"""


def test_the_exact_solvers_follow_a_moved_mocap_base():
    """A 7-hinge arm (spherical shoulder, elbow, spherical wrist) below a mocap body that
    the caller's MjData moved and turned: ``closed_form`` (its arm geometry), ``subproblem``
    (its search), ``lm``, ``auto`` and ``mink`` reach a pose target set at the moved base,
    errors MuJoCo's FK of the answer with the moved base (``Chain.base_state`` holds the
    mocap pose: the exact solvers' caches read the base again when it moves)."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(_MOCAP_SRS_ARM)
    d = mujoco.MjData(m)
    q_goal = np.array([0.4, -0.3, 0.5, -1.2, 0.3, 0.4, -0.2])
    chain = Chain(m, "hand")  # one robot state: its caches built at the first base
    for base, turn in (([0.0, 0.0, 0.8], [1.0, 0, 0, 0]), ([1.0, -0.5, 0.6], [0.9, 0, 0, 0.43])):
        d.mocap_pos[0], d.mocap_quat[0] = base, turn
        d.qpos[:] = q_goal
        mujoco.mj_forward(m, d)
        target = Target(d.site_xpos[0].copy(), mat_to_quat(d.site_xmat[0].reshape(3, 3).copy()))
        d.qpos[:] = 0.0
        mujoco.mj_forward(m, d)
        for name in ("closed_form", "subproblem", "lm", "auto", "mink"):
            res = make_solver(name).solve(chain, target, data=d)
            truth = mujoco.MjData(m)
            truth.mocap_pos[:], truth.mocap_quat[:] = d.mocap_pos, d.mocap_quat
            truth.qpos[chain.qpos_adr] = res.q
            mujoco.mj_kinematics(m, truth)
            error = float(np.linalg.norm(truth.site_xpos[0] - target.position))
            assert res.converged and error < 1e-4, (name, base, error)
            assert res.position_error == pytest.approx(error, abs=1e-9), name
