"""How far an effector is from its goal, and when it counts as there: the one definition.

Solvers (their convergence tests and results), the scene runner (per-frame metrics),
the bench and the sweeps all measure with these functions, so a run that a solver
reports as converged is reported on target by every other part with the same numbers.

- Position error: ``|p_target - p_site|`` [m].
- Orientation error: the angle [rad] of the rotation taking the site frame onto the
  target frame, ``|w|`` with ``R_target = exp([w]x) R_site`` (``mju_subQuat``).
- Gaze error of a site aiming its unit ``axis`` (site frame) at a point: with
  ``f = R_site axis`` and ``v = p_target - p_site``, the angle
  ``theta = atan2(|f x v|, f . v)`` [rad] and the miss, the distance from the target to
  the gaze ray, ``|v| sin(theta)`` (``|v|`` when the target is behind, ``theta >= pi/2``).
- On target: position error (for a gaze: the miss) within :data:`ON_TARGET_DISTANCE`
  and, for a pose target, orientation error within :data:`ON_TARGET_ANGLE`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.rotations import AXES, SIGNED_AXES
from humanoid_ik.errors import TargetError

__all__ = [
    "ON_TARGET_ANGLE",
    "ON_TARGET_DISTANCE",
    "GazeError",
    "axis_vector",
    "gaze_error",
    "on_target",
    "orientation_error",
    "pose_error",
]

ON_TARGET_DISTANCE = 1e-3
"""An effector is on target within this distance [m] (a gaze: of the gaze ray)."""
ON_TARGET_ANGLE = 1e-2
"""... and, for a pose target, within this angle [rad]."""


class GazeError(NamedTuple):
    """How far a gaze is off its target."""

    miss: float
    """Distance [m] from the target to the gaze ray (to the site when behind it)."""
    angle: float
    """Angle [rad] between the gaze axis and the direction to the target."""


def axis_vector(axis: str | ArrayLike) -> NDArray[np.float64]:
    """A site-frame axis ``(3,)`` as a unit vector: ``"x"``, ``"y"``, ``"z"``, their
    opposites ``"-x"``, ``"-y"``, ``"-z"`` (:data:`~humanoid_ik.core.rotations.SIGNED_AXES`),
    or 3 numbers.

    Raises:
        TargetError: an unknown axis name, or not a non-zero 3-vector.
    """
    if isinstance(axis, str):
        if axis not in SIGNED_AXES:
            raise TargetError(f"axis '{axis}' unknown; axes: {', '.join(SIGNED_AXES)}")
        out = np.zeros(3)
        out[AXES[axis[-1]]] = -1.0 if axis[0] == "-" else 1.0
        return out
    a = np.asarray(axis, dtype=np.float64)
    n = float(np.linalg.norm(a)) if a.shape == (3,) and np.all(np.isfinite(a)) else 0.0
    if not n > 1e-12:
        raise TargetError(f"axis {np.asarray(axis).tolist()} must be a non-zero 3-vector")
    return a / n


def gaze_error(
    p_site: NDArray[np.float64],
    R_site: NDArray[np.float64],
    axis: NDArray[np.float64],
    p_target: NDArray[np.float64],
) -> GazeError:
    """The gaze error of a site aiming ``axis`` at ``p_target`` (see the module docstring).

    Args:
        p_site: site position ``(3,)`` [m].
        R_site: site rotation, ``(3, 3)`` or row-major ``(9,)`` (``site_xmat``).
        axis: unit gaze axis ``(3,)`` in the site frame.
        p_target: the point looked at ``(3,)`` [m].
    """
    R = R_site.reshape(9)
    a0, a1, a2 = float(axis[0]), float(axis[1]), float(axis[2])
    f0 = R[0] * a0 + R[1] * a1 + R[2] * a2
    f1 = R[3] * a0 + R[4] * a1 + R[5] * a2
    f2 = R[6] * a0 + R[7] * a1 + R[8] * a2
    v0 = float(p_target[0] - p_site[0])
    v1 = float(p_target[1] - p_site[1])
    v2 = float(p_target[2] - p_site[2])
    dist = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if dist < 1e-12:
        return GazeError(0.0, 0.0)
    c0, c1, c2 = f1 * v2 - f2 * v1, f2 * v0 - f0 * v2, f0 * v1 - f1 * v0
    theta = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), f0 * v0 + f1 * v1 + f2 * v2)
    return GazeError(dist * math.sin(theta) if theta < math.pi / 2 else dist, theta)


def pose_error(
    p_site: NDArray[np.float64],
    R_site: NDArray[np.float64],
    p_target: NDArray[np.float64],
    quat_target: NDArray[np.float64] | None,
    out: NDArray[np.float64],
    quat_buf: NDArray[np.float64],
) -> tuple[float, float]:
    """Fill ``out`` ``(6,)`` with the task error and return its two norms.

    ``out[:3] = p_target - p_site`` [m]; for a pose target ``out[3:6]`` is the
    world-frame rotation vector ``w`` with ``R_target = exp([w]x) R_site`` [rad].

    Args:
        p_site: site position ``(3,)`` [m].
        R_site: site rotation, row-major ``(9,)`` or ``(3, 3)``.
        p_target: target position ``(3,)`` [m].
        quat_target: target orientation, unit wxyz ``(4,)``, or ``None``.
        out: the error vector ``(6,)`` (only ``out[:3]`` is written without a quat).
        quat_buf: scratch ``(2, 4)``.

    Returns:
        ``(position error [m], orientation error [rad] or nan)``.
    """
    # the norms in Python floats (tolist): NumPy's scalar indexing cost half the call
    np.subtract(p_target, p_site, out=out[:3])
    x, y, z = out[:3].tolist()
    ep = math.sqrt(x * x + y * y + z * z)
    if quat_target is None:
        return ep, math.nan
    R = R_site.reshape(9)
    site, rot = quat_buf[0], quat_buf[1, :3]
    mujoco.mju_mat2Quat(site, R)
    mujoco.mju_subQuat(rot, quat_target, site)  # site frame
    mujoco.mju_mulMatVec3(out[3:6], R, rot)  # to the world frame
    x, y, z = out[3:6].tolist()
    er = math.sqrt(x * x + y * y + z * z)
    return ep, er


def orientation_error(R_site: NDArray[np.float64], quat_target: NDArray[np.float64]) -> float:
    """The angle [rad] between a site's rotation (``(3, 3)`` or ``(9,)``) and a target
    orientation (unit wxyz ``(4,)``)."""
    buf = np.empty((2, 4))
    mujoco.mju_mat2Quat(buf[0], R_site.reshape(9))
    mujoco.mju_subQuat(buf[1, :3], quat_target, buf[0])
    return float(np.linalg.norm(buf[1, :3]))


def on_target(position_error: float, orientation_error: float | None = None) -> bool:
    """Within :data:`ON_TARGET_DISTANCE` [m] and, when given, :data:`ON_TARGET_ANGLE`
    [rad] (a gaze passes its miss as ``position_error`` and no angle)."""
    return position_error <= ON_TARGET_DISTANCE and (
        orientation_error is None or orientation_error <= ON_TARGET_ANGLE
    )
