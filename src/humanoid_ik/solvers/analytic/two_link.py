"""Two-link analytic IK (the worksheet): elbow by the law of cosines, then the shoulder.

The chain must start with a spherical shoulder (three hinges whose axes meet at one
point ``S``) followed by an elbow hinge; any joints after the elbow (a wrist) keep their
starting values and ride along. Orientation of the shoulder by the polar-coordinate
method (heading and elevation as YZX Euler angles) or the angle/axis (tangent) method,
then decomposed onto the model's three shoulder hinges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import (
    axes_meeting_point,
    axis_angle_matrix,
    decompose_three_axes,
    rotation_between,
)
from humanoid_ik.core.types import IKResult, Status, Target
from humanoid_ik.solvers.base import Solver
from humanoid_ik.solvers.options import SolverOptions, option

__all__ = ["TwoLink", "law_of_cosines", "polar_angles", "Shell"]

_BOUNDARY_TOL = 1e-9  # [m]: a target this close to the shell counts as on it
_TWISTS = np.deg2rad(np.concatenate([[0.0], np.repeat(np.arange(5.0, 181.0, 5.0), 2)]))
_TWISTS[2::2] *= -1.0


def law_of_cosines(l1: float, l2: float, r: float) -> float:
    """Interior angle ``phi`` [rad] between links ``l1`` and ``l2`` whose ends are ``r`` apart.

    ``r^2 = l1^2 + l2^2 - 2 l1 l2 cos(phi)``; the cosine is clipped to [-1, 1], so a
    target beyond reach gives the straight (``pi``) or folded (``0``) limb.
    """
    c = (l1 * l1 + l2 * l2 - r * r) / (2.0 * l1 * l2)
    return math.acos(max(-1.0, min(1.0, c)))


def polar_angles(v0: NDArray[np.float64], t: NDArray[np.float64]) -> tuple[float, float, float]:
    """The polar-coordinate method: ``(theta_align, beta, gamma)``.

    ``theta_align`` is the angle of the smallest rotation taking the limb ``v0`` onto the
    x axis (step 2a), ``beta = atan2(-t_z, t_x)`` the heading about y and
    ``gamma = asin(t_y / |t|)`` the elevation about z (step 2b), so that
    ``Ry(beta) Rz(gamma) R_align v0`` is parallel to ``t``.
    """
    x = np.array([1.0, 0.0, 0.0]) * float(np.linalg.norm(v0))
    theta_align, _ = rotation_between(v0, x - v0)
    r = float(np.linalg.norm(t))
    beta = math.atan2(-t[2], t[0])
    gamma = math.asin(max(-1.0, min(1.0, t[1] / r)))
    return theta_align, beta, gamma


class Shell(NamedTuple):
    """The elbow geometry of a chain (all in the world frame at the shoulder's zero)."""

    l1: float
    """Upper-arm length normal to the elbow axis [m]."""
    l2: float
    """Forearm-to-end-effector length normal to the elbow axis [m]."""
    h: float
    """Offset between the two along the elbow axis [m] (0 for a planar limb)."""
    alpha: float
    """Elbow angle [rad] at which the limb is folded (distance shortest)."""
    r_min: float
    """Inner radius of the reachable shell [m]: ``sqrt((l1 - l2)^2 + h^2)``."""
    r_max: float
    """Outer radius [m]: ``sqrt((l1 + l2)^2 + h^2)``."""


@dataclass(frozen=True)
class TwoLinkOptions(SolverOptions):
    """Options of ``two_link``.

    Attributes:
        method: the shoulder rotation: ``polar`` or ``angle_axis``.
        branch: the elbow branch: ``auto`` (nearest the start), ``positive``, ``negative``.
    """

    method: str = option("polar", valid=("polar", "angle_axis"))
    branch: str = option("auto", valid=("auto", "positive", "negative"))


class TwoLink(Solver):
    """Analytic shoulder + elbow solve.

    Elbow: with ``a = S - E`` and ``b0 = P - E`` (elbow at zero) split along and normal to
    the elbow axis ``u``, ``|S - P(q)|^2 = l1^2 + l2^2 + h^2 - 2 l1 l2 cos(q - alpha)``,
    so ``q = alpha +- phi`` with ``phi = law_of_cosines(l1, l2, sqrt(r^2 - h^2))`` (the
    worksheet's ``theta2z = phi - pi`` when the limb lies along x). Both branches are
    tried (``branch="auto"``, nearest the start first) or one is chosen.

    Shoulder: ``R`` turns ``v0 = P - S`` toward ``t = p_d - S``: polar
    ``R = Ry(beta) Rz(gamma) R_align`` or angle/axis ``R = Rot(u, phi)`` with
    ``phi = atan2(|r0 x e0|, r0.r0 + r0.e0)``; then ``R = Rot(a1, q1) Rot(a2, q2) Rot(a3, q3)``
    on the shoulder axes. When no decomposition lies inside the joint ranges, a twist
    about ``t`` (which leaves the hand on target) is searched in 5 degree steps.
    A target outside ``r_min <= r <= r_max`` is ``unreachable``; the arm is left
    straight (or folded) and pointing at it.
    """

    name: ClassVar[str] = "two_link"
    summary: ClassVar[str] = "analytic: law of cosines + polar or angle/axis shoulder"
    Options: ClassVar[type[SolverOptions]] = TwoLinkOptions
    options: TwoLinkOptions

    # ------------------------------------------------------------------ structure
    def applicable(self, chain: Chain, pose: bool = False) -> str | None:
        reason = super().applicable(chain, pose)
        if reason is not None:
            return reason
        return self.structure_problem(chain)

    @staticmethod
    def structure_problem(chain: Chain) -> str | None:
        """Why the chain has no spherical shoulder followed by an elbow, or ``None``."""
        if chain.n < 4:
            return (
                f"two_link needs 3 shoulder hinges and an elbow hinge; the chain has "
                f"{chain.n} joint(s)"
            )
        anchors, axes = chain.joint_axes()
        S = axes_meeting_point(anchors[:3], axes[:3])
        if S is None:
            return "two_link needs the first three hinge axes to meet at one point (a shoulder)"
        # the elbow must change the shoulder-to-end distance
        E, u = anchors[3], axes[3]
        d = np.cross(S - E, u)
        if float(np.linalg.norm(d)) < 1e-9:
            return "two_link needs an elbow axis that does not pass through the shoulder"
        return None

    def shell(self, chain: Chain, q0: NDArray[np.float64] | None = None) -> Shell:
        """Elbow geometry and reachable shell with the joints after the elbow at ``q0``."""
        q = chain.q if q0 is None else np.array(q0, dtype=np.float64)
        return self._geometry(chain, q)[0]

    def _geometry(self, chain: Chain, q: NDArray[np.float64]):
        z = q.copy()
        z[:4] = 0.0
        chain.set_q(z)
        anchors, axes = chain.joint_axes()
        S = axes_meeting_point(anchors[:3], axes[:3])
        E, u = anchors[3], axes[3]
        P0 = chain.position.copy()
        a, b0 = S - E, P0 - E
        au, bu = float(a @ u), float(b0 @ u)
        ap, bp = a - au * u, b0 - bu * u
        A = float(ap @ bp)
        B = float(ap @ np.cross(u, bp))
        l1, l2, h = float(np.linalg.norm(ap)), float(np.linalg.norm(bp)), abs(au - bu)
        alpha = math.atan2(B, A)
        shell = Shell(l1, l2, h, alpha, math.hypot(l1 - l2, h), math.hypot(l1 + l2, h))
        return shell, S, axes[:3].copy()

    # ------------------------------------------------------------------ solve
    def _solve(self, chain: Chain, target: Target, q0: NDArray[np.float64]) -> IKResult:
        shell, S, shoulder_axes = self._geometry(chain, q0)
        pd = target.position
        t = pd - S
        r = float(np.linalg.norm(t))
        outside = max(r - shell.r_max, shell.r_min - r, 0.0)
        r_plane = math.sqrt(max(r * r - shell.h * shell.h, 0.0))
        phi = law_of_cosines(shell.l1, shell.l2, r_plane) if shell.l2 > 0 else 0.0
        branches = self._branches(chain, shell.alpha, phi, q0[3])

        best: tuple[float, NDArray[np.float64]] | None = None
        for qe in branches:
            q = q0.copy()
            q[3] = qe
            q[:3] = 0.0
            chain.set_q(q)
            v0 = chain.position - S
            direction = t if r > 1e-12 else v0
            R = self.shoulder_rotation(v0, direction)
            _, q[:3], _ = _fit_shoulder(chain, R, direction, shoulder_axes, q0[:3])
            violation = float(
                np.sum(np.maximum(chain.lower - q, 0.0) + np.maximum(q - chain.upper, 0.0))
            )
            if violation == 0.0:
                best = (0.0, q)
                break
            if best is None or violation < best[0]:
                best = (violation, chain.clip(q))
        assert best is not None
        q = best[1]
        if outside > _BOUNDARY_TOL:
            where = "beyond" if r > shell.r_max else "inside the inner hole of"
            msg = (
                f"target is {outside:.6g} m {where} the reachable shell "
                f"[{shell.r_min:.4f}, {shell.r_max:.4f}] m around the shoulder"
            )
            return self._result(chain, target, q, 1, status=Status.UNREACHABLE, message=msg)
        if best[0] > 0.0:
            res = self._result(chain, target, q, 1)
            if not res.converged:
                return self._result(
                    chain,
                    target,
                    q,
                    1,
                    status=Status.UNREACHABLE,
                    message="no shoulder and elbow angles inside the joint ranges reach the target",
                )
            return res
        return self._result(chain, target, q, 1)

    def _branches(self, chain: Chain, alpha: float, phi: float, q_start: float) -> list[float]:
        """Elbow candidates ``alpha +- phi`` (moved into range by 2 pi where possible)."""
        lo, hi = chain.lower[3], chain.upper[3]
        cands = []
        for sign, q in ((1.0, alpha + phi), (-1.0, alpha - phi)):
            q = math.remainder(q, 2.0 * math.pi)
            for shift in (0.0, 2.0 * math.pi, -2.0 * math.pi):
                if lo - 1e-12 <= q + shift <= hi + 1e-12:
                    q = q + shift
                    break
            cands.append((sign, q))
        if self.options.branch == "positive":
            return [q for _, q in cands if q >= 0] or [max(q for _, q in cands)]
        if self.options.branch == "negative":
            return [q for _, q in cands if q < 0] or [min(q for _, q in cands)]
        qs = [q for _, q in cands]
        if abs(qs[0] - qs[1]) < 1e-12:
            qs = qs[:1]
        qs.sort(key=lambda q: (not (lo - 1e-12 <= q <= hi + 1e-12), abs(q - q_start)))
        return qs

    def shoulder_rotation(self, v0: NDArray[np.float64], t: NDArray[np.float64]) -> NDArray:
        """World rotation ``(3, 3)`` about the shoulder that points ``v0`` along ``t``."""
        if self.options.method == "polar":
            theta_align, beta, gamma = polar_angles(v0, t)
            x = np.array([1.0, 0.0, 0.0]) * float(np.linalg.norm(v0))
            _, u_align = rotation_between(v0, x - v0)
            R_align = axis_angle_matrix(u_align, theta_align)
            Ry = axis_angle_matrix([0.0, 1.0, 0.0], beta)
            Rz = axis_angle_matrix([0.0, 0.0, 1.0], gamma)
            return Ry @ Rz @ R_align
        phi, u = rotation_between(v0, t / np.linalg.norm(t) * np.linalg.norm(v0) - v0)
        return axis_angle_matrix(u, phi)


_RANGE_SLACK = 1e-9  # [rad]: a decomposition's rounding at a range end


def _fit_shoulder(
    chain: Chain,
    R: NDArray[np.float64],
    t: NDArray[np.float64],
    axes: NDArray[np.float64],
    q_start: NDArray[np.float64],
) -> tuple[bool, NDArray[np.float64], float]:
    """Shoulder angles for ``R`` inside the ranges, twisting about ``t`` if needed.

    Twists are tried at 0, +-5, +-10, ... 180 degrees; when none fits, the search
    narrows around the twist with the smallest range violation (steps of 1 degree,
    then a quarter of that, down to 1e-10 rad).

    Returns ``(found, q (3,), range violation [rad] of the best candidate)``.
    """
    lo, hi = chain.lower[:3], chain.upper[:3]
    t_hat = t / np.linalg.norm(t)
    best: list[Any] = [np.zeros(3), math.inf, 0.0]  # q, violation, twist

    def trial(psi: float) -> bool:
        Rt = R if psi == 0.0 else axis_angle_matrix(t_hat, psi) @ R
        for sol in decompose_three_axes(Rt, axes[0], axes[1], axes[2], float(q_start[0])):
            q = _into_range(sol, lo, hi)
            # an angle at its range end may come out a rounding error beyond it
            slack = np.maximum(lo - q, 0.0) + np.maximum(q - hi, 0.0)
            v = float(np.sum(np.where(slack > _RANGE_SLACK, slack, 0.0)))
            if v == 0.0:
                q = np.clip(q, lo, hi)
            closer = v == best[1] == 0.0 and _dist(q, q_start) < _dist(best[0], q_start)
            if v < best[1] or closer:
                best[:] = [q, v, psi]
        return best[1] == 0.0

    for psi in _TWISTS:
        trial(float(psi))
        if best[1] == 0.0:
            return True, best[0], 0.0
    step = math.radians(1.0)
    while step > 1e-10:
        centre = best[2]
        for k in (1, -1, 2, -2, 3, -3, 4, -4):
            if trial(centre + k * step):
                return True, best[0], 0.0
        step *= 0.25
    return False, best[0], best[1]


def _into_range(q: NDArray, lo: NDArray, hi: NDArray) -> NDArray:
    """Each angle shifted by a multiple of 2 pi into its range where one fits."""
    out = q.copy()
    for i in range(out.shape[0]):
        for shift in (0.0, 2.0 * math.pi, -2.0 * math.pi):
            if lo[i] - 1e-12 <= out[i] + shift <= hi[i] + 1e-12:
                out[i] += shift
                break
    return out


def _dist(a: NDArray, b: NDArray) -> float:
    return float(np.sum(np.abs(a - b)))
