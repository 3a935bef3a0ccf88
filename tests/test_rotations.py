"""Rotation helpers: Rodrigues, quaternions, rotation log, three-axis decomposition."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from humanoid_ik.core.rotations import (
    axis_angle_matrix,
    decompose_three_axes,
    hinge_angle_between,
    mat_to_quat,
    quat_to_mat,
    rotation_between,
    rotation_log,
)

unit = st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(
    lambda v: 0.2 < float(np.linalg.norm(v))
)
angle = st.floats(-math.pi + 1e-6, math.pi - 1e-6)


@given(unit, angle)
def test_axis_angle_is_a_rotation_about_the_axis(axis, t):
    """Rot(u, t) is orthonormal, keeps u, and turns normal vectors by t."""
    u = np.array(axis) / np.linalg.norm(axis)
    R = axis_angle_matrix(u, t)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(R @ u, u, atol=1e-12)
    n = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
    assert hinge_angle_between(u, n, R @ n) == pytest.approx(t, abs=1e-9)


@given(unit, angle)
def test_quaternion_round_trip(axis, t):
    """mat_to_quat inverts quat_to_mat (up to sign), and rotation_log recovers u t."""
    u = np.array(axis) / np.linalg.norm(axis)
    R = axis_angle_matrix(u, t)
    q = mat_to_quat(R)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    np.testing.assert_allclose(quat_to_mat(q), R, atol=1e-12)
    np.testing.assert_allclose(rotation_log(R), u * t, atol=1e-7)


def test_rotation_log_near_pi_and_identity():
    """The log is exact at pi (axis from the symmetric part) and near the identity."""
    u = np.array([1.0, 2.0, 2.0]) / 3.0
    w = rotation_log(axis_angle_matrix(u, math.pi))
    assert np.linalg.norm(w) == pytest.approx(math.pi)
    assert abs(float(w @ u)) == pytest.approx(math.pi)
    np.testing.assert_allclose(rotation_log(axis_angle_matrix(u, 1e-9)), u * 1e-9, atol=1e-15)


def test_rotation_between_parallel_and_opposite():
    """Parallel vectors give phi = 0; opposite ones phi = pi about a normal axis."""
    phi, _ = rotation_between([1, 0, 0], [1, 0, 0])
    assert phi == 0.0
    phi, u = rotation_between([1, 0, 0], [-2, 0, 0])
    assert phi == pytest.approx(math.pi)
    assert abs(u[0]) < 1e-12 and np.linalg.norm(u) == pytest.approx(1.0)


@settings(max_examples=200)
@given(unit, unit, unit, angle, angle, angle)
def test_decompose_three_axes_recovers_the_rotation(a1, a2, a3, q1, q2, q3):
    """Every returned triple rebuilds R; the generating triple is among them (mod 2 pi)."""
    u1, u2, u3 = (np.array(a) / np.linalg.norm(a) for a in (a1, a2, a3))
    if abs(u1 @ u2) > 0.95 or abs(u2 @ u3) > 0.95:
        return  # nearly parallel neighbours cannot span rotations
    R = axis_angle_matrix(u1, q1) @ axis_angle_matrix(u2, q2) @ axis_angle_matrix(u3, q3)
    sols = decompose_three_axes(R, u1, u2, u3, q1_free=q1)
    assert sols
    for s in sols:
        Rs = axis_angle_matrix(u1, s[0]) @ axis_angle_matrix(u2, s[1]) @ axis_angle_matrix(u3, s[2])
        np.testing.assert_allclose(Rs, R, atol=1e-6)


def test_decompose_gimbal_lock_uses_the_free_angle():
    """Ry(0) with axes z, y, z: only q1 + q3 is fixed; q1 takes the given free value."""
    z, y = np.array([0.0, 0, 1]), np.array([0.0, 1, 0])
    R = axis_angle_matrix(z, 0.7)
    sols = decompose_three_axes(R, z, y, z, q1_free=0.2)
    assert sols[0] == pytest.approx([0.2, 0.0, 0.5])


def test_decompose_unreachable_rotation():
    """Three parallel axes cannot make a rotation about another axis: no solution."""
    z = np.array([0.0, 0, 1])
    assert decompose_three_axes(axis_angle_matrix([1, 0, 0], 0.5), z, z, z) == []


def test_hinge_angle_is_zero_for_a_vector_along_the_axis():
    """A vector along the hinge (up to rounding noise) is not turned: 0, not the angle of
    the noise."""
    axis = np.array([0.0, 1.0, 0.0])
    v = np.array([3e-17, 1.0, -2e-17])  # the y axis after a rotation about y, with rounding
    assert hinge_angle_between(axis, v, np.array([1.0, 0.2, 0.3])) == 0.0
    assert hinge_angle_between(axis, np.array([1.0, 0.0, 0.0]), axis * 2.0) == 0.0
    assert hinge_angle_between(axis, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])) == (
        pytest.approx(math.pi / 2)
    )
