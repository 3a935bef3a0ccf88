"""two_link on every kind of chain it accepts, against an independent numeric oracle;
branches, ranges, messages, intermediate values, caches, and ``Chain.from_xml_string``.

The oracle knows nothing of the law of cosines: it runs the chain's forward kinematics
as a product of exponentials (hinge axes and anchors read from MuJoCo at zero, checked
against MuJoCo's own FK), finds every root by Levenberg-Marquardt from a grid of starts
(planar and two-hinge shoulders), or samples the free twist of a three-hinge shoulder
and decomposes each rotation with ``core.rotations.decompose_three_axes``; every answer
is checked with MuJoCo's FK.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray

from humanoid_ik import Chain, IKResult, SolverError, make_solver
from humanoid_ik.core.rotations import axis_angle_matrix, decompose_three_axes, rotation_between
from humanoid_ik.errors import ModelError, NameNotFoundError
from humanoid_ik.solvers.analytic.two_link import (
    AngleAxis,
    TwoLink,
    angle_axis_method,
    between,
    polar_angles,
    polar_method,
)
from humanoid_ik.solvers.analytic.two_link.geometry import place

from .chains import (
    CCD_XML,
    FIXTURES,
    MODELS,
    REPORT_XML,
    SMALL_ARM_XML,
    WORKSHEET_XML,
    chain,
    fixture,
)

TWO_PI = 2.0 * math.pi
K_OF = {"planar": 1, "two_hinge": 2, "three_hinge": 3}


# ------------------------------------------------------------------------------ the oracle
class Screws(NamedTuple):
    """The shoulder and elbow hinges at zero (world) and the hand there."""

    anchors: NDArray[np.float64]
    axes: NDArray[np.float64]
    hand: NDArray[np.float64]


def screws(ch: Chain, k: int, riding: NDArray[np.float64]) -> Screws:
    """Anchors and unit axes ``(k + 1, 3)`` of the shoulder and elbow, and the hand,
    read from MuJoCo with the chain at zero and the riding joints at ``riding``."""
    z = np.zeros(ch.n)
    z[k + 1 :] = riding
    ch.set_q(z)
    anchors, axes = ch.joint_axes()
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    return Screws(anchors[: k + 1].copy(), axes[: k + 1].copy(), ch.position.copy())


def _rotations(u: NDArray, th: NDArray) -> NDArray:
    """``Rot(u, th)`` for each angle ``(M,)``: ``(M, 3, 3)``."""
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    s, c = np.sin(th)[:, None, None], np.cos(th)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def poe(sc: Screws, Q: NDArray) -> tuple[NDArray, NDArray]:
    """Hand positions ``(M, 3)`` and position Jacobians ``(M, 3, m)`` at joint rows
    ``Q (M, m)``: ``P = T_1(q_1) ... T_m(q_m) P0`` with ``T_i`` the turn about hinge
    line ``i`` at zero, ``dP/dq_i = u_i' x (P - A_i')`` (line ``i`` moved by the joints
    before it)."""
    M, m = Q.shape
    R = np.broadcast_to(np.eye(3), (M, 3, 3)).copy()
    t = np.zeros((M, 3))
    us, anchors = [], []
    for i in range(m):
        A, u = sc.anchors[i], sc.axes[i]
        us.append(R @ u)
        anchors.append(R @ A + t)
        Ri = _rotations(u, Q[:, i])
        t = np.einsum("mij,mj->mi", R, A - Ri @ A) + t
        R = R @ Ri
    P = R @ sc.hand + t
    J = np.stack([np.cross(us[i], P - anchors[i]) for i in range(m)], axis=2)
    return P, J


def wrap(q: NDArray) -> NDArray:
    """Angles wrapped to ``[-pi, pi)``."""
    return (np.asarray(q) + math.pi) % TWO_PI - math.pi


def numeric_roots(
    sc: Screws, target: NDArray, per_joint: int, steps: int = 150, residual: float = 1e-10
) -> list[NDArray]:
    """Every joint vector (wrapped) whose hand lands on ``target`` within ``residual``
    [m]: Levenberg-Marquardt from a grid of ``per_joint ** m`` starts, ``steps`` steps,
    roots closer than 1e-4 rad merged."""
    m = sc.axes.shape[0]
    g = np.linspace(-math.pi, math.pi, per_joint, endpoint=False) + 0.1
    Q = np.stack(np.meshgrid(*([g] * m), indexing="ij"), axis=-1).reshape(-1, m)
    for _ in range(steps):
        P, J = poe(sc, Q)
        JT = J.transpose(0, 2, 1)
        A = JT @ J + 1e-12 * np.eye(m)
        Q = Q + np.linalg.solve(A, JT @ (target - P)[..., None])[..., 0]
    P, _ = poe(sc, Q)
    good = wrap(Q[np.linalg.norm(P - target, axis=1) < residual])
    roots: list[NDArray] = []
    for q in good:
        if all(np.max(np.abs(wrap(q - r))) > 1e-4 for r in roots):
            roots.append(q)
    return roots


def fits(q: NDArray, lo: NDArray, hi: NDArray, tol: float = 1e-7) -> bool:
    """Some turn-shift of every angle lies inside its range."""
    for x, a, b in zip(q, lo, hi, strict=True):
        y = a + (x - a) % TWO_PI if math.isfinite(a) else x
        if not (y <= b + tol or abs(y - TWO_PI - a) <= tol):
            return False
    return True


def two_link_roots(ch: Chain, target: NDArray, q0: NDArray, k: int):
    """two_link's solutions as (wrapped shoulder + elbow, inside) pairs."""
    sols = TwoLink().solutions(ch, target, q0)
    return [(wrap(s.q[: k + 1]), s.inside) for s in sols]


def same_sets(a: list[NDArray], b: list[NDArray], tol: float) -> bool:
    """Each root of ``a`` has one in ``b`` within ``tol`` rad and back."""
    near = lambda x, ys: any(np.max(np.abs(wrap(x - y))) < tol for y in ys)  # noqa: E731
    return all(near(x, b) for x in a) and all(near(y, a) for y in b)


# ------------------------------------------------------------------------------ targets
def oracle_targets(
    ch: Chain, k: int, seed: int, n: int = 24, home: NDArray | None = None
) -> list[tuple[str, NDArray]]:
    """Dense targets, each with a kind: FK of ``n`` random in-range poses; the workspace
    boundary (straight elbow) and the inner hole (folded elbow), 3 each; every joint at
    a range end, 4; random points around the shoulder, 8 (mostly out of reach; planar:
    in the plane)."""
    rng = np.random.default_rng(seed)
    tl = TwoLink()
    home = ch.q_home if home is None else home
    shell = tl.shell(ch, home)
    out: list[tuple[str, NDArray]] = []

    def fk(q: NDArray) -> NDArray:
        qq = home.copy()
        qq[: k + 1] = q[: k + 1]
        return ch.fk(qq)[0]

    for _ in range(n):
        out.append(("inside", fk(ch.random_q(rng))))
    for qe, kind in ((shell.alpha + math.pi, "straight"), (shell.alpha, "folded")):
        for _ in range(3):
            q = ch.random_q(rng)
            q[k] = qe
            out.append((kind, fk(q)))
    for _ in range(4):
        ends = rng.integers(0, 2, size=k + 1)
        q = np.where(ends == 1, ch.upper[: k + 1], ch.lower[: k + 1])
        out.append(("range_end", fk(np.where(np.isfinite(q), q, 0.0))))
    sc = screws(ch, k, home[k + 1 :])
    S = sc.anchors[0]
    for _ in range(8):
        p = S + rng.uniform(-1.0, 1.0, 3) * 1.5 * shell.r_max
        if k == 1:
            a = sc.axes[0]
            p = p - float((p - fk(np.zeros(k + 1))) @ a) * a
        out.append(("random", p))
    ch.reset()
    return out


# ------------------------------------------------------------------------------ chains
def _skew_2() -> Chain:
    """Two hinges that neither meet nor are parallel, then an elbow."""
    return chain(
        """<mujoco><worldbody><body>
        <joint name="a" axis="0 0 1"/><geom size=".05"/>
        <body pos="0 0.3 0"><joint name="b" axis="1 0 0"/><geom size=".05"/>
        <site name="tip" pos="1 0 0"/></body></body></worldbody></mujoco>""",
        "tip",
    )


PLANAR_AND_TWO = {
    "planar_arm": lambda: fixture("planar_arm"),
    "planar_arm_wrist_at_1": lambda: fixture("planar_arm"),
    "report_arm": lambda: chain(REPORT_XML, "hand_site"),
    "ccd_arm": lambda: chain(CCD_XML, "p3"),
    "two_hinge_arm": lambda: fixture("two_hinge_arm"),
    "two_hinge_no_wrist": lambda: fixture("two_hinge_arm", riding=False),
}
RIDING_AT = {"planar_arm_wrist_at_1": 1.0, "two_hinge_arm": -1.2}
"""Chains whose riding wrist starts away from its home value in the oracle test."""
THREE = {
    "three_hinge_arm": lambda: fixture("three_hinge_arm"),
    "humanoid_right": lambda: Chain(),
    "small_arm": lambda: chain(SMALL_ARM_XML, "tip"),
    "worksheet": lambda: chain(WORKSHEET_XML, "p3"),
}


def test_poe_matches_mujoco():
    """The oracle's product-of-exponentials FK equals MuJoCo's on every fixture (1e-12 m)."""
    rng = np.random.default_rng(0)
    for make in (*PLANAR_AND_TWO.values(), *THREE.values()):
        ch = make()
        k = K_OF[TwoLink.kind(ch)]
        sc = screws(ch, k, ch.q_home[k + 1 :])
        Q = np.stack([ch.random_q(rng)[: k + 1] for _ in range(20)])
        P, J = poe(sc, Q)
        for q, p, j in zip(Q, P, J, strict=True):
            full = ch.q_home.copy()
            full[: k + 1] = q
            np.testing.assert_allclose(ch.fk(full)[0], p, atol=1e-12)
            np.testing.assert_allclose(ch.jacobian(full)[:3, : k + 1], j, atol=1e-12)


def test_kinds_of_chain():
    """Each fixture is read as the shoulder it has."""
    kinds = {name: TwoLink.kind(make()) for name, make in {**PLANAR_AND_TWO, **THREE}.items()}
    assert kinds == {
        "planar_arm": "planar",
        "planar_arm_wrist_at_1": "planar",
        "report_arm": "planar",
        "ccd_arm": "planar",
        "two_hinge_arm": "two_hinge",
        "two_hinge_no_wrist": "two_hinge",
        "three_hinge_arm": "three_hinge",
        "humanoid_right": "three_hinge",
        "small_arm": "three_hinge",
        "worksheet": "three_hinge",
    }


# ------------------------------------------------------------------------------ planar, 2-hinge
@pytest.mark.slow
@pytest.mark.parametrize("name", list(PLANAR_AND_TWO))
def test_oracle_planar_and_two_hinge(name):
    """Planar and two-hinge chains: every numeric root found, none extra, ranges flagged right."""
    ch = PLANAR_AND_TWO[name]()
    q0 = ch.q_home.copy()
    if name in RIDING_AT:  # start from another wrist: the hand's constants change
        q0[-1] = RIDING_AT[name]
    k = K_OF[TwoLink.kind(ch)]
    sc = screws(ch, k, q0[k + 1 :])
    solver = make_solver("two_link")
    counts = {"roots": 0, "inside": 0, "unreachable": 0}
    for kind, target in oracle_targets(ch, k, seed=len(name), home=q0):
        res = solver.solve(ch, target, q0)
        phi = res.details["phi"]
        singular = kind in ("straight", "folded") or min(phi, math.pi - phi) < 1e-6
        # a double root (straight or folded elbow) converges slowly: more steps, and
        # the roots spread (more so for a short folded limb)
        roots = numeric_roots(
            sc, target, 12 if k == 1 else 7, *((400, 1e-8) if singular else (150, 1e-10))
        )
        found = two_link_roots(ch, target, q0, k)
        tol = 1e-2 if singular else 1e-7
        assert same_sets([r for r, _ in found], roots, tol), (name, kind, found, roots)
        for q, ins in found:
            assert ins == fits(q, ch.lower[: k + 1], ch.upper[: k + 1]), (name, kind, q)
            full = q0.copy()
            full[: k + 1] = q
            assert np.linalg.norm(ch.fk(full)[0] - target) < 1e-9
        inside = [q for q, ins in found if ins]
        counts["roots"] += len(roots)
        counts["inside"] += bool(inside)
        assert ch.within_limits(res.q) and np.allclose(res.q[k + 1 :], q0[k + 1 :])
        if inside:
            assert res.converged and res.position_error < 1e-9, (name, kind, res)
            dist = [np.linalg.norm(wrap(q - wrap(res.q[: k + 1]))) for q in inside]
            assert min(dist) < 1e-9
        else:
            counts["unreachable"] += 1
            assert res.status == "unreachable" and res.message, (name, kind, res)
    assert counts["inside"] >= 24 and counts["unreachable"] >= 3, counts


def test_two_hinge_band_edge_and_beyond():
    """On the band's edge one shoulder solution; beyond it unreachable, turned to the edge."""
    m = mujoco.MjModel.from_xml_path(str(MODELS / "two_hinge_arm.xml"))
    m.jnt_limited[:] = 0  # the band alone decides
    ch = Chain(m, "hand_site", FIXTURES["two_hinge_arm"][1][:3])
    q0 = ch.q_home.copy()
    sc = screws(ch, 2, np.zeros(0))
    a1, a2 = sc.axes[0], sc.axes[1]
    S = sc.anchors[0]
    qe = -1.0
    ch.set_q([0.0, 0.0, qe])
    v = ch.position - S
    # q2 puts v in the plane of a1 and a2, on a1's side: the band's lower edge
    e = a1 - (a1 @ a2) * a2
    q2 = math.atan2(float(a2 @ np.cross(v, e)), float(v @ e - (v @ a2) * (e @ a2)))
    edge = ch.fk([0.7, q2, qe])[0]
    on_branch = [s for s in TwoLink().solutions(ch, edge, q0) if abs(s.q[2] - qe) < 1e-9]
    assert [s.shoulder for s in on_branch] == ["both"]
    assert np.linalg.norm(ch.fk(on_branch[0].q)[0] - edge) < 1e-9
    res = make_solver("two_link", branch="negative").solve(ch, edge, q0)
    assert res.converged and res.position_error < 1e-9 and res.q[2] == pytest.approx(qe)
    low = res.details["band"][0]
    assert res.details["theta_t"] == pytest.approx(low, abs=1e-9)
    # along a1 itself: theta_t = 0 < low
    target = S + 0.45 * a1
    res = make_solver("two_link").solve(ch, target, q0)
    assert res.status == "unreachable" and "outside the band" in res.message
    assert "turned to the band's edge" in res.message
    low, high = res.details["band"]
    assert res.details["theta_t"] == pytest.approx(0.0, abs=1e-12) and low > 0.3
    # the hand ends on the band's edge: low from a1, at the target's distance
    hand = ch.fk(res.q)[0] - S
    assert math.acos(float(hand @ a1) / np.linalg.norm(hand)) == pytest.approx(low, abs=1e-9)
    assert res.position_error == pytest.approx(2 * 0.45 * math.sin(low / 2), abs=1e-9)
    assert TwoLink().solutions(ch, target, q0) == []


# ------------------------------------------------------------------------------ three hinges
def _twist_of(R: NDArray, R0: NDArray, n: NDArray) -> float:
    """The angle of ``R R0'`` (a turn about ``n``)."""
    M = R @ R0.T
    h = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    h /= np.linalg.norm(h)
    return math.atan2(float(n @ np.cross(h, M @ h)), float(h @ M @ h))


def _elbow_roots(sc: Screws, target: NDArray) -> list[float]:
    """Elbow angles putting the hand at the target's distance from the shoulder:
    sign changes of ``|P(qe) - S|^2 - r^2`` on 4096 samples, bisected, and touching
    extrema (straight or folded limb) refined by golden section."""
    S, A, u, P0 = sc.anchors[0], sc.anchors[-1], sc.axes[-1], sc.hand
    r2 = float((target - S) @ (target - S))

    def f(x: NDArray) -> NDArray:
        P = A + (_rotations(u, np.atleast_1d(x)) @ (P0 - A))
        return np.sum((P - S) ** 2, axis=1) - r2

    xs = np.linspace(-math.pi, math.pi, 4097)
    fx = f(xs)
    roots = []
    for i in np.flatnonzero(np.sign(fx[:-1]) * np.sign(fx[1:]) < 0):
        a, b = xs[i], xs[i + 1]
        for _ in range(60):
            c = 0.5 * (a + b)
            a, b = (a, c) if np.sign(f(c)[0]) != np.sign(f(a)[0]) else (c, b)
        roots.append(0.5 * (a + b))
    for i in range(1, 4096):
        if abs(fx[i]) < 1e-6 * r2 and abs(fx[i]) <= abs(fx[i - 1]) and abs(fx[i]) <= abs(fx[i + 1]):
            a, b = xs[i - 1], xs[i + 1]
            for _ in range(80):
                c, d = b - 0.618 * (b - a), a + 0.618 * (b - a)
                a, b = (a, d) if abs(f(c)[0]) < abs(f(d)[0]) else (c, b)
            x = 0.5 * (a + b)
            if abs(f(x)[0]) < 1e-10 * max(r2, 1.0) and all(abs(wrap(x - y)) > 1e-3 for y in roots):
                roots.append(x)
    return roots


def _feasible_twists(ch: Chain, sc: Screws, target: NDArray, qe: float, N: int):
    """Twists ``(N,)`` about the shoulder-target line and which keep every shoulder hinge
    in range (``core.rotations.decompose_three_axes``), with ``R0`` the smallest turn of
    the limb onto the target line."""
    S, A, u = sc.anchors[0], sc.anchors[3], sc.axes[3]
    P = A + axis_angle_matrix(u, qe) @ (sc.hand - A)
    v, t = P - S, target - S
    phi, axis = rotation_between(v, t / np.linalg.norm(t) * np.linalg.norm(v) - v)
    R0 = axis_angle_matrix(axis, phi)
    n = t / np.linalg.norm(t)
    deltas = np.linspace(-math.pi, math.pi, N, endpoint=False)
    lo, hi = ch.lower[:3], ch.upper[:3]
    if not np.any(np.isfinite(lo) | np.isfinite(hi)):
        return deltas, np.ones(N, dtype=bool), R0, n
    ok = np.zeros(N, dtype=bool)
    for i, d in enumerate(deltas):
        R = axis_angle_matrix(n, d) @ R0
        ok[i] = any(fits(q, lo, hi) for q in decompose_three_axes(R, *sc.axes[:3]))
    return deltas, ok, R0, n


@pytest.mark.slow
@pytest.mark.parametrize("name", list(THREE))
def test_oracle_three_hinge(name):
    """Three-hinge chains: reached iff a sampled twist fits, at the feasible twist nearest."""
    ch = THREE[name]()
    q0 = ch.q_home.copy()
    sc = screws(ch, 3, q0[4:])
    S = sc.anchors[0]
    ch.set_q(q0)
    elbow_start = ch.joint_axes()[0][3]
    solver = make_solver("two_link")
    N = 360
    step = TWO_PI / N
    checked = 0
    for kind, target in oracle_targets(ch, 3, seed=3 + len(name), n=14):
        res = solver.solve(ch, target, q0)
        assert ch.within_limits(res.q) and np.allclose(res.q[4:], q0[4:])
        any_feasible = False
        for qe in _elbow_roots(sc, target):
            if not fits(np.array([qe]), ch.lower[3:4], ch.upper[3:4]):
                continue
            deltas, ok, R0, n = _feasible_twists(ch, sc, target, qe, N)
            any_feasible |= bool(ok.any())
            if not res.converged or abs(wrap(res.q[3] - qe)) > 1e-6 or not ok.any():
                continue
            # the twist of the answer, and the preferred one, in the oracle's frame
            R = np.eye(3)
            for a, x in zip(sc.axes[:3], res.q[:3], strict=True):
                R = R @ axis_angle_matrix(a, x)
            d_sol = _twist_of(R, R0, n)
            elbows = S + np.einsum(
                "ijk,k->ij",
                np.stack([axis_angle_matrix(n, d) @ R0 for d in deltas]),
                sc.anchors[3] - S,
            )
            spread = np.linalg.norm(elbows - elbow_start, axis=1)
            if np.ptp(spread) < 1e-6:  # elbow on the shoulder-target line: no preference
                continue
            d_pref = deltas[int(np.argmin(spread))]
            gap_sol = abs(wrap(d_sol - d_pref))
            gap_grid = np.min(np.abs(wrap(deltas[ok] - d_pref)))
            assert gap_sol <= gap_grid + 1.5 * step, (name, kind, gap_sol, gap_grid)
            got = res.details["twist"] - res.details["twist_preferred"]
            assert abs(wrap(got - (d_sol - d_pref))) < 1.5 * step
            checked += 1
        if any_feasible:
            assert res.converged and res.position_error < 1e-9, (name, kind, res)
        elif res.converged:  # a feasible arc narrower than the sampling: verify it
            assert ch.within_limits(res.q) and res.position_error < 1e-9
        else:
            assert res.status == "unreachable" and res.message
    assert checked >= 12


def test_three_hinge_agrees_with_closed_form_on_the_humanoid():
    """On the humanoid two_link and closed_form give the same joints for position targets."""
    ch = Chain()
    rng = np.random.default_rng(5)
    tl, cf = make_solver("two_link"), make_solver("closed_form")
    same = 0
    for _ in range(300):
        q = ch.random_q(rng)
        q[4:] = ch.q_home[4:]
        p, _ = ch.fk(q)
        ch.reset()
        a = tl.solve(ch, p)
        ch.reset()
        b = cf.solve(ch, p)
        assert a.converged == b.converged
        if a.converged:
            same += bool(np.allclose(a.q, b.q, atol=1e-9))
    assert same >= 295


def test_three_hinge_twist_options():
    """method polar/angle_axis keep the worksheet's twist; nearest keeps the elbow in place."""
    ch = chain(WORKSHEET_XML, "p3")
    pd = np.array([-3.0, math.sqrt(7.0), 0.0])
    for method in ("polar", "angle_axis"):
        res = make_solver("two_link", method=method, branch="negative").solve(ch, pd, np.zeros(4))
        assert res.details["twist"] == pytest.approx(res.details["twist_preferred"], abs=1e-12)
    q0 = np.array([0.3, -0.4, 0.5, -1.0])
    res = make_solver("two_link", branch="negative").solve(ch, pd, q0)
    ch.set_q(q0)
    before = ch.data.body("lower").xpos.copy()
    ch.set_q(res.q)
    after = ch.data.body("lower").xpos.copy()
    # any other twist puts the elbow further from where it was
    n = pd / np.linalg.norm(pd)
    for d in np.linspace(-3.0, 3.0, 25):
        other = axis_angle_matrix(n, d) @ after
        assert np.linalg.norm(after - before) <= np.linalg.norm(other - before) + 1e-12


def test_three_hinge_out_of_range_and_branch_options():
    """Out of range: unreachable, the missing joint named; a chosen branch that misses says so."""
    ch = chain(
        """<mujoco><compiler angle="radian" autolimits="true"/><worldbody><body>
        <joint name="s1" axis="0 1 0" range="-0.3 0.3"/>
        <joint name="s2" axis="0 0 1" range="-0.3 0.3"/>
        <joint name="s3" axis="1 0 0" range="-0.3 0.3"/>
        <geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/>
        <body pos="1 0 0"><joint name="el" axis="0 0 1" range="0 2"/>
        <geom type="capsule" fromto="0 0 0 1 0 0" size=".05"/><site name="tip" pos="1 0 0"/>
        </body></body></worldbody></mujoco>""",
        "tip",
    )
    res = make_solver("two_link").solve(ch, [-1.5, 0.0, 0.0])
    assert res.status == "unreachable" and "inside the joint ranges" in res.message
    assert "nearest branch: joint '" in res.message
    assert ch.within_limits(res.q)
    p, _ = ch.fk([0.1, 0.2, 0.0, 1.0])
    ok = make_solver("two_link").solve(ch, p, np.zeros(4))
    assert ok.converged and ok.details["branch"] == "positive"
    neg = make_solver("two_link", branch="negative").solve(ch, p, np.zeros(4))
    assert neg.status == "unreachable" and "on the chosen branch 'negative'" in neg.message


# ------------------------------------------------------------------------------ messages
def test_unreachable_messages_per_kind():
    """Off the plane, beyond the shell, in the hole: unreachable with the distance."""
    ch = fixture("planar_arm", riding=False)
    tl = make_solver("two_link")
    shell = tl.shell(ch)
    sc = screws(ch, 1, np.zeros(0))
    a = sc.axes[0]
    p_in, _ = ch.fk([0.4, -0.9])
    res = tl.solve(ch, p_in + 0.25 * a)
    assert res.status == "unreachable" and "0.25 m off the planar arm's plane" in res.message
    assert res.position_error == pytest.approx(0.25, abs=1e-9)
    straight, _ = ch.fk([0.4, wrap(np.array(shell.alpha + math.pi))])
    res = tl.solve(ch, straight)
    assert res.converged and res.position_error < 1e-9
    assert res.details["branch"] == "both" and res.details["r"] == pytest.approx(shell.r_max)
    axis_point = sc.anchors[0] + float((straight - sc.anchors[0]) @ a) * a
    out = (straight - axis_point) / np.linalg.norm(straight - axis_point)
    res = tl.solve(ch, straight + 0.5 * out)
    assert res.status == "unreachable" and "0.5 m beyond the reachable shell" in res.message
    assert res.position_error == pytest.approx(0.5, abs=1e-9)  # stretched toward it
    ch3 = fixture("three_hinge_arm", riding=False)
    s3 = tl.shell(ch3)
    S3 = screws(ch3, 3, np.zeros(0)).anchors[0]
    res = tl.solve(ch3, S3 + 0.5 * s3.r_min * np.array([0.0, 0.6, 0.8]))
    assert res.status == "unreachable" and "inside the inner hole of" in res.message
    assert f"{0.5 * s3.r_min:.6g} m inside" in res.message


def test_refused_chains_and_errors():
    """Chains that are not two-link arms are refused with the reason; solve and kind raise it."""
    tl = make_solver("two_link")
    one = chain(
        """<mujoco><worldbody><body><joint name="j" axis="0 0 1"/><geom size=".1"/>
        <site name="tip" pos="1 0 0"/></body></worldbody></mujoco>""",
        "tip",
    )
    assert "1, 2 or 3 shoulder hinges" in tl.applicable(one)
    assert "meet at one point" in tl.applicable(_skew_2())
    coincident = chain(
        """<mujoco><worldbody><body><joint name="a" axis="0 0 1"/><geom size=".05"/>
        <body><joint name="b" axis="0 0 1"/><geom size=".05"/>
        <site name="tip" pos="1 0 0"/></body></body></worldbody></mujoco>""",
        "tip",
    )
    assert "lies on the shoulder's axis" in tl.applicable(coincident)
    parallel = chain(
        """<mujoco><worldbody><body>
        <joint name="s1" axis="0 0 1"/><joint name="s2" axis="0 0 1"/>
        <joint name="s3" axis="1 0 0"/><geom size=".05"/>
        <body pos="1 0 0"><joint name="el" axis="0 1 0"/><geom size=".05"/>
        <site name="tip" pos="1 0 0"/></body></body></worldbody></mujoco>""",
        "tip",
    )
    assert "neighbours are not parallel" in tl.applicable(parallel)
    with pytest.raises(SolverError, match="meet at one point"):
        tl.solve(_skew_2(), [1.0, 0.0, 0.0])
    with pytest.raises(SolverError, match="meet at one point"):
        TwoLink.kind(_skew_2())
    with pytest.raises(SolverError, match="option 'shoulder' of solver 'two_link' is 'up'"):
        make_solver("two_link", shoulder="up")


OFFSET_WRIST_XML = """<mujoco><worldbody><body name="upper">
  <joint name="s1" axis="0 0 1"/><joint name="s2" axis="0 1 0"/><joint name="s3" axis="1 0 0"/>
  <geom size=".05"/>
  <body name="fore" pos="0 0 -0.3"><joint name="elbow" axis="0 1 0"/><geom size=".04"/>
    <body name="wrist" pos="0 0 -0.25"><joint name="w1" axis="0 0 1"/><geom size=".03"/>
      <body name="hand" pos="{x} 0 -0.05"><joint name="w2" axis="0 1 0"/><geom size=".02"/>
        <site name="tip" pos="0.1 0 0"/></body></body></body></body></worldbody></mujoco>"""
"""A three-hinge shoulder and an elbow, then a two-hinge wrist whose axes meet (``x`` 0)
or pass 0.05 m apart (``x`` 0.05)."""


@pytest.fixture(scope="module")
def g1_model():
    """G1's original URDF (example-robot-data)."""
    from humanoid_ik.core.models import load_model
    from tests.robots import robot_file

    return load_model(robot_file("g1"))


def test_joints_after_the_elbow_must_be_a_wrist(g1_model):
    """G1's default chain from a hand runs from the waist: the waist's yaw and roll meet,
    so they look like a shoulder with the waist's pitch for an elbow and the whole arm
    (7 hinges) riding along. two_link held those at home and reached 0 % of the chain's
    targets (worst 798 mm): it is refused, naming the misread elbow, and auto takes no
    second opinion from it. A wrist whose two axes miss each other by 0.05 m is refused
    too; the same wrist with its axes meeting, and the humanoid's arm, are two-link limbs
    and give the answers they always did."""
    tl = TwoLink()
    arm = Chain(g1_model, body="left_rubber_hand")
    assert arm.n == 10 and arm.joint_names[2] == "waist_pitch_joint"
    why = tl.applicable(arm)
    assert why is not None and why.startswith(
        "two_link needs a wrist of at most 3 hinges after the elbow; the 7 joint(s) after "
        "the elbow 'waist_pitch_joint'"
    )
    assert "--joints" in why and "\n" not in why
    with pytest.raises(SolverError, match="wrist of at most 3 hinges"):
        tl.solve(arm, arm.fk(arm.q_home)[0])
    auto = make_solver("auto")
    assert auto.second_opinion(arm) is None

    offset = Chain.from_xml_string(OFFSET_WRIST_XML.format(x=0.05), "tip")
    why = tl.applicable(offset)
    assert why is not None and "those of 'w1', 'w2' (after the elbow 'elbow') do not" in why
    meeting = Chain.from_xml_string(OFFSET_WRIST_XML.format(x=0.0), "tip")
    assert tl.applicable(meeting) is None and TwoLink.kind(meeting) == "three_hinge"
    rng = np.random.default_rng(3)
    for _ in range(5):  # targets with the wrist at home: reached exactly
        q = meeting.random_q(rng)
        q[4:] = meeting.q_home[4:]
        res = tl.solve(meeting, meeting.fk(q)[0], meeting.q_home)
        assert res.converged and res.position_error < 1e-9

    humanoid = Chain()
    assert tl.applicable(humanoid) is None
    res = tl.solve(humanoid, [0.35, -0.30, 1.15])
    np.testing.assert_allclose(res.q[:4], [0.112389, 0.098302, -0.260851, 1.580848], atol=1e-6)


# ------------------------------------------------------------------------------ details
def test_planar_details_follow_the_report():
    """Planar details: theta1 = theta_t1 -+ theta_t2 and theta2 = -+(phi - pi) per branch."""
    ch = fixture("planar_arm", riding=False)
    p, _ = ch.fk([0.5, -1.1])
    neg = make_solver("two_link", branch="negative").solve(ch, p, np.zeros(2))
    pos = make_solver("two_link", branch="positive").solve(ch, p, np.zeros(2))
    d = neg.details
    assert d["kind"] == "planar" and d["branch"] == "negative" and d["shoulder"] == ""
    assert d["theta1"] == pytest.approx(d["theta_t1"] + d["theta_t2"], abs=1e-12)
    assert pos.details["theta1"] == pytest.approx(d["theta_t1"] - d["theta_t2"], abs=1e-12)
    assert d["theta2"] == pytest.approx(d["phi"] - math.pi, abs=1e-12)
    assert pos.details["theta2"] == pytest.approx(math.pi - d["phi"], abs=1e-12)
    assert d["off_plane"] < 1e-12 and neg.converged and pos.converged
    assert {tuple(np.round(neg.q, 9)), tuple(np.round(pos.q, 9))} == {
        tuple(np.round(s.q, 9)) for s in TwoLink().solutions(ch, p, np.zeros(2))
    }


def test_details_are_read_only_and_in_json():
    """details is a read-only mapping, computed when read, and plain data in to_dict."""
    ch = Chain()
    res = make_solver("two_link").solve(ch, [0.3, -0.3, 1.1])
    with pytest.raises(TypeError):
        res.details["phi"] = 0.0  # type: ignore[index]
    assert set(res.details) >= {"phi", "theta2", "twist", "polar", "angle_axis"}
    assert len(res.details) == len(list(res.details))
    with pytest.raises(KeyError):
        res.details["nope"]
    doc = res.to_dict()
    assert doc["details"]["polar"]["theta1z"] == pytest.approx(res.details["polar"].theta1z)
    assert doc["details"]["angle_axis"]["axis"] == pytest.approx(res.details["angle_axis"].axis)


def test_worksheet_helpers_match_core():
    """The float methods equal core.rotations.rotation_between and the array helper."""
    rng = np.random.default_rng(2)
    for _ in range(50):
        v, t = rng.normal(size=3), rng.normal(size=3)
        phi, u = rotation_between(v, t - v)
        aa = angle_axis_method(tuple(v), tuple(t))
        assert aa.phi == pytest.approx(phi, abs=1e-12)
        np.testing.assert_allclose(aa.axis, u, atol=1e-12)
        b = between(tuple(v), tuple(t - v))
        assert b[0] == pytest.approx(phi, abs=1e-12)
        pm = polar_method(tuple(v), tuple(t))
        theta, beta, gamma = polar_angles(v, t)
        assert (pm.theta1z, pm.beta, pm.gamma) == (theta, beta, gamma)
        x = np.array([np.linalg.norm(v), 0.0, 0.0])
        np.testing.assert_allclose(axis_angle_matrix(pm.align_axis, theta) @ v, x, atol=1e-12)
    # parallel vectors: a turn of pi about some axis normal to v
    phi, u = between((1.0, 0.0, 0.0), (-2.0, 0.0, 0.0))
    assert phi == pytest.approx(math.pi) and abs(u[0]) < 1e-12
    assert polar_method((-2.0, 0.0, 0.0), (1.0, 0.0, 0.0)).theta1z == pytest.approx(math.pi)


def test_place_shifts_by_turns():
    """place: into a narrow range next to its middle, next to pref for a wide one."""
    assert place(0.5, -1.0, 1.0, 0.0) == 0.5
    assert place(0.5 + TWO_PI, -1.0, 1.0, 0.0) == pytest.approx(0.5)
    assert place(3.0, -1.0, 1.0, 0.0) == pytest.approx(3.0)  # does not fit: stays nearest
    assert place(0.1, -math.inf, math.inf, 6.0) == pytest.approx(0.1 + TWO_PI)
    assert place(-3.0, -4.0, 4.0, 3.5) == pytest.approx(-3.0 + TWO_PI)
    assert place(3.0, -2.0, 6.0, -1.9) == pytest.approx(3.0)


# ------------------------------------------------------------------------------ caches
def test_riding_joints_and_base_moves():
    """Joints after the elbow keep their start values; a moved free base is read again."""
    ch = fixture("three_hinge_arm")
    tl = make_solver("two_link")
    tl.prepare(ch)
    for wrist in (-0.8, 0.0, 0.9):
        q = np.array([0.3, -0.2, 0.1, 1.0, wrist])
        p, _ = ch.fk(q)
        res = tl.solve(ch, p, np.array([0.0, 0.0, 0.0, 0.5, wrist]))
        assert res.converged and res.position_error < 1e-9 and res.q[4] == wrist
    arm = chain(SMALL_ARM_XML, "tip")
    data = mujoco.MjData(arm.model)
    mujoco.mj_resetData(arm.model, data)
    q = np.array([0.3, 0.2, -0.4, -1.0, 0.1, 0.2, 0.3])
    for shift in (0.0, 0.7):
        data.qpos[1] = shift  # the free base's y
        arm.load(data)
        p, _ = arm.fk(q)
        arm.load(data)
        res = tl.solve(arm, p)
        assert res.converged and res.position_error < 1e-9


# ------------------------------------------------------------------------------ from_xml_string
def test_chain_from_xml_string():
    """Chain.from_xml_string builds a chain from MJCF text and raises as Chain does."""
    ch = Chain.from_xml_string(CCD_XML, "p3")
    np.testing.assert_allclose(ch.fk([0.0, 0.0])[0], [3.0, 0.0, 0.0], atol=1e-12)
    assert Chain.from_xml_string(CCD_XML, "p3", ["j2"]).joint_names == ["j2"]
    assert Chain.from_xml_string(CCD_XML, body="link2").n == 2
    with pytest.raises(ModelError, match="MJCF string does not compile: .*unrecognized"):
        Chain.from_xml_string("<mujoco><bad/></mujoco>")
    with pytest.raises(ModelError, match="MJCF must be a string of XML, got bytes"):
        Chain.from_xml_string(b"<mujoco/>")  # type: ignore[arg-type]
    with pytest.raises(NameNotFoundError, match="site 'nope' not in model"):
        Chain.from_xml_string(CCD_XML, "nope")


def test_two_hinge_shoulder_option():
    """shoulder=plus/minus pick each shoulder solution; auto the one nearest the start."""
    ch = fixture("two_hinge_arm", riding=False)
    q0 = ch.q_home.copy()
    rng = np.random.default_rng(4)
    while True:  # a target both shoulder solutions reach inside the ranges
        p, _ = ch.fk(ch.random_q(rng))
        sols = [s for s in TwoLink().solutions(ch, p, q0) if s.inside]
        if {s.shoulder for s in sols} == {"plus", "minus"}:
            break
    got = {}
    for tag in ("plus", "minus"):
        res = make_solver("two_link", shoulder=tag).solve(ch, p, q0)
        assert res.converged and res.details["shoulder"] == tag
        got[tag] = res.q
    assert not np.allclose(got["plus"], got["minus"])
    for q in got.values():
        assert any(np.allclose(q, s.q, atol=1e-12) for s in sols)
    auto = make_solver("two_link").solve(ch, p, q0)
    np.testing.assert_allclose(auto.q, sols[0].q, atol=1e-12)
    assert sols[0].distance <= sols[-1].distance


@pytest.mark.parametrize("offset", [0.0, 1e-5, -1e-9])
def test_three_hinge_gimbal_lock(offset):
    """At the humanoid shoulder's gimbal lock the start posture comes back exactly."""
    ch = Chain()
    for q4 in ([0.3, math.pi / 2 + offset, 0.2, 1.0], [1.2, math.pi / 2 + offset, -0.7, 0.4]):
        q = ch.q_home.copy()
        q[:4] = q4
        p, _ = ch.fk(q)
        res = make_solver("two_link").solve(ch, p, q)
        assert res.converged and res.position_error < 1e-12
        np.testing.assert_allclose(res.q, q, atol=1e-6)  # q1, q3 ill-conditioned there


def test_three_hinge_shoulder_option():
    """On the worksheet's arm shoulder=plus/minus give the two decompositions of one rotation."""
    ch = chain(WORKSHEET_XML, "p3")
    pd = np.array([-3.0, math.sqrt(7.0), 0.0])
    got = {}
    for tag in ("plus", "minus"):
        res = make_solver("two_link", method="polar", branch="negative", shoulder=tag).solve(
            ch, pd, np.zeros(4)
        )
        assert res.converged and res.position_error < 1e-12 and res.details["shoulder"] == tag
        got[tag] = res.q
    # the same shoulder rotation: (y, z, x) = (b, c, 0) and (b + pi, pi - c, pi)
    a, b = got["plus"], got["minus"]
    assert abs(wrap(a[0] - b[0])) == pytest.approx(math.pi, abs=1e-9)
    assert wrap(np.array(a[1] + b[1])) == pytest.approx(-math.pi, abs=1e-9)
    assert abs(wrap(a[2] - b[2])) == pytest.approx(math.pi, abs=1e-9)


def test_unlimited_joints_stay_next_to_the_start():
    """Unlimited joints come back by whole turns next to the start (tracking stays smooth)."""
    ch = chain(CCD_XML, "p3")
    q0 = np.array([TWO_PI + 0.2, -TWO_PI - 0.3])
    p, _ = ch.fk([0.25, -0.35])
    res = make_solver("two_link").solve(ch, p, q0)
    assert res.converged
    np.testing.assert_allclose(res.q, [TWO_PI + 0.25, -TWO_PI - 0.35], atol=1e-12)


def test_ikresult_details_field():
    """IKResult.details: empty by default, a given dict copied read-only, JSON-ready."""
    plain = IKResult(np.zeros(2), True, 1, 0.0, None, "converged")
    assert dict(plain.details) == {} and "details" not in plain.to_dict()
    given = {"phi": np.float64(1.5), "axis": AngleAxis(0.5, (0.0, 0.0, 1.0))}
    res = IKResult(np.zeros(2), True, 1, 0.0, None, "converged", details=given)
    given["phi"] = 9.0
    assert res.details["phi"] == 1.5
    with pytest.raises(TypeError):
        res.details["phi"] = 2.0  # type: ignore[index]
    assert res.to_dict()["details"] == {"phi": 1.5, "axis": {"phi": 0.5, "axis": [0.0, 0.0, 1.0]}}
    assert not next(f for f in dataclasses.fields(IKResult) if f.name == "details").compare


def test_ikresult_equality_and_pickling():
    """Two results are equal when every field but ``details`` is (``q`` element by
    element; it raised on the array before); they pickle (``details`` kept) and are not
    hashable."""
    import pickle

    a = IKResult(np.array([0.1, 0.2]), True, 3, 1e-6, None, "converged", "lm", details={"x": 1})
    same = IKResult(np.array([0.1, 0.2]), True, 3, 1e-6, None, "converged", "lm")
    other_q = IKResult(np.array([0.1, 0.3]), True, 3, 1e-6, None, "converged", "lm")
    other_status = IKResult(np.array([0.1, 0.2]), False, 3, 1e-6, None, "max_iterations", "lm")
    assert a == same and a != other_q and a != other_status and a != "converged"
    back = pickle.loads(pickle.dumps(a))
    assert back == a and dict(back.details) == {"x": 1} and back.status is a.status
    with pytest.raises(TypeError):
        hash(a)
