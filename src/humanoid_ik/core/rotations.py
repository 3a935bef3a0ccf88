"""Rotation helpers: axis-angle, quaternions (wxyz, as MuJoCo), look-at, and the
decomposition of a rotation onto three hinge axes.

All angles in [rad]. Rotation matrices are (3, 3) with the axes of the rotated frame as
columns, as in MuJoCo's ``xmat``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.errors import TargetError

__all__ = [
    "axis_name",
    "SIGNED_AXES",
    "wrap_angle",
    "axis_angle_matrix",
    "rotation_between",
    "look_at",
    "quat_to_mat",
    "mat_to_quat",
    "rotation_log",
    "normalize_quat",
    "quat_norms",
    "UNIT_TOL",
    "decompose_three_axes",
    "hinge_angle_between",
    "axes_meeting_point",
    "AXES",
    "quat_mul",
]

AXES = {"x": 0, "y": 1, "z": 2}
SIGNED_AXES = ("x", "y", "z", "-x", "-y", "-z")
"""The names of a frame's axes and their opposites (a gaze along ``-x``: iCub's head)."""


def axis_name(v: ArrayLike, tol: float = 1e-6) -> str | None:
    """The :data:`SIGNED_AXES` name of the direction ``v`` when it lies along a frame
    axis (within ``tol``), else ``None``."""
    a = np.asarray(v, dtype=np.float64)
    a = a / np.linalg.norm(a)
    k = int(np.argmax(np.abs(a)))
    if abs(abs(float(a[k])) - 1.0) > tol:
        return None
    return ("-" if a[k] < 0 else "") + "xyz"[k]


def axis_angle_matrix(axis: ArrayLike, angle: float) -> NDArray[np.float64]:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues).

    ``R = I + sin(t) [u]x + (1 - cos(t)) [u]x^2``.
    """
    u = np.asarray(axis, dtype=np.float64)
    u = u / np.linalg.norm(u)
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def hinge_angle_between(axis: NDArray, v: NDArray, w: NDArray) -> float:
    """Angle of the rotation about unit ``axis`` that takes ``v`` closest to ``w``.

    Both vectors are projected on the plane normal to the axis:
    ``t = atan2(u . (v_p x w_p), v_p . w_p)``. Returns 0 when either projection vanishes
    (below 1e-9 of its vector's length: a vector along the axis, which no turn moves).
    """
    vp = v - np.dot(v, axis) * axis
    wp = w - np.dot(w, axis) * axis
    if np.dot(vp, vp) <= 1e-18 * np.dot(v, v) or np.dot(wp, wp) <= 1e-18 * np.dot(w, w):
        return 0.0
    s = float(np.dot(axis, np.cross(vp, wp)))
    c = float(np.dot(vp, wp))
    return math.atan2(s, c)


def rotation_between(r: ArrayLike, e: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """The angle/axis (tangent) rotation of the lecture notes.

    Rotating the limb vector ``r`` by ``phi`` about ``u`` points it along ``r + e``:
    ``phi = atan2(|r x e|, r.r + r.e)``, ``u = (r x e) / |r x e|``.
    When ``r`` and ``r + e`` are parallel the axis is any vector normal to ``r``.

    Returns:
        ``(phi, u)``: angle in [rad] and unit axis ``(3,)``.
    """
    r = np.asarray(r, dtype=np.float64)
    e = np.asarray(e, dtype=np.float64)
    c = np.cross(r, e)
    n = float(np.linalg.norm(c))
    phi = math.atan2(n, float(r @ r + r @ e))
    if n > 1e-12 * max(1.0, float(np.linalg.norm(r) * np.linalg.norm(e))):
        return phi, c / n
    # Parallel: pick an axis normal to r (only matters when phi = pi).
    helper = np.eye(3)[int(np.argmin(np.abs(r)))]
    u = np.cross(r, helper)
    return phi, u / np.linalg.norm(u)


def look_at(
    position: ArrayLike,
    target: ArrayLike,
    up: ArrayLike = (0.0, 0.0, 1.0),
    forward_axis: str = "x",
) -> NDArray[np.float64]:
    """Rotation whose ``forward_axis`` column points from ``position`` at ``target``.

    The columns of a rotation matrix are the axes of its frame (lecture notes, look-at).
    With forward axis k: column k is ``f = (target - position) / |.|``, column k+1 is
    ``normalize(up x f)`` and column k+2 is ``f x column k+1`` (indices mod 3), so for the
    x axis the frame's z column lies as close to ``up`` as possible. When ``f`` is
    parallel to ``up`` the world axis least aligned with ``f`` stands in for ``up``.

    Args:
        position: origin of the frame ``(3,)`` in [m].
        target: point to look at ``(3,)`` in [m].
        up: preferred up direction ``(3,)``.
        forward_axis: ``"x"``, ``"y"`` or ``"z"``, the column that points at the target.

    Raises:
        TargetError: target equal to position, zero ``up``, or an unknown axis name.
    """
    if forward_axis not in AXES:
        raise TargetError(f"forward axis '{forward_axis}' unknown; axes: x, y, z")
    k = AXES[forward_axis]
    f = np.asarray(target, dtype=np.float64) - np.asarray(position, dtype=np.float64)
    nf = float(np.linalg.norm(f))
    if not nf > 1e-12:
        raise TargetError("look-at target coincides with the frame's position")
    f = f / nf
    u = np.asarray(up, dtype=np.float64)
    if not float(np.linalg.norm(u)) > 1e-12:
        raise TargetError(f"up vector {u.tolist()} has zero length")
    s = np.cross(u, f)
    if float(np.linalg.norm(s)) < 1e-9 * float(np.linalg.norm(u)):
        s = np.cross(np.eye(3)[int(np.argmin(np.abs(f)))], f)
    s = s / np.linalg.norm(s)
    R = np.empty((3, 3))
    R[:, k] = f
    R[:, (k + 1) % 3] = s
    R[:, (k + 2) % 3] = np.cross(f, s)
    return R


def quat_norms(quats: NDArray[np.float64]) -> NDArray[np.float64]:
    """The norms of wxyz quaternions ``(..., 4)``, summed in one fixed order (w, x, y, z),
    so that a quaternion's norm is the same bits alone or as a row of many
    (``solve_batch``'s targets are normalised as :class:`~.types.Target` normalises one)."""
    w, x, y, z = (quats[..., k] for k in range(4))
    return np.sqrt(((w * w + x * x) + y * y) + z * z)


UNIT_TOL = 1e-3
"""How far a target quaternion's norm may be from 1 (it is then normalised)."""


def normalize_quat(quat: ArrayLike, tol: float = UNIT_TOL) -> NDArray[np.float64]:
    """Check a wxyz quaternion and return it with unit norm.

    Raises:
        TargetError: wrong shape, NaN/inf, zero norm, or a norm further than ``tol`` from 1.
    """
    q = np.asarray(quat, dtype=np.float64)
    if q.shape != (4,):
        raise TargetError(f"quaternion must have 4 values (w, x, y, z), got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise TargetError(f"quaternion {q.tolist()} is not finite")
    n = float(quat_norms(q))
    if n == 0.0:
        raise TargetError("quaternion (0, 0, 0, 0) has zero norm; expected a unit (w, x, y, z)")
    if abs(n - 1.0) > tol:
        raise TargetError(
            f"quaternion {q.tolist()} has norm {n:.6g}; expected a unit quaternion (w, x, y, z)"
        )
    return q / n


def quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product ``a * b`` of wxyz quaternions ``(4,)`` (``b`` applied first)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def quat_to_mat(quat: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``(3, 3)`` of a unit wxyz quaternion ``(4,)``; of many ``(N, 4)``,
    ``(N, 3, 3)``, each the bits of its own call (the same operations, row by row)."""
    q = np.asarray(quat, dtype=np.float64)
    w, x, y, z = q if q.ndim == 1 else q.T
    m = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return m if q.ndim == 1 else np.ascontiguousarray(np.moveaxis(m, -1, 0))


def mat_to_quat(R: ArrayLike) -> NDArray[np.float64]:
    """Unit wxyz quaternion of a rotation matrix, with w >= 0 (Shepperd's method)."""
    m = np.asarray(R, dtype=np.float64)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    out = np.array(q)
    out /= np.linalg.norm(out)
    return out if out[0] >= 0 else -out


def rotation_log(R: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector ``w`` (axis times angle, angle in [0, pi]) with ``exp([w]x) = R``."""
    m = np.asarray(R, dtype=np.float64)
    v = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    s = 0.5 * float(np.linalg.norm(v))
    c = 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0)
    angle = math.atan2(s, c)
    if s > 1e-7:
        return v * (angle / (2.0 * s))
    if c > 0:  # near identity: first order
        return 0.5 * v
    # near pi: the symmetric part is c I + (1 - c) u u'
    M = 0.5 * (m + m.T) - c * np.eye(3)
    i = int(np.argmax(np.diag(M)))
    u = M[:, i] / np.linalg.norm(M[:, i])
    if float(u @ v) < 0:
        u = -u
    return u * angle


def decompose_three_axes(
    R: ArrayLike, a1: ArrayLike, a2: ArrayLike, a3: ArrayLike, q1_free: float = 0.0
) -> list[NDArray[np.float64]]:
    """All ``(q1, q2, q3)`` with ``R = Rot(a1, q1) Rot(a2, q2) Rot(a3, q3)``.

    Generalised (Davenport) Euler angles on three unit axes given in one frame at the
    zero configuration (a product of exponentials). ``q2`` solves
    ``a1' R a3 = a1' Rot(a2, q2) a3``, an equation ``A cos q2 + B sin q2 = C``; then ``q1``
    takes ``Rot(a2, q2) a3`` to ``R a3`` about ``a1``, and ``q3`` is what remains. In the
    gimbal lock (``Rot(a2, q2) a3`` parallel to ``a1``) only ``q1 + q3`` is fixed; ``q1``
    takes ``q1_free``.

    Returns:
        Up to two solutions, each ``(3,)``, angles wrapped to (-pi, pi]; empty when ``R``
        is not reachable with these axes.
    """
    Rm = np.asarray(R, dtype=np.float64)
    u1, u2, u3 = (np.asarray(a, dtype=np.float64) / np.linalg.norm(a) for a in (a1, a2, a3))
    d12, d23, d13 = float(u1 @ u2), float(u2 @ u3), float(u1 @ u3)
    A = d13 - d12 * d23
    B = float(u1 @ np.cross(u2, u3))
    C = float(u1 @ Rm @ u3) - d12 * d23
    K = math.hypot(A, B)
    if K < 1e-12:
        return []
    ratio = C / K
    if abs(ratio) > 1.0 + 1e-9:
        return []
    base = math.atan2(B, A)
    delta = math.acos(max(-1.0, min(1.0, ratio)))
    q2s = [base + delta] if delta < 1e-12 else [base + delta, base - delta]
    # a vector normal to u3, to read q3 off the remaining rotation
    n3 = np.cross(u3, np.eye(3)[int(np.argmin(np.abs(u3)))])
    n3 /= np.linalg.norm(n3)
    out = []
    for q2 in q2s:
        R2 = axis_angle_matrix(u2, q2)
        v = R2 @ u3
        w = Rm @ u3
        vp = v - (v @ u1) * u1
        if np.linalg.norm(vp) < 1e-9:
            q1 = q1_free
        else:
            q1 = hinge_angle_between(u1, v, w)
        R3 = R2.T @ axis_angle_matrix(u1, q1).T @ Rm
        q3 = hinge_angle_between(u3, n3, R3 @ n3)
        out.append(np.array([wrap_angle(q1), wrap_angle(q2), wrap_angle(q3)]))
    return out


def axes_meeting_point(
    anchors: ArrayLike, axes: ArrayLike, tol: float = 1e-7
) -> NDArray[np.float64] | None:
    """The point where every hinge axis line ``anchor_i + s u_i`` passes, or ``None``.

    Least squares over the lines: ``sum_i (I - u_i u_i') S = sum_i (I - u_i u_i') a_i``
    (each term the projection normal to unit ``u_i``), then each line is checked to
    pass within ``tol`` [m] of ``S``. Parallel axes (a singular system) pin no point.

    Args:
        anchors: a point on each line ``(K, 3)`` [m].
        axes: unit directions ``(K, 3)``.
        tol: largest distance [m] of a line from the point.

    Returns:
        ``S (3,)`` [m], or ``None`` when the lines do not meet in one point.
    """
    A = np.asarray(anchors, dtype=np.float64)
    U = np.asarray(axes, dtype=np.float64)
    M = np.zeros((3, 3))
    b = np.zeros(3)
    for a, u in zip(A, U, strict=True):
        P = np.eye(3) - np.outer(u, u)
        M += P
        b += P @ a
    if np.linalg.cond(M) > 1e9:  # parallel axes do not pin a point
        return None
    S = np.asarray(np.linalg.solve(M, b), dtype=np.float64)
    for a, u in zip(A, U, strict=True):
        if float(np.linalg.norm(np.cross(S - a, u))) > tol:
            return None
    return S


def wrap_angle(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    w = math.remainder(a, 2.0 * math.pi)
    return math.pi if w == -math.pi else w
