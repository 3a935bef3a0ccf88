"""``subproblem``: exact IK of 6-hinge arms by Paden-Kahan subproblems, against oracles.

Arms: random ones of every family (lengths, offsets, axis directions and base poses
unlike UR5's and Kinova's), built as MJCF strings, and the real UR5 and Kinova j2s6s200.
Oracles: MuJoCo's FK of every solution (to 1e-9), the joint vector a target was made
from (always among the solutions), and a dense numeric search (many ``lm`` starts)
whose every answer must be one of ours; the ranges and the 2 pi shift checked against
a plain Python reading of the same rule."""

from __future__ import annotations

import math
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik import Chain, Target, solve
from humanoid_ik.core.rotations import mat_to_quat, quat_to_mat
from humanoid_ik.core.types import Status
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.analytic.subproblem import family_of, solutions, subproblem_cache
from humanoid_ik.solvers.analytic.subproblem.geometry import arm_geometry
from humanoid_ik.solvers.jacobian.lm import LM
from humanoid_ik.solvers.registry import make_solver

from .robots import robot_file

FAMILIES = {
    "parallel": "three parallel axes (h2 || h3 || h4)",
    "parallel_reversed": "three parallel axes (h3 || h4 || h5)",
    "parallel_meet56": "three parallel axes (h2 || h3 || h4), h5 and h6 meet",
    "parallel_reversed_meet12": "three parallel axes (h3 || h4 || h5), h1 and h2 meet",
    "wrist_23": "spherical wrist (axes 4, 5, 6 meet), h2 || h3",
    "wrist_12": "spherical wrist (axes 4, 5, 6 meet), h1 || h2",
    "wrist_meet12": "spherical wrist (axes 4, 5, 6 meet), h1 and h2 meet",
    "wrist_meet23": "spherical wrist (axes 4, 5, 6 meet), h2 and h3 meet",
    "shoulder_45": "spherical shoulder (axes 1, 2, 3 meet), h4 || h5",
}
"""The random arms' kinds and the family each must be found in."""


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def random_arm(
    kind: str, seed: int, ranges: list[tuple[float, float]] | None = None, mid: bool = False
) -> str:
    """An MJCF 6-hinge arm of ``kind`` (a key of :data:`FAMILIES`): random axes, links of
    0.1-0.5 m in random directions, a random base pose, a random end site; joints
    unlimited unless ``ranges``. A torso hinge ``torso`` above the arm moves its base;
    with ``mid`` a hinge ``mid`` between ``j4`` and ``j5`` (off the chain) too."""
    rng = np.random.default_rng(seed)
    axes = [_unit(rng) for _ in range(6)]
    links = [_unit(rng) * rng.uniform(0.1, 0.5) for _ in range(6)]  # body i+1 from body i
    sign = lambda: rng.choice([-1.0, 1.0])  # noqa: E731
    if kind.startswith("parallel"):
        a, b, c = (2, 3, 4) if kind.startswith("parallel_reversed") else (1, 2, 3)
        axes[b], axes[c] = sign() * axes[a], sign() * axes[a]
        if kind == "parallel_meet56":  # body 6 at body 5's origin: axes 5 and 6 meet (UR)
            links[4] = np.zeros(3)
        if kind == "parallel_reversed_meet12":  # body 2 at body 1's: axes 1 and 2 meet
            links[0] = np.zeros(3)
    if kind.startswith("wrist"):
        links[3] = links[4] = np.zeros(3)  # bodies 4, 5, 6 at one point
        if kind == "wrist_23":
            axes[2] = sign() * axes[1]
        elif kind == "wrist_12":
            axes[1] = sign() * axes[0]
        elif kind == "wrist_meet12":
            links[0] = np.zeros(3)
        else:
            links[1] = np.zeros(3)
    if kind == "shoulder_45":
        links[0] = links[1] = np.zeros(3)  # bodies 1, 2, 3 at one point
        axes[4] = sign() * axes[3]
    quat = rng.normal(size=4)
    quat /= np.linalg.norm(quat)
    site = _unit(rng) * rng.uniform(0.05, 0.2)
    fmt = lambda v: " ".join(f"{x:.17g}" for x in v)  # noqa: E731
    body = f'<site name="tip" pos="{fmt(site)}"/>'
    for i in range(5, -1, -1):
        rng_attr = "" if ranges is None else f' range="{ranges[i][0]!r} {ranges[i][1]!r}"'
        pos = fmt(links[i - 1]) if i else "0 0 0"
        extra = f'<joint name="mid" axis="{fmt(_unit(rng))}"/>' if mid and i == 3 else ""
        body = (
            f'<body name="b{i + 1}" pos="{pos}"><joint name="j{i + 1}" axis="{fmt(axes[i])}"'
            f'{rng_attr}/>{extra}<geom type="sphere" size="0.02"/>{body}</body>'
        )
    return (
        '<mujoco><compiler angle="radian" autolimits="true"/><worldbody>'
        f'<body name="torso" pos="{fmt(rng.uniform(-1, 1, 3))}" quat="{fmt(quat)}">'
        '<joint name="torso" axis="0.3 0.4 0.866"/><geom type="sphere" size="0.05"/>'
        f"{body}</body></worldbody></mujoco>"
    )


def arm_chain(kind: str, seed: int, **kw) -> Chain:
    return Chain.from_xml_string(
        random_arm(kind, seed, **kw), site="tip", joints=[f"j{i}" for i in range(1, 7)]
    )


def real_chain(name: str) -> Chain:
    """UR5, Kinova, or ``humanoid6``: the bundled arm without its last wrist hinge (a
    spherical shoulder whose last two axes meet: the reversed chain's case)."""
    if name == "humanoid6":
        return Chain(joints=Chain().joint_names[:6])
    body = {"ur5": "ee_link", "kinova": "j2s6s200_end_effector"}[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Kinova's home pose outside its ranges
        return Chain(robot_file(name), body=body)


def pose_at(chain: Chain, q: np.ndarray) -> Target:
    p, R = chain.fk(q)
    return Target(p.copy(), mat_to_quat(R))


def same_angles(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """``a`` and ``b`` equal modulo 2 pi, joint by joint, within ``tol`` [rad]."""
    d = np.remainder(np.asarray(a) - np.asarray(b) + math.pi, 2 * math.pi) - math.pi
    return bool(np.abs(d).max() <= tol)


def check_solutions(chain: Chain, target: Target, sols: list[np.ndarray]) -> None:
    """Every solution's MuJoCo FK equals the target to 1e-9."""
    R_t = quat_to_mat(target.quat)
    for s in sols:
        p, R = chain.fk(s)
        np.testing.assert_allclose(p, target.position, rtol=0, atol=1e-9)
        np.testing.assert_allclose(R, R_t, rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- families
@pytest.mark.parametrize("kind", sorted(FAMILIES))
def test_random_arms_are_found_in_their_family(kind):
    for seed in range(3):
        fam = subproblem_cache(arm_chain(kind, seed)).family
        assert fam is not None and fam.name == FAMILIES[kind]


def test_real_arms_families_and_refusals():
    """UR5: three parallel axes; Kinova: a spherical wrist with h2 || h3; the bundled arm
    with its last joint searched. A 5-hinge arm, a 6-hinge arm of random axes and one
    whose wrist meets but whose other axes neither meet nor are parallel get a reason,
    said by applicable() and by solve()."""
    assert subproblem_cache(real_chain("ur5")).family.name == FAMILIES["parallel_meet56"]
    assert subproblem_cache(real_chain("kinova")).family.name == FAMILIES["wrist_23"]
    assert subproblem_cache(real_chain("humanoid6")).family.name == (
        "spherical shoulder (axes 1, 2, 3 meet), h5 and h6 meet"
    )
    assert subproblem_cache(Chain()).family.name == (
        "spherical shoulder (axes 1, 2, 3 meet), h5 and h6 meet, joint 7 searched"
    )
    solver = make_solver("subproblem")
    five = Chain(joints=Chain().joint_names[:5])
    assert "needs 6 or 7 hinges; the chain has 5" in solver.applicable(five, True)
    general = arm_chain("none", 0)
    why = solver.applicable(general, True)
    assert why.startswith("subproblem needs a spherical wrist or shoulder")
    wrist = arm_chain("wrist_23", 0)
    geo, _ = arm_geometry(wrist)
    h = geo.axes.copy()
    h[2] = np.cross(h[1], h[0]) / np.linalg.norm(np.cross(h[1], h[0]))  # h2, h3 not parallel
    fam, why = family_of(geo._replace(axes=h))
    assert fam is None and "axes 4-6 meet" in why and "general 3R" in why
    with pytest.raises(SolverError, match="needs a spherical wrist"):
        solver.solve(general, pose_at(general, np.zeros(6)))
    ur5 = real_chain("ur5")
    with pytest.raises(SolverError, match="pose targets only"):
        solve(ur5, [0.3, 0.2, 0.4], "subproblem")


# ----------------------------------------------------------------------------- oracles
@pytest.mark.parametrize("kind", sorted(FAMILIES))
def test_every_solution_reaches_the_target_and_none_is_missed(kind):
    """Random arms, random targets: every solution's FK is the target to 1e-9, the
    joint vector the target was made from is among them, no two are the same, and
    every answer of 40 ``lm`` starts (tolerances 1e-10) is one of them."""
    rng = np.random.default_rng(7)
    dense = LM(restarts=0, tol=1e-10, rot_tol=1e-10, max_iterations=200)
    counts = []
    for seed in range(4):
        chain = arm_chain(kind, 10 + seed)
        for _ in range(3):
            q = rng.uniform(-math.pi, math.pi, 6)
            target = pose_at(chain, q)
            sols = solutions(chain, target)
            counts.append(len(sols))
            assert any(same_angles(s, q, 1e-7) for s in sols)
            check_solutions(chain, target, sols)
            for i, a in enumerate(sols):
                assert not any(same_angles(a, b, 1e-6) for b in sols[i + 1 :])
            for _ in range(40):
                res = dense.solve(chain, target, rng.uniform(-math.pi, math.pi, 6))
                if res.converged:
                    assert any(same_angles(res.q, s, 1e-5) for s in sols), res.q
    assert max(counts) >= 4 and all(c <= 8 for c in counts)


@pytest.mark.parametrize("name", ["ur5", "kinova", "humanoid6"])
def test_real_arms_every_solution_and_none_missed(name):
    """UR5, Kinova and the bundled arm's first six hinges: the same oracles inside the
    real ranges (lm stays in them)."""
    chain = real_chain(name)
    rng = np.random.default_rng(11)
    dense = LM(restarts=0, tol=1e-10, rot_tol=1e-10, max_iterations=200)
    found = 0
    for _ in range(8):
        q = chain.random_q(rng)
        target = pose_at(chain, q)
        sols = solutions(chain, target)
        assert any(same_angles(s, q, 1e-7) for s in sols)
        check_solutions(chain, target, sols)
        for _ in range(30):
            res = dense.solve(chain, target, chain.random_q(rng))
            if res.converged:
                found += 1
                assert any(same_angles(res.q, s, 1e-5) for s in sols), res.q
    assert found > 20  # the search is a real one (of 240 starts)


# ----------------------------------------------------------------------------- ranges
def nearest_in_range(chain: Chain, sols: list[np.ndarray], q0: np.ndarray):
    """The rule in plain Python: each angle shifted by 2 pi k into its range nearest the
    start; the in-range solution nearest the start."""
    best, best_d = None, math.inf
    for s in sols:
        x = np.empty(6)
        for k in range(6):
            fits = [
                s[k] + 2 * math.pi * m
                for m in range(-3, 4)
                if chain.lower[k] - 1e-9 <= s[k] + 2 * math.pi * m <= chain.upper[k] + 1e-9
            ]
            if not fits:
                break
            x[k] = min(fits, key=lambda v: abs(v - q0[k]))
        else:
            d = float(((x - q0) ** 2).sum())
            if d < best_d:
                best, best_d = x, d
    return best


def quat_from(rng: np.random.Generator) -> np.ndarray:
    """A seeded random unit quaternion."""
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


@pytest.mark.parametrize("name", ["ur5", "kinova"])
def test_ranges_with_the_2pi_shift_and_the_nearest_solution(name):
    """UR5's joints span [-2 pi, 2 pi] (two shifts fit: the one nearest the start is
    taken), Kinova's limited joints lie in [0.33, 5.96] (solutions in (-pi, pi] need
    a shift of 2 pi), its others are unlimited (moved nearest the start): the answer
    is the plain rule's, inside the ranges, and its FK is the target. A target beyond
    reach returns the start, its errors (measured in ``lm``'s kernel) MuJoCo FK's."""
    chain = real_chain(name)
    solver = make_solver("subproblem")
    rng = np.random.default_rng(5)
    shifted = 0
    for _ in range(40):
        target = pose_at(chain, chain.random_q(rng))
        q0 = chain.random_q(rng)
        want = nearest_in_range(chain, solutions(chain, target, q0), q0)
        res = solver.solve(chain, target, q0)
        assert res.converged and res.status is Status.CONVERGED and res.iterations == 1
        assert chain.within_limits(res.q, tol=0.0)
        np.testing.assert_allclose(res.q, want, rtol=0, atol=1e-9)
        assert res.position_error < 1e-9 and res.orientation_error < 1e-9
        assert res.details["inside"] >= 1 and res.details["solutions"] >= res.details["inside"]
        shifted += int(np.abs(res.q).max() > math.pi)
        # the errors (measured in lm's kernel) are those of MuJoCo's FK of the answer
        far = Target(target.position * 5.0 + [0.0, 0.0, 2.0], quat_from(rng))
        off = solver.solve(chain, far, res.q)  # beyond reach: the start, metres off
        p, R = chain.fk(off.q)
        assert off.position_error == pytest.approx(np.linalg.norm(p - far.position), abs=1e-12)
        angle = np.arccos(np.clip((np.trace(quat_to_mat(far.quat).T @ R) - 1) / 2, -1, 1))
        assert off.orientation_error == pytest.approx(angle, abs=1e-7)
        assert not off.converged and off.position_error > 0.1
    assert shifted > 10  # the shift was needed


def test_a_target_whose_solutions_all_leave_the_ranges_is_unreachable():
    """Ranges of +-0.2 rad about zero; a target made at 1 rad per joint: every solution
    leaves them, so the answer is ``unreachable``, the least violating one clipped."""
    ranges = [(-0.2, 0.2)] * 6
    chain = arm_chain("wrist_23", 3, ranges=ranges)
    target = pose_at(chain, np.full(6, 1.0))
    assert nearest_in_range(chain, solutions(chain, target), np.zeros(6)) is None
    res = make_solver("subproblem").solve(chain, target, np.zeros(6))
    assert res.status is Status.UNREACHABLE and not res.converged
    assert "none inside the joint ranges" in res.message
    assert res.details["solutions"] >= 1 and res.details["inside"] == 0
    assert chain.within_limits(res.q, tol=0.0)


def test_a_target_beyond_reach_is_unreachable():
    chain = real_chain("ur5")
    p, R = chain.fk(chain.q_home)
    start = chain.q_home.copy()
    res = make_solver("subproblem").solve(chain, Target(p + [3.0, 0, 0], mat_to_quat(R)), start)
    assert res.status is Status.UNREACHABLE and res.details["solutions"] == 0
    assert "beyond the arm's reach" in res.message
    np.testing.assert_array_equal(res.q, start)
    assert res.position_error > 2.0


@pytest.mark.parametrize("joint", ["torso", "mid"])
def test_a_moved_joint_off_the_chain_is_followed(joint):
    """The geometry is read in the base frame: after the torso hinge (above the chain)
    or a hinge between its joints (off the chain) turns, answers are exact in the arm's
    new pose."""
    chain = arm_chain("parallel", 4, mid=True)
    solver = make_solver("subproblem")
    adr = chain.model.joint(joint).qposadr[0]
    q = np.array([0.3, -1.0, 0.5, 2.0, -0.4, 1.2])
    for angle in (0.0, 0.7, -1.9):
        chain.data.qpos[adr] = angle
        target = pose_at(chain, q)
        res = solver.solve(chain, target, np.zeros(6))
        assert res.converged and res.position_error < 1e-9 and res.orientation_error < 1e-9
        assert any(same_angles(s, q, 1e-7) for s in solutions(chain, target))


# ----------------------------------------------------------------------------- threads
def test_one_solver_object_serves_two_threads():
    """Two threads, each with its own UR5, ONE solver object: every answer is the one a
    fresh solver gives on a third chain (solving the targets in reverse order)."""
    solver = make_solver("subproblem")
    rng = np.random.default_rng(3)
    alone = real_chain("ur5")
    targets = [pose_at(alone, alone.random_q(rng)) for _ in range(100)]
    start = alone.q_home.copy()
    fresh = make_solver("subproblem")
    reference = [fresh.solve(alone, t, start) for t in targets[::-1]][::-1]
    assert all(r.converged for r in reference)
    wrong = [0, 0]

    def run(k: int) -> None:
        chain = real_chain("ur5")
        for t, ref in zip(targets, reference, strict=True):
            got = solver.solve(chain, t, start)
            if not np.array_equal(got.q, ref.q) or got.status is not ref.status:
                wrong[k] += 1

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == [0, 0]


# ----------------------------------------------------------------------------- 7 hinges
SEARCHED = {
    "meet56_last": "spherical shoulder (axes 1, 2, 3 meet), h5 and h6 meet, joint 7 searched",
    "meet23_first": "spherical wrist (axes 5, 6, 7 meet), h2 and h3 meet, joint 1 searched",
}
"""Random 7-hinge arms (Panda-like: the last joint held leaves a spherical shoulder and
axes 5, 6 that meet; Talos-like: the first held leaves a spherical wrist and axes 2, 3
that meet) and the family each must be found in."""


def random_arm7(kind: str, seed: int, limit: float | None = None) -> Chain:
    """A 7-hinge MJCF arm of ``kind`` (a key of :data:`SEARCHED`): random axes, links of
    0.1-0.5 m, a random end site; joints in [-limit, limit] or unlimited."""
    rng = np.random.default_rng(seed)
    axes = [_unit(rng) for _ in range(7)]
    links = [_unit(rng) * rng.uniform(0.1, 0.5) for _ in range(6)]  # body i+2 from body i+1
    zero = (0, 1, 4) if kind == "meet56_last" else (1, 4, 5)  # the bodies at one point
    for i in zero:
        links[i] = np.zeros(3)
    fmt = lambda v: " ".join(f"{x:.17g}" for x in v)  # noqa: E731
    body = f'<site name="tip" pos="{fmt(_unit(rng) * rng.uniform(0.05, 0.2))}"/>'
    for i in range(6, -1, -1):
        lim = "" if limit is None else f' range="{-limit!r} {limit!r}"'
        pos = fmt(links[i - 1]) if i else "0 0 0"
        body = (
            f'<body name="b{i + 1}" pos="{pos}"><joint name="j{i + 1}" axis="{fmt(axes[i])}"'
            f'{lim}/><geom type="sphere" size="0.02"/>{body}</body>'
        )
    xml = (
        '<mujoco><compiler angle="radian" autolimits="true"/><worldbody>'
        f'<body name="base" pos="0.1 -0.2 0.3" quat="0.9 0.1 0.3 -0.2">{body}</body>'
        "</worldbody></mujoco>"
    )
    return Chain.from_xml_string(xml, site="tip", joints=[f"j{i}" for i in range(1, 8)])


def searched_real(name: str) -> Chain:
    """Panda's arm or Talos's left arm, from example-robot-data's URDFs."""
    from humanoid_ik.core.limbs import limb_chain
    from humanoid_ik.core.models import load_model
    from humanoid_ik.core.robot import Robot

    robot, limb = {"panda": ("panda", "arm"), "talos": ("talos", "left_arm")}[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a home pose outside the ranges
        return limb_chain(Robot(load_model(str(robot_file(robot)))), limb)


@pytest.mark.parametrize("kind", sorted(SEARCHED))
def test_seven_hinges_every_solution_at_the_held_joint_and_none_missed(kind):
    """Random 7-hinge arms: with the held joint at a value, every solution's FK is the
    target to 1e-9 and the joint vector the target was made from is among them; every
    answer of 30 ``lm`` starts (tolerances 1e-10, any value of the held joint) is among
    the solutions at its own value of that joint."""
    rng = np.random.default_rng(3)
    dense = LM(restarts=0, tol=1e-10, rot_tol=1e-10, max_iterations=200)
    k = 6 if kind.endswith("last") else 0
    checked = 0
    for seed in range(3):
        chain = random_arm7(kind, 20 + seed)
        family = subproblem_cache(chain).family
        assert family is not None and family.name == SEARCHED[kind] and family.locked == k
        for _ in range(3):
            q = rng.uniform(-math.pi, math.pi, 7)
            target = pose_at(chain, q)
            sols = solutions(chain, target, q)
            assert all(s.shape == (7,) and s[k] == q[k] for s in sols)
            assert any(same_angles(s, q, 1e-7) for s in sols)
            check_solutions(chain, target, sols)
            for _ in range(30):
                res = dense.solve(chain, target, rng.uniform(-math.pi, math.pi, 7))
                if res.converged:
                    checked += 1
                    at = solutions(chain, target, res.q)
                    assert any(same_angles(res.q, s, 1e-5) for s in at), res.q
    assert checked > 50  # the search is a real one (of 270 starts)


@pytest.mark.parametrize("kind", sorted(SEARCHED))
def test_seven_hinges_the_search_finds_an_answer_in_the_ranges(kind):
    """Limited random 7-hinge arms, targets at in-range joint vectors, solved from zero:
    at least 99.5 % exact answers inside the ranges, the searched joint in its range; a
    target beyond reach is unreachable after the whole range was tried."""
    solver = make_solver("subproblem")
    solved = total = 0
    for seed in range(4):
        chain = random_arm7(kind, 40 + seed, limit=2.0)
        rng = np.random.default_rng(seed)
        for _ in range(50):
            target = pose_at(chain, chain.random_q(rng))
            res = solver.solve(chain, target, np.zeros(7))
            total += 1
            if res.converged:
                solved += 1
                assert res.details["inside"] >= 1 and res.details["tried"] >= 1
                assert np.all(res.q >= chain.lower - 1e-9) and np.all(res.q <= chain.upper + 1e-9)
                check_solutions(chain, target, [res.q])
    assert solved >= 0.995 * total
    far = Target(chain.fk(np.zeros(7))[0] * 0 + 50.0, [1.0, 0.0, 0.0, 0.0])
    res = solver.solve(chain, far, np.zeros(7))
    assert res.status is Status.UNREACHABLE and res.details["solutions"] == 0
    assert res.details["tried"] > 200  # 4 rad at 0.25, then at 0.02
    np.testing.assert_array_equal(res.q, np.zeros(7))


@pytest.mark.parametrize("name", ["panda", "talos"])
def test_seven_hinge_real_arms_by_search_and_auto_keeps_lm(name):
    """Panda (its last joint searched) and Talos's left arm (its first): exact answers
    inside the ranges for nearly every in-range target from home; ``auto`` stays with
    ``lm`` there (the search measured no faster on most arms)."""
    chain = searched_real(name)
    family = subproblem_cache(chain).family
    assert family is not None and family.locked == (6 if name == "panda" else 0)
    solver = make_solver("subproblem")
    rng = np.random.default_rng(5)
    home = chain.q.copy()
    solved = 0
    for _ in range(100):
        target = pose_at(chain, chain.random_q(rng))
        res = solver.solve(chain, target, home)
        if res.converged:
            solved += 1
            assert np.all(res.q >= chain.lower - 1e-9) and np.all(res.q <= chain.upper + 1e-9)
            check_solutions(chain, target, [res.q])
    assert solved >= 98
    auto = make_solver("auto")
    assert auto.choice(chain, pose=True).name == "lm"
    assert "searched" in auto.reason(chain, pose=True)


@pytest.mark.slow
def test_searched_benchmark_reports_both_solvers():
    """benchmarks/searched.py prints, per arm, both solvers' successes, CPU median and
    p95 and their ratio, and the values the search tried (speed itself is the
    benchmark's business, not a test's)."""
    root = Path(__file__).resolve().parents[1]
    script = str(root / "benchmarks" / "searched.py")
    out = subprocess.run(
        [sys.executable, script, "--n", "6", "--arms", "panda,talos"],
        capture_output=True, text=True, timeout=300, cwd=root,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    rows = out.stdout.splitlines()
    assert [r.split()[0] for r in rows] == ["panda", "talos"]
    for row in rows:
        assert "subproblem 6/6 median" in row and "| lm 6/6 median" in row
        sp, lm = (float(row.split(f"{k} 6/6 median ")[1].split()[0]) for k in ("subproblem", "lm"))
        ratio = float(row.split("| ratio ")[1].split()[0])
        assert ratio == pytest.approx(sp / lm, abs=0.01)
