"""Every worked example of the reference notes, reproduced to 1e-4 with FK from MuJoCo
(the worksheet and the report's arm followed number by number from the public API, to
1e-6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from humanoid_ik import Chain, look_at, make_solver
from humanoid_ik.core.rotations import rotation_between
from humanoid_ik.solvers.analytic.two_link import law_of_cosines, polar_angles

from .chains import CCD_XML, REPORT_XML, WORKSHEET_XML, chain, model

TOL = 1e-4
API_TOL = 1e-6
PD = np.array([-3.0, math.sqrt(7.0), 0.0])


@pytest.fixture()
def worksheet() -> Chain:
    return Chain(model(WORKSHEET_XML), "p3")


def test_law_of_cosines_elbow():
    """Step 1: phi = arccos(-0.25) = 1.8234766 and theta2z = phi - pi = -1.3181161."""
    phi = law_of_cosines(3.0, 2.0, 4.0)
    assert phi == pytest.approx(1.8234766, abs=TOL)
    assert math.degrees(phi) == pytest.approx(104.4775, abs=TOL)
    assert phi - math.pi == pytest.approx(-1.3181161, abs=TOL)


def test_step1_elbow_only_fk(worksheet):
    """Step 1 check: with only the elbow at theta2z, MuJoCo puts p3 at (3.5, -1.9364917, 0)."""
    p, _ = worksheet.fk([0, 0, 0, -1.3181161])
    np.testing.assert_allclose(p, [3.5, -1.9364917, 0.0], atol=TOL)
    assert np.linalg.norm(p) == pytest.approx(4.0, abs=TOL)


def test_polar_method_angles_and_fk(worksheet):
    """Steps 2a/2b: theta1z = 0.5053605 puts p3 on x; heading pi, elevation 0.7227342."""
    v0 = np.array([3.5, -1.9364917, 0.0])
    theta1z, beta, gamma = polar_angles(v0, PD)
    assert theta1z == pytest.approx(0.5053605, abs=TOL)
    assert math.sin(theta1z) == pytest.approx(0.4841229, abs=TOL)
    assert abs(beta) == pytest.approx(math.pi, abs=TOL)  # atan2 may return -pi
    assert gamma == pytest.approx(0.7227342, abs=TOL)
    p, _ = worksheet.fk([0, theta1z, 0, -1.3181161])
    np.testing.assert_allclose(p, [4.0, 0.0, 0.0], atol=TOL)


@pytest.mark.parametrize("method", ["polar", "angle_axis"])
def test_worksheet_solver_reaches_target(worksheet, method):
    """two_link by either method puts p3 at (-3, 2.6457513, 0) with theta2z = -1.3181161."""
    solver = make_solver("two_link", method=method, branch="negative", tol=1e-9)
    res = solver.solve(worksheet, PD, q0=np.zeros(4))
    assert res.status == "converged"
    assert res.q[3] == pytest.approx(-1.3181161, abs=TOL)
    p, _ = worksheet.fk(res.q)
    np.testing.assert_allclose(p, [-3.0, 2.6457513, 0.0], atol=TOL)
    assert res.position_error < 1e-9


def test_polar_method_joint_angles(worksheet):
    """Polar: R1 = Ry(beta) Rz(gamma) Rz(theta1z) decomposes to y = pi, z = 1.2280947, x = 0."""
    res = make_solver("two_link", method="polar", branch="negative").solve(
        worksheet, PD, q0=np.zeros(4)
    )
    assert abs(res.q[0]) == pytest.approx(math.pi, abs=TOL)
    assert res.q[1] == pytest.approx(0.7227342 + 0.5053605, abs=TOL)
    assert res.q[2] == pytest.approx(0.0, abs=TOL)


def test_angle_axis_method(worksheet):
    """Angle/axis: r0 x e0 = (0, 0, 3.4506546), phi = 2.9242189 about +z, shoulder z = phi."""
    r0 = np.array([3.5, -1.9364917, 0.0])
    e0 = PD - r0
    np.testing.assert_allclose(e0, [-6.5, 4.5822430, 0.0], atol=TOL)
    np.testing.assert_allclose(np.cross(r0, e0), [0.0, 0.0, 3.4506546], atol=TOL)
    phi, u = rotation_between(r0, e0)
    assert phi == pytest.approx(2.9242189, abs=TOL)
    np.testing.assert_allclose(u, [0.0, 0.0, 1.0], atol=1e-12)
    res = make_solver("two_link", method="angle_axis", branch="negative").solve(
        worksheet, PD, q0=np.zeros(4)
    )
    np.testing.assert_allclose(res.q, [0.0, 2.9242189, 0.0, -1.3181161], atol=TOL)


def test_both_elbow_branches(worksheet):
    """The positive branch (theta2z = +1.3181161) reaches the same target."""
    res = make_solver("two_link", branch="positive").solve(worksheet, PD, q0=np.zeros(4))
    assert res.q[3] == pytest.approx(1.3181161, abs=TOL)
    p, _ = worksheet.fk(res.q)
    np.testing.assert_allclose(p, PD, atol=TOL)


def test_reachability_shell(worksheet):
    """Reachable only when |l1 - l2| <= r <= l1 + l2: the shell is [1, 5]."""
    shell = make_solver("two_link").shell(worksheet, np.zeros(4))
    assert (shell.l1, shell.l2, shell.h) == pytest.approx((3.0, 2.0, 0.0), abs=1e-12)
    assert (shell.r_min, shell.r_max) == pytest.approx((1.0, 5.0), abs=1e-12)


def test_worksheet_followed_from_the_api(worksheet):
    """Example 1 followed number by number from two_link's details and MuJoCo's FK (1e-6)."""
    res = make_solver("two_link", method="polar", branch="negative").solve(
        worksheet, PD, q0=np.zeros(4)
    )
    d = res.details
    assert res.converged and res.position_error < 1e-12 and d["kind"] == "three_hinge"
    # step 1: length
    assert d["r"] == pytest.approx(4.0, abs=API_TOL)
    assert d["shell"] == pytest.approx((1.0, 5.0), abs=1e-12)  # |l1 - l2| <= r <= l1 + l2
    assert math.cos(d["phi"]) == pytest.approx(-0.25, abs=API_TOL)
    assert d["phi"] == pytest.approx(1.8234766, abs=API_TOL)
    assert math.degrees(d["phi"]) == pytest.approx(104.4775, abs=1e-4)
    theta2z = d["theta2"]
    assert theta2z == pytest.approx(d["phi"] - math.pi, abs=1e-15)
    assert theta2z == pytest.approx(-1.3181161, abs=API_TOL) and d["elbow"] == theta2z
    assert math.degrees(theta2z) == pytest.approx(-75.5225, abs=1e-4)
    p3, _ = worksheet.fk([0.0, 0.0, 0.0, theta2z])
    np.testing.assert_allclose(p3, [3.5, -1.9364917, 0.0], atol=API_TOL)
    assert np.linalg.norm(p3) == pytest.approx(4.0, abs=API_TOL)
    # step 2a: the limb onto x (the second hinge of the worksheet's shoulder is z)
    polar = d["polar"]
    assert math.sin(polar.theta1z) == pytest.approx(2.0 * math.sin(-theta2z) / 4.0, abs=1e-12)
    assert math.sin(polar.theta1z) == pytest.approx(0.4841229, abs=API_TOL)
    assert polar.theta1z == pytest.approx(0.5053605, abs=API_TOL)
    np.testing.assert_allclose(polar.align_axis, [0.0, 0.0, 1.0], atol=1e-12)
    p3, _ = worksheet.fk([0.0, polar.theta1z, 0.0, theta2z])
    np.testing.assert_allclose(p3, [4.0, 0.0, 0.0], atol=API_TOL)
    # step 2b: heading and elevation; R1 = Ry(beta) Rz(gamma) Rz(theta1z) on hinges y, z, x
    assert abs(polar.beta) == pytest.approx(math.pi, abs=API_TOL)  # atan2 may give -pi
    assert polar.gamma == pytest.approx(0.7227342, abs=API_TOL)
    R1 = [polar.beta, polar.gamma + polar.theta1z, 0.0, theta2z]
    p3, _ = worksheet.fk(R1)
    np.testing.assert_allclose(p3, [-3.0, 2.6457513, 0.0], atol=API_TOL)
    # the polar method's answer is that very rotation
    np.testing.assert_allclose(np.abs(res.q), np.abs(R1), atol=API_TOL)
    # step 2, angle/axis: r0 = p3 - p1 with the shoulder reset, e0 = pd - p3
    r0, _ = worksheet.fk([0.0, 0.0, 0.0, theta2z])
    e0 = PD - r0
    np.testing.assert_allclose(e0, [-6.5, 4.5822430, 0.0], atol=API_TOL)
    np.testing.assert_allclose(np.cross(r0, e0), [0.0, 0.0, 3.4506546], atol=API_TOL)
    aa = d["angle_axis"]
    assert aa.phi == pytest.approx(2.9242189, abs=API_TOL)
    np.testing.assert_allclose(aa.axis, [0.0, 0.0, 1.0], atol=1e-12)
    p3, _ = worksheet.fk([0.0, aa.phi, 0.0, theta2z])
    np.testing.assert_allclose(p3, [-3.0, 2.6457513, 0.0], atol=API_TOL)
    res = make_solver("two_link", method="angle_axis", branch="negative").solve(
        worksheet, PD, q0=np.zeros(4)
    )
    np.testing.assert_allclose(res.q, [0.0, 2.9242189, 0.0, -1.3181161], atol=API_TOL)


def _report_law_of_cosine(a: float, b: float, c: float) -> float:
    """The report's ``lawOfCosine``: ``acos((a^2 + b^2 - c^2) / 2ab)``."""
    return math.acos((a * a + b * b - c * c) / (2 * a * b))


@pytest.mark.parametrize("dest", [(0.35, 0.55), (-0.2, 0.05), (0.52, 0.2)])
def test_report_planar_arm(dest):
    """Example 4: the report's theta_1 = atan2 + law of cosines, theta_2 - pi at the elbow."""
    arm = chain(REPORT_XML, "hand_site")
    l1, l2, source = 0.32, 0.27, (0.1, 0.2)
    dist = math.hypot(dest[0] - source[0], dest[1] - source[1])
    theta_t1 = math.atan2(dest[1] - source[1], dest[0] - source[0])
    theta_t2 = _report_law_of_cosine(dist, l1, l2)
    theta_1, theta_2 = theta_t1 + theta_t2, _report_law_of_cosine(l1, l2, dist)
    target = [dest[0], dest[1], 1.3]
    res = make_solver("two_link", branch="negative").solve(arm, target, q0=[0.0, 0.0])
    d = res.details
    assert d["kind"] == "planar" and res.converged and res.position_error < 1e-12
    assert d["r"] == pytest.approx(dist, abs=1e-12)
    assert d["theta_t1"] == pytest.approx(theta_t1, abs=API_TOL)
    assert d["theta_t2"] == pytest.approx(theta_t2, abs=API_TOL)
    assert d["phi"] == pytest.approx(theta_2, abs=API_TOL)
    np.testing.assert_allclose(res.q, [theta_1, theta_2 - math.pi], atol=API_TOL)
    p, _ = arm.fk(res.q)
    np.testing.assert_allclose(p, target, atol=1e-12)
    assert d["shell"] == pytest.approx((l1 - l2, l1 + l2), abs=1e-12)


def test_report_reachable_shell():
    """Beyond L1 + L2 or inside L1 - L2 the report's arm cannot reach: unreachable."""
    arm = chain(REPORT_XML, "hand_site")
    for r, where in ((0.6, "beyond"), (0.04, "inside the inner hole of")):
        res = make_solver("two_link").solve(arm, [0.1 + r, 0.2, 1.3], q0=[0.0, 0.0])
        assert res.status == "unreachable" and f"m {where} the reachable shell" in res.message
    res = make_solver("two_link").solve(arm, [0.1 + 0.59, 0.2, 1.3], q0=[0.0, 0.0])
    assert res.converged and res.position_error < 1e-12


def test_ccd_single_sweep():
    """CCD, nudge 1: joint 2 turns 116.5651 deg, joint 1 33.4924 deg; p3 misses by 0.4441010."""
    chain = Chain(model(CCD_XML), "p3")
    pd = np.array([1.0, 2.0, 0.0])
    p, _ = chain.fk([0.0, 0.0])
    np.testing.assert_allclose(p, [3.0, 0.0, 0.0], atol=1e-12)
    res = make_solver("ccd", nudge=1.0, max_iterations=1, restarts=0, tol=1e-12).solve(
        chain, pd, q0=[0.0, 0.0]
    )
    assert math.degrees(res.q[1]) == pytest.approx(116.5651, abs=TOL)
    assert math.degrees(res.q[0]) == pytest.approx(33.4924, abs=TOL)
    # after joint 2 alone
    p, _ = chain.fk([0.0, res.q[1]])
    np.testing.assert_allclose(p, [1.5527864, 0.8944272, 0.0], atol=TOL)
    # after the full sweep
    p3, _ = chain.fk(res.q)
    np.testing.assert_allclose(p3, [0.8013920, 1.6027840, 0.0], atol=TOL)
    np.testing.assert_allclose(chain.data.body("link2").xpos, [1.6679182, 1.1036525, 0], atol=TOL)
    assert res.position_error == pytest.approx(0.4441010, abs=TOL)
    assert res.status == "max_iterations"


def test_ccd_iterates_to_target():
    """Further sweeps bring p3 onto pd = (1, 2, 0)."""
    chain = Chain(model(CCD_XML), "p3")
    res = make_solver("ccd", nudge=1.0, tol=1e-9).solve(chain, [1.0, 2.0, 0.0], q0=[0.0, 0.0])
    assert res.converged
    p, _ = chain.fk(res.q)
    np.testing.assert_allclose(p, [1.0, 2.0, 0.0], atol=1e-8)


def test_ccd_small_nudge_needs_more_sweeps():
    """With c = 0.1 each visit turns a tenth of phi: more sweeps, same target."""
    chain = Chain(model(CCD_XML), "p3")
    fast = make_solver("ccd", nudge=1.0, tol=1e-6).solve(chain, [1.0, 2.0, 0.0], q0=[0, 0])
    slow = make_solver("ccd", nudge=0.1, tol=1e-6, max_iterations=2000, restarts=0).solve(
        chain, [1.0, 2.0, 0.0], q0=[0, 0]
    )
    assert slow.converged and fast.converged
    assert slow.iterations > 5 * fast.iterations


def test_look_at_rotation():
    """Object at (1, 1, 0), target (4, -3, 0): the forward column is (0.6, -0.8, 0)."""
    R = look_at([1.0, 1.0, 0.0], [4.0, -3.0, 0.0])
    np.testing.assert_allclose(R[:, 0], [0.6, -0.8, 0.0], atol=1e-12)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(R[:, 2], [0.0, 0.0, 1.0], atol=1e-12)  # up is kept
