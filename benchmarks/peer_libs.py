"""The libraries of ``benchmarks/peers.py``, each made ready for one chain: a
:class:`PeerRun` (its solve of one target from the chain's home pose, and its FK's gap
to MuJoCo's), or the reason it does not run there.

- **Ours**: a solver by registry name, made and prepared once; ``solve_auto``: the
  convenience call ``solve(chain, target, "auto", q0=start)``.
- **TRAC-IK** (``pytracik``, solve type Speed, epsilon 1e-5) and **IKPy** on our URDF
  of the chain (``outputs/urdf.py``); a **plain mink loop** (``mink_step.py``).
- **roboticstoolbox-python** (``rtb``): its compiled ``ik_LM`` / ``ik_NR`` on an ETS of
  the chain, built from MuJoCo's hinge anchors and axes at zero joint values: per hinge
  one constant ``SE3`` (to a frame whose z is the hinge axis) and one ``Rz``, the
  elements its URDF reader gives a URDF whose axes lie along a coordinate axis; then the
  end-effector frame as one more ``SE3``. Not our chain URDF through its reader: for an
  axis off the coordinate axes (UR5's ``wrist_2`` is off by 1e-11 in the world frame) it
  rotates the joint frame by 1 rad about the axis instead of onto it, so its FK is 0.1 m
  off. Unlimited hinges get ``[-pi, pi]`` (what its URDF reader gives a ``continuous``
  joint; no pose is lost). Joint limits on (``joint_limits=True``), its other defaults
  (``ilimit`` 30, ``slimit`` 100 random restarts); its ``tol`` bounds the residual
  ``E = e'e / 2`` (``e``: position [m] and angle-axis [rad] error), so the default 1e-6
  accepts answers 1.4 mm off; the ``_tight`` rows use :data:`TIGHT_TOL`.
- **EAIK** (analytic, by subproblem decomposition): a robot of axes ``H`` and offsets
  ``P`` at zero joint values (MuJoCo's, in the world frame) and the end-effector
  rotation at zero; of all its solutions of a pose, the answer is the one nearest the
  start inside the ranges (least-squares ones only where no exact one is). EAIK
  returns angles in ``[-pi, pi]``: ``eaik`` moves each joint by the multiple of 2 pi
  that brings it nearest the start inside its range (a wide range, UR5's ``[-2 pi,
  2 pi]``, or one off zero, Kinova's ``[0.82, 5.46]``), ``eaik_raw`` takes the angles
  as EAIK gives them. A 7-hinge arm is solved with one joint locked (the first or last
  joint where EAIK knows the locked arm's decomposition, else another it knows): at the
  start's value, then at that value plus and minus 1, 2, ... times :data:`LOCK_STEP`
  inside its range (at most pi away), until one gives an exact answer inside the
  ranges. Its iterations are
  its calls; the CPU time of its calls alone is kept apart from that of the pick.

Each peer's FK is compared with MuJoCo's at :data:`FK_POSES` random in-range joint
vectors (:func:`fk_gap`) before anything is timed.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.core.types import Target
from humanoid_ik.experiments.bench import not_reaching
from humanoid_ik.outputs.atomic import write_text
from humanoid_ik.outputs.urdf import BASE_LINK
from humanoid_ik.solvers import make_solver
from humanoid_ik.solvers.one_call import solve

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mink_step import PlainMinkLoop  # noqa: E402  (the one plain mink loop)

Vec = NDArray[np.float64]
Solve = Callable[[Target], tuple[Vec, float | None]]
"""One library's solve of one target: joint values and iterations (``None``: not
reported)."""


@dataclass
class PeerRun:
    """One library made ready for a target list: its solve, the largest gap of its FK
    to MuJoCo's (``None``: it runs MuJoCo's), and, where the solve adds our own work
    around the library's call (EAIK: the pick among its solutions), the CPU time of the
    library's calls alone in each solve [s]."""

    solve: Solve
    fk_gap: float | None = None
    call_cpu: list[float] | None = None
    notes: dict[str, float] = field(default_factory=dict)


FK_TOL = 1e-9
"""A peer's FK agrees with MuJoCo's to this [m, and rotation matrix entries]."""
FK_POSES = 5
TWO_PI = 2 * math.pi
LOCK_STEP = 2 * math.pi / 64
"""Spacing of the locked joint's values in EAIK's sweep on a 7-hinge arm [rad]."""
TIGHT_TOL = 1e-10
"""roboticstoolbox's ``tol`` in the ``_tight`` rows (its default is 1e-6)."""


def pose_matrix(tgt: Target) -> Vec:
    """The ``(4, 4)`` homogeneous matrix of a target (identity rotation without one)."""
    T = np.eye(4)
    if tgt.quat is not None:
        T[:3, :3] = quat_to_mat(tgt.quat)
    T[:3, 3] = tgt.position
    return T


def fk_gap(
    chain: Chain,
    fk: Callable[[Vec], Vec],
    seed: int = 12345,
    lock: tuple[int, float] | None = None,
) -> float:
    """Largest difference between ``fk(q)`` (a ``(4, 4)`` matrix) and MuJoCo's FK of the
    chain over :data:`FK_POSES` random in-range ``q`` (position [m] and rotation
    entries), joint ``lock[0]`` at ``lock[1]`` where given; the chain is left at home."""
    rng, gap = np.random.default_rng(seed), 0.0
    for _ in range(FK_POSES):
        q = chain.random_q(rng)
        if lock is not None:
            q[lock[0]] = lock[1]
        p, R = chain.fk(q)
        T = np.asarray(fk(q), dtype=np.float64)
        gap = max(gap, float(np.abs(T[:3, 3] - p).max()), float(np.abs(T[:3, :3] - R).max()))
    chain.reset()
    return gap


def zero_pose(chain: Chain) -> tuple[Vec, Vec, Vec, Vec]:
    """Hinge anchors ``(n, 3)``, unit axes ``(n, 3)``, end-effector position and
    rotation, all in the world frame with the chain at zero (the rest at home)."""
    chain.reset()
    anchors, axes = chain.joint_axes_at(np.zeros(chain.n))
    p0, R0 = chain.fk(np.zeros(chain.n))
    chain.reset()
    return anchors, axes, p0, R0


def setup_ours(name: str, chain: Chain, pose: bool) -> PeerRun | str:
    """One of our solvers by registry name, made and prepared once (``solve_auto``: the
    ``solve()`` call with ``"auto"`` on every target), or why it does not apply."""
    solver = make_solver("auto" if name == "solve_auto" else name)
    reason = not_reaching(solver, chain, pose)
    if reason is not None:
        return reason
    start = chain.q_home.copy()
    if name == "solve_auto":

        def call(tgt: Target) -> tuple[Vec, float | None]:
            res = solve(chain, tgt, "auto", q0=start)
            return res.q, res.iterations

        return PeerRun(call)
    solver.prepare(chain)

    def one(tgt: Target) -> tuple[Vec, float | None]:
        res = solver.solve(chain, tgt, start)
        return res.q, res.iterations

    return PeerRun(one)


def _fk_matrix(T: Any) -> Vec:
    return np.asarray(T, dtype=np.float64).reshape(4, 4)


def setup_trac_ik(chain: Chain, urdf: str, timeout: float, pose: bool) -> PeerRun | str:
    """TRAC-IK (pytracik, solve type Speed, epsilon 1e-5) with ``timeout`` [s]."""
    if not pose:
        return "pose targets only (pytracik has no position-only call)"
    try:
        import pytracik
    except ImportError:
        return "pytracik not installed (pip install -e '.[bench-peers]')"
    ik = pytracik.TRAC_IK(BASE_LINK, chain.ee_name, urdf, timeout, 1e-5, pytracik.SolveType.Speed)
    start = chain.q_home.copy()
    gap = fk_gap(chain, lambda q: _fk_matrix(pytracik.fk(ik, q)))

    def one(tgt: Target) -> tuple[Vec, float | None]:
        assert tgt.quat is not None
        w, x, y, z = tgt.quat
        p = tgt.position
        r = pytracik.ik(ik, start, p[0], p[1], p[2], x, y, z, w)
        return (np.asarray(r[1:], dtype=np.float64) if r[0] >= 0 else start), None

    return PeerRun(one, gap)


def setup_mink_plain(chain: Chain, pose: bool) -> PeerRun | str:
    """The plain mink loop of ``benchmarks/mink_step.py`` (our mink solver's defaults)."""
    from humanoid_ik.solvers.mink import MinkOptions

    chain.reset()
    loop = PlainMinkLoop(chain, MinkOptions(), pose)
    return PeerRun(lambda t: loop.solve(t))


def setup_ikpy(chain: Chain, urdf: str) -> PeerRun | str:
    """IKPy (its default optimiser) on the URDF, from the same start."""
    try:
        from ikpy.chain import Chain as IKPyChain
    except ImportError:
        return "ikpy not installed (pip install -e '.[bench-peers]')"
    with tempfile.TemporaryDirectory() as tmp:
        path = write_text(Path(tmp) / "arm.urdf", urdf)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ik = IKPyChain.from_urdf_file(
                str(path),
                base_elements=[BASE_LINK],
                active_links_mask=[False] + [True] * chain.n + [False],
            )
    init = np.concatenate([[0.0], chain.q_home, [0.0]])
    gap = fk_gap(chain, lambda q: ik.forward_kinematics(np.concatenate([[0.0], q, [0.0]])))

    def one(tgt: Target) -> tuple[Vec, float | None]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if tgt.quat is None:
                q = ik.inverse_kinematics(tgt.position, initial_position=init)
            else:
                q = ik.inverse_kinematics(
                    tgt.position,
                    quat_to_mat(tgt.quat),
                    orientation_mode="all",
                    initial_position=init,
                )
        return np.asarray(q[1:-1], dtype=np.float64), None

    return PeerRun(one, gap)


def _z_frame(axis: Vec) -> Vec:
    """A rotation whose third column is ``axis``."""
    t = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(t, axis)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(axis, x), axis])


def _se3(R: Vec, p: Vec) -> Vec:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def rtb_ets(chain: Chain):  # -> roboticstoolbox.ETS
    """The chain as a roboticstoolbox ETS (see the module's docstring)."""
    from roboticstoolbox import ET, ETS

    anchors, axes, p0, R0 = zero_pose(chain)
    M_prev, a_prev, ets = np.eye(3), np.zeros(3), ETS()
    for i in range(chain.n):
        M = _z_frame(axes[i])
        lo, hi = float(chain.lower[i]), float(chain.upper[i])
        qlim = [lo if math.isfinite(lo) else -math.pi, hi if math.isfinite(hi) else math.pi]
        fixed = _se3(M_prev.T @ M, M_prev.T @ (anchors[i] - a_prev))
        ets = ets * ET.SE3(fixed) * ET.Rz(qlim=qlim)
        M_prev, a_prev = M, anchors[i]
    return ets * ET.SE3(_se3(M_prev.T @ R0, M_prev.T @ (p0 - a_prev)))


def setup_rtb(chain: Chain, method: str, tol: float, pose: bool) -> PeerRun | str:
    """roboticstoolbox's ``ik_LM`` or ``ik_NR`` with ``tol``, from the chain's home
    pose: the solve and its FK gap, or why it does not run."""
    try:
        import roboticstoolbox  # noqa: F401
    except ImportError:
        return "roboticstoolbox-python not installed (pip install -e '.[bench-peers]')"
    if not pose:
        return "pose targets only (in this benchmark)"
    ets = rtb_ets(chain)
    gap = fk_gap(chain, ets.eval)
    ik = ets.ik_LM if method == "lm" else ets.ik_NR
    start = chain.q_home.copy()

    def one(tgt: Target) -> tuple[Vec, float | None]:
        sol = ik(pose_matrix(tgt), q0=start, tol=tol, joint_limits=True)
        return np.asarray(sol.q, dtype=np.float64), float(sol.iterations)

    return PeerRun(one, gap)


def nearest_in_range(Q: Vec, start: Vec, lo: Vec, hi: Vec, shift: bool) -> Vec | None:
    """Of the solutions ``Q (k, n)``, the one nearest ``start`` inside ``[lo, hi]``
    (to 1e-9 rad), each joint first moved by the multiple of 2 pi that brings it
    nearest the start inside its range when ``shift``; ``None`` when none is inside."""
    lo, hi = lo - 1e-9, hi + 1e-9
    if shift:
        Q = Q + TWO_PI * np.round((start - Q) / TWO_PI)
        Q -= TWO_PI * (Q > hi)
        Q += TWO_PI * (Q < lo)
    inside = ((Q >= lo) & (Q <= hi)).all(axis=1)
    if not inside.any():
        return None
    Q = Q[inside]
    return Q[int(np.argmin(np.abs(Q - start).sum(axis=1)))]


def _eaik_robot(H: Vec, P: Vec, R0: Vec, lock: list[tuple[int, float]]):
    import eaik.pybindings.EAIK as EAIK

    return EAIK.Robot(H.T.copy(), P.T.copy(), R0, lock, True)


def lock_joint(chain: Chain) -> int | None:
    """The joint EAIK locks on a 7-hinge chain: the first, else the last, else another,
    whose locking leaves an arm EAIK knows a decomposition of; ``None`` if none does."""
    anchors, axes, p0, R0 = zero_pose(chain)
    P = np.vstack([anchors[0], np.diff(anchors, axis=0), p0 - anchors[-1]])
    order = [0, chain.n - 1, *range(1, chain.n - 1)]
    for k in order:
        try:
            if _eaik_robot(axes, P, R0, [(k, 0.0)]).has_known_decomposition():
                return k
        except RuntimeError:  # its remodelling fails on some locked arms (Baxter's)
            continue
    return None


def setup_eaik(chain: Chain, shift: bool, pose: bool) -> PeerRun | str:
    """EAIK on the chain (see the module's docstring): the solve (its iterations: the
    number of EAIK calls) and its FK gap, or why it does not run."""
    try:
        import eaik.pybindings.EAIK  # noqa: F401
    except ImportError:
        return "eaik not installed (pip install -e '.[bench-peers]')"
    if not pose:
        return "pose targets only (an analytic solver of poses)"
    if chain.n > 7:
        return f"EAIK solves up to 6 joints, or 7 with one locked; the chain has {chain.n}"
    anchors, axes, p0, R0 = zero_pose(chain)
    P = np.vstack([anchors[0], np.diff(anchors, axis=0), p0 - anchors[-1]])
    start, lo, hi = chain.q_home.copy(), chain.lower.copy(), chain.upper.copy()
    notes: dict[str, float] = {}
    if chain.n <= 6:
        try:
            robots = [_eaik_robot(axes, P, R0, [])]
        except RuntimeError as e:
            return f"EAIK cannot model this arm ({e})"
        if not robots[0].has_known_decomposition():
            return f"EAIK knows no decomposition of this arm ({robots[0].get_kinematic_family()})"
        gap = fk_gap(chain, robots[0].fwdkin)
    else:
        k = lock_joint(chain)
        if k is None:
            return "EAIK knows no decomposition of this arm, nor with any one joint locked"
        s0 = float(np.clip(start[k], lo[k], hi[k]))
        lo_k, hi_k = max(float(lo[k]), s0 - math.pi), min(float(hi[k]), s0 + math.pi)
        steps = [i * sign for i in range(1, int(math.pi / LOCK_STEP) + 1) for sign in (1, -1)]
        values = [s0, *(s0 + i * LOCK_STEP for i in steps if lo_k <= s0 + i * LOCK_STEP <= hi_k)]
        robots = [_eaik_robot(axes, P, R0, [(k, float(v))]) for v in values]
        gap = fk_gap(chain, robots[0].fwdkin, lock=(k, s0))
        notes = {"locked_joint": float(k), "lock_values": float(len(values))}

    call_cpu: list[float] = []
    clock = time.process_time

    def one(tgt: Target) -> tuple[Vec, float | None]:
        T, fallback, spent = pose_matrix(tgt), None, 0.0
        try:
            for calls, robot in enumerate(robots, 1):
                c0 = clock()
                sol = robot.calculate_IK(T)
                spent += clock() - c0
                Q, ls = sol.Q, sol.is_LS
                if len(Q) == 0:
                    continue
                if not ls.all():
                    best = nearest_in_range(Q[~ls], start, lo, hi, shift)
                    if best is not None:
                        return best, float(calls)
                if fallback is None and ls.any():
                    fallback = nearest_in_range(Q[ls], start, lo, hi, shift)
            return (start if fallback is None else fallback), float(len(robots))
        finally:
            call_cpu.append(spent)

    return PeerRun(one, gap, call_cpu, notes)


def setup_peer(peer: str, chain: Chain, urdf: str, pose: bool) -> PeerRun | str:
    """A peer by name (not dm_control, which runs in its own venv)."""
    if peer.startswith("trac_ik_"):
        return setup_trac_ik(chain, urdf, 0.005 if peer == "trac_ik_5ms" else 0.05, pose)
    if peer == "mink_plain":
        return setup_mink_plain(chain, pose)
    if peer == "ikpy":
        return setup_ikpy(chain, urdf)
    if peer.startswith("rtb_"):
        tol = TIGHT_TOL if peer.endswith("_tight") else 1e-6
        return setup_rtb(chain, "lm" if peer.startswith("rtb_lm") else "nr", tol, pose)
    assert peer in ("eaik", "eaik_raw"), peer
    return setup_eaik(chain, peer == "eaik", pose)
