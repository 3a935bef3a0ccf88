"""THE elbow of an arm chain: its shoulder, elbow and wrist points, and how far an elbow
pole (``Target.pole``) is from the plane they span.

Every solver that honours a pole reads the arm through this module, so "the elbow
points at the pole" means one thing everywhere:

- the **elbow** is the chain's elbow hinge: joint 3 of a ``closed_form`` arm, joint
  ``k`` after a ``two_link`` shoulder of ``k`` hinges, else the joint with ``elbow`` in
  its name, else the one whose anchor (at zero) is farthest from both the first and
  the last joint's; the elbow *point* is its anchor (``MjData.xanchor``);
- the **shoulder point** is where the hinges before the elbow turn about: the point
  nearest all their axes at zero (exact where they meet; the middle of the offsets
  where they do not, as on G1), fixed in the body the chain hangs from;
- the **wrist point** is where the hinges after the elbow meet (the anchor of a single
  one; the end frame itself for an arm without a wrist), fixed in the end frame.

The elbow's *plane* is the plane through the three points. A pole is honoured when it
lies in that plane on the elbow's side of the shoulder-wrist line: :func:`pole_angle`
is the angle between the half-plane of the elbow and that of the pole about the line
(0 when honoured, pi when the elbow points away), the figure every solver reports as
``details["pole_error"]``. :func:`pole_turns` are the turns of the whole arm about an
axis through the shoulder (the swivel of ``closed_form``, the twist of ``two_link``)
that bring the pole into the plane, and :func:`pole_search` the search over them that
both exact solvers run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple, TypeVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.names import name_words
from humanoid_ik.core.rotations import axes_meeting_point, axis_angle_matrix
from humanoid_ik.core.types import Status

__all__ = [
    "POLE_TOL",
    "ArmPoints",
    "ElbowFrame",
    "arm_points",
    "elbow_frame",
    "pole_angle",
    "pole_turns",
    "pole_search",
    "pole_verdict",
]

T = TypeVar("T")

POLE_TOL = 1e-6
"""[rad]: a pole within this angle of the elbow's plane counts as honoured."""


class ArmPoints(NamedTuple):
    """The shoulder, elbow and wrist points ``(3,)`` [m] of an arm, in the world."""

    shoulder: NDArray[np.float64]
    elbow: NDArray[np.float64]
    wrist: NDArray[np.float64]


def _elbow_index(chain: Chain, anchors: NDArray[np.float64]) -> int:
    """The elbow's index in the chain (see the module's rules)."""
    # imported here: the solvers' packages import this module
    from humanoid_ik.solvers.analytic.closed_form.geometry import arm_cache
    from humanoid_ik.solvers.analytic.two_link.geometry import limb_cache

    if arm_cache(chain).reason is None:
        return 3
    limb = limb_cache(chain)
    if limb.reason is None:
        return limb.k
    for i, j in enumerate(chain.joint_ids):
        if "elbow" in name_words(chain.model.joint(int(j)).name):
            return i
    far = np.minimum(
        np.linalg.norm(anchors - anchors[0], axis=1), np.linalg.norm(anchors - anchors[-1], axis=1)
    )
    return int(np.argmax(far))


def _centre(anchors: NDArray[np.float64], axes: NDArray[np.float64]) -> NDArray[np.float64]:
    """The point nearest every axis line (the mean anchor where they are parallel)."""
    if len(anchors) < 2:
        return anchors[0].copy()
    p = axes_meeting_point(anchors, axes, tol=math.inf)
    return anchors.mean(axis=0) if p is None else p


class ElbowFrame:
    """A chain's elbow, read once at zero (kept with the chain, :func:`elbow_frame`).

    Attributes:
        elbow: the elbow joint's index in the chain.
        base_body: the body the chain's first joint's body hangs from.
        shoulder_local: the shoulder point in that body's frame ``(3,)`` [m].
        wrist_local: the wrist point in the end frame ``(3,)`` [m].
    """

    def __init__(self, chain: Chain):
        zero = np.zeros(chain.n)
        anchors, axes = chain.joint_axes_at(zero)
        k = self.elbow = _elbow_index(chain, anchors)
        S = _centre(anchors[:k], axes[:k]) if k > 0 else anchors[0].copy()
        after = slice(k + 1, chain.n)
        keep = chain.q
        chain.set_q(zero)
        W = _centre(anchors[after], axes[after]) if k + 1 < chain.n else chain.position.copy()
        m, d = chain.model, chain.data
        self.base_body = int(m.body_parentid[m.jnt_bodyid[int(chain.joint_ids[0])]])
        Rb, pb = d.xmat[self.base_body].reshape(3, 3), d.xpos[self.base_body]
        self.shoulder_local = Rb.T @ (S - pb)
        self.wrist_local = chain.rotation.T @ (W - chain.position)
        chain.set_q(keep)

    def points(self, chain: Chain, data: mujoco.MjData | None = None) -> ArmPoints:
        """The points at the kinematics of ``data`` (default: the chain's scratch data)."""
        d = chain.data if data is None else data
        Rb = d.xmat[self.base_body].reshape(3, 3)
        S = d.xpos[self.base_body] + Rb @ self.shoulder_local
        E = np.array(d.xanchor[int(chain.joint_ids[self.elbow])])
        if chain.ee_kind == "site":
            p, R = d.site_xpos[chain.ee_id], d.site_xmat[chain.ee_id].reshape(3, 3)
        else:
            p, R = d.xpos[chain.ee_id], d.xmat[chain.ee_id].reshape(3, 3)
        return ArmPoints(S, E, p + R @ self.wrist_local)


def elbow_frame(chain: Chain) -> ElbowFrame:
    """The chain's :class:`ElbowFrame` (read on the first call, then kept)."""
    return chain.derived("elbow_frame", ElbowFrame)


def arm_points(chain: Chain, q: ArrayLike | None = None) -> ArmPoints:
    """The shoulder, elbow and wrist points of the chain at ``q`` (default: its current
    joints; with ``q`` the scratch data is left at ``q``)."""
    if q is not None:
        chain.set_q(chain.check_q(q))
    return elbow_frame(chain).points(chain)


def _normal_part(v: NDArray[np.float64], u: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The unit part of ``v`` normal to unit ``u`` (``None`` where ``v`` lies along ``u``)."""
    p = v - float(v @ u) * u
    r = float(np.linalg.norm(p))
    return None if r < 1e-12 * max(1.0, float(np.linalg.norm(v))) else p / r


def pole_angle(points: ArmPoints, pole: ArrayLike) -> float:
    """The angle [rad] in ``[0, pi]`` between the half-plane of the elbow and that of
    ``pole`` about the shoulder-wrist line: 0 when the pole lies in the elbow's plane on
    its side. NaN where it is not defined (a straight arm, a pole on the line)."""
    S, E, W = points
    line = W - S
    nl = float(np.linalg.norm(line))
    if nl < 1e-12:
        return math.nan
    u = line / nl
    a = _normal_part(E - S, u)
    b = _normal_part(np.asarray(pole, dtype=np.float64) - S, u)
    if a is None or b is None:
        return math.nan
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b))


def pole_turns(points: ArmPoints, axis: ArrayLike, pole: ArrayLike) -> list[float]:
    """The turns [rad] of the arm about the unit ``axis`` through its shoulder that put
    ``pole`` into the elbow's half-plane (the swivel or twist that honours the pole,
    less the arm's own), smallest first; the one turn that brings it nearest where
    none does.

    The plane's normal ``m = (W - S) x (E - S)`` turns with the arm, so the pole lies in
    the plane where ``p . Rot(n, d) m = A + B cos d + C sin d = 0`` (``p = pole - S``):
    two roots. Where the wrist point lies on the axis (a pose target's swivel) one of
    them has the elbow on the pole's side; where it does not (a position target, the
    wrist held) both may, and both are returned.
    """
    S, E, W = points
    n = np.asarray(axis, dtype=np.float64)
    p = np.asarray(pole, dtype=np.float64) - S
    m = np.cross(W - S, E - S)
    mn = float(m @ n)
    mp = m - mn * n
    A, B, C = float(p @ n) * mn, float(p @ mp), float(p @ np.cross(n, mp))
    R = math.hypot(B, C)
    if R < 1e-15:
        return [0.0]
    phi = math.atan2(C, B)
    x = max(-1.0, min(1.0, -A / R))
    scored = []
    for d in (phi + math.acos(x), phi - math.acos(x)):
        Rd = axis_angle_matrix(n, d)
        got = pole_angle(ArmPoints(S, S + Rd @ (E - S), S + Rd @ (W - S)), S + p)
        d = math.atan2(math.sin(d), math.cos(d))
        scored.append((math.pi if math.isnan(got) else got, abs(d), d))
    scored.sort()
    keep = [d for a, _, d in scored if a <= POLE_TOL]
    return sorted(keep, key=abs) if keep else [scored[0][2]]


def pole_search(
    chain: Chain,
    solve: Callable[[float], T],
    shoulder: ArrayLike,
    frame: tuple[ArrayLike, ArrayLike, ArrayLike],
    pole: NDArray[np.float64],
    tries: int = 4,
) -> tuple[T, float, float] | None:
    """The answer of ``solve(psi)`` (a swivel or twist [rad] about ``n`` of ``frame =
    (n, r, k)``, 0 toward ``r``) that honours ``pole``, searched from the pole's own
    angle about ``n`` seen from ``shoulder``; ``None`` where the pole lies on that line.

    ``solve`` leaves the chain at its answer. Each answer's :func:`pole_turns` give the
    swivels that would put the pole in its plane (exact while the elbow branch stays:
    the arm turns rigidly about ``n``); they are solved in turn until one is honoured
    (within :data:`POLE_TOL`) or ``tries`` solves are spent.

    Returns:
        ``(answer, its swivel asked for, its pole_angle)``, the nearest found.
    """
    n, r, k = (np.asarray(v, dtype=np.float64) for v in frame)
    p = pole - np.array(shoulder)
    x, y = float(p @ r), float(p @ k)
    if math.hypot(x, y) < 1e-12 * max(1.0, float(np.linalg.norm(p))):
        return None
    first = math.atan2(y, x)
    arm = elbow_frame(chain)
    res = solve(first)
    pts = arm.points(chain)
    err = pole_angle(pts, pole)
    best = (res, first, math.pi if math.isnan(err) else err)
    tried = [first]
    queue: list[tuple[ArmPoints, float]] = []
    fresh: ArmPoints | None = pts  # an answer whose turns are not yet queued
    while best[2] > POLE_TOL and len(tried) < tries:
        if fresh is not None:
            queue += [(fresh, d) for d in pole_turns(fresh, n, pole)]
            fresh = None
        if not queue:
            break
        pts, d = queue.pop(0)
        e = pts.elbow - pts.shoulder
        want = math.atan2(float(e @ k), float(e @ r)) + d
        want = math.atan2(math.sin(want), math.cos(want))
        if any(abs(math.remainder(want - t, 2.0 * math.pi)) < 1e-9 for t in tried):
            continue
        tried.append(want)
        res = solve(want)
        got = arm.points(chain)
        err = pole_angle(got, pole)
        err = math.pi if math.isnan(err) else err
        if err < best[2]:
            best = (res, want, err)
        if err > POLE_TOL:
            fresh = got
    return best


def pole_verdict(err: float, status: Status, otherwise: str) -> str:
    """``details["pole"]`` of an answer at ``err`` [rad] from its pole: ``honoured``, not
    honoured where the target is unreachable, else ``otherwise`` (why not)."""
    if err <= POLE_TOL:
        return "honoured"
    return "not honoured: the target is unreachable" if status is Status.UNREACHABLE else otherwise
