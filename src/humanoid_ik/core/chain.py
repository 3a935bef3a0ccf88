"""A kinematic chain of hinge joints on a robot: a light view over its state.

MuJoCo is the single source of truth for where things are: the chain writes ``qpos``,
runs ``mj_kinematics`` and reads ``site_xpos``/``site_xmat`` (or ``xpos``/``xmat`` for a
body end effector) and ``mj_jacSite``/``mj_jacBody``. The chain owns no ``MjData`` and
no buffer: it works in its :class:`~humanoid_ik.core.robot.Robot`'s one scratch state,
which every chain of that robot shares. The caller's ``MjData`` is read with
:meth:`Chain.load` and only written by :meth:`Chain.apply`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Hashable, Sequence
from typing import Any, TypeVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.checks import float_array
from humanoid_ik.core.model_checks import check_ranges
from humanoid_ik.core.models import home_qpos
from humanoid_ik.core.mujoco_warnings import mujoco_warnings
from humanoid_ik.core.robot import Robot, joint_name, names
from humanoid_ik.errors import (
    ChainError,
    ModelError,
    NameNotFoundError,
    TargetError,
    UnsupportedJointError,
)

__all__ = ["Chain", "DEFAULT_SITE", "REACH_METHOD", "REACH_SAMPLES", "REACH_STARTS", "end_bodies"]

T = TypeVar("T")

DEFAULT_SITE = "right_palm_site"
REACH_SAMPLES = 500
"""How many seeded random joint vectors inside the ranges :meth:`Chain.reach` samples."""
REACH_STARTS = 3
"""How many of the farthest samples it refines by gradient ascent."""
REACH_METHOD = f"sampled, {REACH_SAMPLES} poses"
"""How :meth:`Chain.reach` finds the reach, as reports print it."""
_REACH_SEED = 0
_JOINT_TYPE_NAMES = {int(t): k[6:].lower() for k, t in mujoco.mjtJoint.__members__.items()}


def _check_args(site: Any, body: Any, joints: Any) -> None:
    """One :class:`ChainError` for an end effector or joint list of the wrong type."""
    for what, value in (("site", site), ("body", body)):
        if value is not None and not isinstance(value, str):
            raise ChainError(f"{what} must be a name (a string), got {value!r}")
    if joints is None or isinstance(joints, str):
        return
    if not isinstance(joints, Sequence) or not all(isinstance(j, str) for j in joints):
        raise ChainError(f"joints must be a list of joint names, got {joints!r}")


def end_bodies(model: mujoco.MjModel) -> list[str]:
    """Named bodies without child bodies that a joint moves, in model order: the end
    effectors a model without sites offers (``--body NAME``)."""
    parents = set(model.body_parentid[1:].tolist())
    found = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)]
    return [n for b, n in enumerate(found) if n and b not in parents and model.body_weldid[b]]


def _no_default_site(model: mujoco.MjModel) -> NameNotFoundError:
    """The error of a chain on a model without the default site: it points at ``--body``
    and names a few bodies that could be end effectors."""
    sites = names(model, mujoco.mjtObj.mjOBJ_SITE, model.nsite)
    err, ends = NameNotFoundError("site", DEFAULT_SITE, sites), end_bodies(model)
    shown = ", ".join(ends[:8]) + (f" (and {len(ends) - 8} more)" if len(ends) > 8 else "")
    err.args = (
        f"{err} (the default end effector); name one with --body NAME (body=NAME) or --site "
        f"NAME (site=NAME); bodies at the end of a hinge chain: {shown or '(none)'}",
    )
    return err


class Chain:
    """Hinge joints from a root to an end-effector site or body, on a robot's state.

    Args:
        model: a :class:`~humanoid_ik.core.robot.Robot` (the chain shares its state with
            the robot's other chains), or an ``MjModel``, an MJCF/URDF path or ``None``
            for the bundled humanoid (the chain then gets a robot state of its own; an
            MJCF string: :meth:`from_xml_string`).
        site: end-effector site name (default ``right_palm_site`` when ``body`` is unset).
        joints: joint names; by default the hinge joints on the path from the end
            effector's body to the root, stopping at a free joint.
        body: end-effector body name, instead of a site.

    Raises:
        ModelError, NameNotFoundError, UnsupportedJointError, ChainError.

    Attributes:
        robot: the robot state the chain works in (``model`` and ``data`` are its).
        joint_ids, joint_names, qpos_adr, dof_adr: the chain's joints, in dof order.
        n: the number of joints.
        ee_kind, ee_id, ee_name: the end effector (``"site"`` or ``"body"``).
        key: ``(ee_kind, ee_id, joint ids)``, what makes two chains of a robot the same.
    """

    def __init__(
        self,
        model: Robot | mujoco.MjModel | str | os.PathLike | None = None,
        site: str | None = None,
        joints: Sequence[str] | None = None,
        *,
        body: str | None = None,
    ):
        _check_args(site, body, joints)
        self.robot = model if isinstance(model, Robot) else Robot(model)
        m = self.model = self.robot.model
        if site is not None and body is not None:
            raise ChainError("give an end-effector site or a body, not both")
        if body is not None:
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
            if bid < 0:
                raise NameNotFoundError("body", body, names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody))
            self.ee_kind, self.ee_id, self.ee_name = "body", bid, body
            ee_body = bid
        else:
            default, site = site is None, DEFAULT_SITE if site is None else site
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
            if sid < 0 and default:
                raise _no_default_site(m)
            if sid < 0:
                raise NameNotFoundError("site", site, names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite))
            self.ee_kind, self.ee_id, self.ee_name = "site", sid, site
            ee_body = int(m.site_bodyid[sid])
        path_joints = self._path_joints(ee_body)
        self.path_joint_ids = np.array(path_joints, dtype=np.int64)
        """Every joint between the end effector's body and the world, tip first (the
        chain's joints among them)."""
        if joints is None:
            ids = self._default_joints(path_joints)
        else:
            ids = self._named_joints(joints, path_joints)
        if not ids:
            raise ChainError(f"no hinge joint moves {self.ee_kind} '{self.ee_name}'")
        ids.sort(key=lambda j: int(m.jnt_dofadr[j]))
        self.joint_ids = np.array(ids, dtype=np.int64)
        self.n = len(ids)  # read by every solve: an attribute, not a property (0.2 us)
        self.joint_names = [joint_name(m, j) for j in ids]
        self.qpos_adr = m.jnt_qposadr[self.joint_ids].astype(np.int64)
        self.dof_adr = m.jnt_dofadr[self.joint_ids].astype(np.int64)
        self.key: tuple[str, int, tuple[int, ...]] = (self.ee_kind, self.ee_id, tuple(ids))
        dofs = self.dof_adr
        contiguous = bool(np.all(np.diff(dofs) == 1))
        # chain columns: a view of the robot's buffer when the dofs are contiguous
        self.dof_slice = slice(int(dofs[0]), int(dofs[-1]) + 1) if contiguous else None
        """The chain's columns of the robot's Jacobian as a slice (``None``: not contiguous)."""
        # a view of the robot's buffer (never reallocated), so made once
        self._columns = None if self.dof_slice is None else self.robot.jac[:, self.dof_slice]
        self._base_qpos = self._qpos_off_chain()
        self._base_mocap = int(m.body_mocapid[m.body_rootid[ee_body]])  # -1: no mocap base
        self._limits_version = -1
        self._read_ranges()

    # ----------------------------------------------------------------- the live model
    def _read_ranges(self) -> None:
        m = self.model
        limited = m.jnt_limited[self.joint_ids].astype(bool)
        rng = m.jnt_range[self.joint_ids]
        self._lower = np.where(limited, rng[:, 0], -np.inf)
        self._upper = np.where(limited, rng[:, 1], np.inf)
        home = home_qpos(m)[self.qpos_adr]
        self._q_home = np.minimum(np.maximum(home, self._lower), self._upper)
        self._limits_version = self.robot.version

    @property
    def lower(self) -> NDArray[np.float64]:
        """Lower joint limits ``(n,)`` [rad] (``-inf`` for an unlimited joint), read from
        the live model (followed after :meth:`sync`)."""
        if self._limits_version != self.robot.version:
            self._read_ranges()
        return self._lower

    @property
    def upper(self) -> NDArray[np.float64]:
        """Upper joint limits ``(n,)`` [rad] (``inf`` for an unlimited joint)."""
        if self._limits_version != self.robot.version:
            self._read_ranges()
        return self._upper

    @property
    def q_home(self) -> NDArray[np.float64]:
        """Chain joints at the ``home`` keyframe if there is one, else ``qpos0``, inside
        the ranges ``(n,)`` [rad]."""
        if self._limits_version != self.robot.version:
            self._read_ranges()
        return self._q_home

    @property
    def data(self) -> mujoco.MjData:
        """The robot's scratch ``MjData``, shared with its other chains."""
        return self.robot.data

    @property
    def version(self) -> int:
        """The robot's :attr:`~humanoid_ik.core.robot.Robot.version`: a cache held
        outside compares it to know whether it is still current."""
        return self.robot.version

    def sync(self) -> bool:
        """Follow changes made to the live ``MjModel`` (see :meth:`Robot.sync`): the
        ranges and the home pose are re-read, every :meth:`derived` cache dropped.

        Returns:
            True when the model had changed.
        """
        return self.robot.sync()

    def refresh(self) -> None:
        """Re-read everything taken from the model and drop the caches derived from it."""
        self.robot.refresh()

    def claim(self) -> None:
        """Mark the chain's robot busy for one solve (:meth:`release` ends it).

        A robot holds one scratch state, so it serves one thread at a time: give each
        thread its own robot (or ``Chain``, which makes one), or guard a shared one.

        Raises:
            ChainError: another thread is solving on this robot right now.
        """
        self.robot.claim()

    def release(self) -> None:
        """End the solve that :meth:`claim` began."""
        self.robot.release()

    def _qpos_off_chain(self) -> slice | NDArray[np.int64] | None:
        """``qpos`` addresses of the path's joints outside the chain (a floating base, a
        torso hinge): a slice where they follow each other, ``None`` when there is none."""
        m = self.model
        mine = set(self.joint_ids.tolist())
        sizes = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}
        idx: list[int] = []
        for j in self.path_joint_ids.tolist():
            if j not in mine:
                start = int(m.jnt_qposadr[j])
                idx += range(start, start + sizes.get(int(m.jnt_type[j]), 1))
        if not idx:
            return None
        idx.sort()
        if idx[-1] - idx[0] == len(idx) - 1:
            return slice(idx[0], idx[-1] + 1)
        return np.array(idx, dtype=np.int64)

    def base_state(self) -> list[float] | None:
        """The scratch ``qpos`` of the path's joints outside the chain and the pose of a
        mocap body the path hangs from, which move the chain's base (``None``: nothing
        does): what a cache of world-frame geometry compares to know it is current."""
        d, k = self.data, self._base_mocap
        state = None if self._base_qpos is None else d.qpos[self._base_qpos].tolist()
        if k < 0:
            return state
        return [*(state or ()), *d.mocap_pos[k].tolist(), *d.mocap_quat[k].tolist()]

    @classmethod
    def from_xml_string(
        cls,
        xml: str,
        site: str | None = None,
        joints: Sequence[str] | None = None,
        *,
        body: str | None = None,
    ) -> Chain:
        """A chain on a model compiled from an MJCF string (``MjModel.from_xml_string``).

        Args:
            xml: the MJCF document.
            site, joints, body: as for :class:`Chain`.

        Raises:
            ModelError: ``xml`` is not a string, MuJoCo cannot compile it (its message kept),
                or a joint's range is inverted (a zero-width one is locked, with a warning).
            NameNotFoundError, UnsupportedJointError, ChainError: as :class:`Chain`.
        """
        if not isinstance(xml, str):
            raise ModelError(f"MJCF must be a string of XML, got {type(xml).__name__}")
        try:
            with mujoco_warnings():  # MuJoCo's warnings: Python's, no MUJOCO_LOG.TXT
                model = mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            raise ModelError(f"MJCF string does not compile: {' '.join(str(exc).split())}") from exc
        check_ranges(model, "MJCF string", xml=xml)
        return cls(model, site, joints, body=body)

    def derived(self, key: Hashable, build: Callable[[Chain], T]) -> T:
        """A value derived from the chain's fixed kinematics, built by ``build(self)`` on
        the first call for ``key`` and kept in the robot's workspace (shared by equal
        chains of that robot) until the model changes.

        The rule: what is computed from the chain's joints and the model's kinematics alone
        (a solver's seed poses, its geometry) stays valid until the model changes, and
        :meth:`sync` (run by every solve) drops it then; ``build`` must leave the scratch
        data's joint values as it found them.
        """
        return self.robot.workspace((self.key, key), lambda: build(self))

    # ----------------------------------------------------------------- structure
    def _path_joints(self, body: int) -> list[int]:
        """Joints of the bodies from ``body`` up to the world, tip first."""
        m = self.model
        out: list[int] = []
        b = body
        while b > 0:
            start, num = int(m.body_jntadr[b]), int(m.body_jntnum[b])
            out.extend(range(start + num - 1, start - 1, -1))
            b = int(m.body_parentid[b])
        return out

    def _joint_desc(self, j: int) -> str:
        name = joint_name(self.model, j)
        return f"'{name}' ({_JOINT_TYPE_NAMES[int(self.model.jnt_type[j])]})"

    def _default_joints(self, path: list[int]) -> list[int]:
        ids = []
        for j in path:
            jt = int(self.model.jnt_type[j])
            if jt == mujoco.mjtJoint.mjJNT_FREE:
                break
            if jt != mujoco.mjtJoint.mjJNT_HINGE:
                raise UnsupportedJointError(
                    f"joint {self._joint_desc(j)} on the path of {self.ee_kind} "
                    f"'{self.ee_name}' is not a hinge; chains support hinge joints only "
                    "(pass --joints / joints= to choose the hinges)"
                )
            ids.append(j)
        return ids

    def _named_joints(self, wanted: Sequence[str], path: list[int]) -> list[int]:
        m = self.model
        if isinstance(wanted, str):
            wanted = [wanted]
        ids = []
        all_names = names(m, mujoco.mjtObj.mjOBJ_JOINT, m.njnt)
        for name in wanted:
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            if j < 0:
                raise NameNotFoundError("joint", name, all_names)
            if int(m.jnt_type[j]) != mujoco.mjtJoint.mjJNT_HINGE:
                raise UnsupportedJointError(
                    f"joint {self._joint_desc(j)} is not a hinge; chains support hinge joints only"
                )
            if j not in path:
                on_path = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, k) for k in path]
                raise ChainError(
                    f"joint '{name}' does not move {self.ee_kind} '{self.ee_name}'; joints on "
                    f"its path: {', '.join(n for n in on_path if n) or '(none)'}"
                )
            if j in ids:
                raise ChainError(f"joint '{name}' is listed twice")
            ids.append(j)
        return ids

    def reset(self) -> None:
        """The robot's scratch data to the home pose (:meth:`Robot.reset`), the chain's
        joints at :attr:`q_home`."""
        self.robot.reset()
        self.set_q(self.q_home)

    # ----------------------------------------------------------------- properties
    @property
    def q(self) -> NDArray[np.float64]:
        """Chain joint values in the scratch data ``(n,)`` [rad]."""
        return self.data.qpos[self.qpos_adr].copy()

    @property
    def position(self) -> NDArray[np.float64]:
        """End-effector position ``(3,)`` in [m] from the last kinematics pass (a view)."""
        if self.ee_kind == "site":
            return self.data.site_xpos[self.ee_id]
        return self.data.xpos[self.ee_id]

    @property
    def rotation(self) -> NDArray[np.float64]:
        """End-effector rotation ``(3, 3)`` from the last kinematics pass."""
        if self.ee_kind == "site":
            return self.data.site_xmat[self.ee_id].reshape(3, 3)
        return self.data.xmat[self.ee_id].reshape(3, 3)

    # ----------------------------------------------------------------- MuJoCo I/O
    def check_q(self, q: ArrayLike) -> NDArray[np.float64]:
        """``q`` as a finite float64 ``(n,)`` array.

        Raises:
            TargetError: wrong shape or NaN/inf.
        """
        arr = float_array("joint vector", q)
        if arr.shape != (self.n,):
            raise TargetError(f"joint vector must have shape ({self.n},), got {arr.shape}")
        if not np.isfinite(arr).all():
            raise TargetError(f"joint vector {arr.tolist()} is not finite")
        return arr

    def set_q(self, q: ArrayLike) -> None:
        """Write chain joints into the scratch ``qpos`` and run ``mj_kinematics``."""
        self.data.qpos[self.qpos_adr] = q
        mujoco.mj_kinematics(self.model, self.data)

    def fk(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """End-effector position ``(3,)`` [m] and rotation ``(3, 3)`` at ``q``, from MuJoCo."""
        self.set_q(self.check_q(q))
        return self.position.copy(), self.rotation.copy()

    def jacobian(self, q: ArrayLike | None = None) -> NDArray[np.float64]:
        """Geometric Jacobian ``(6, n)`` of the end effector: rows 0-2 linear velocity
        [m/rad], rows 3-5 angular velocity, both in the world frame (``mj_jacSite``)."""
        if q is not None:
            self.set_q(self.check_q(q))
        return self.current_jacobian().copy()

    def current_jacobian(self) -> NDArray[np.float64]:
        """The Jacobian ``(6, n)`` at the scratch data's current kinematics
        (``mj_kinematics`` must be current), in a buffer the robot reuses: a view of
        :attr:`Robot.jac` when the chain's dofs follow each other, else a gathered copy.
        Valid until the next call; the caller may overwrite it."""
        r = self.robot
        m, d = self.model, r.data
        mujoco.mj_comPos(m, d)
        if self.ee_kind == "site":
            mujoco.mj_jacSite(m, d, r.jacp, r.jacr, self.ee_id)
        else:
            mujoco.mj_jacBody(m, d, r.jacp, r.jacr, self.ee_id)
        if self._columns is not None:
            return self._columns
        J = r.buffer(("chain_jacobian", self.key), (6, self.n))
        np.take(r.jac, self.dof_adr, axis=1, out=J)
        return J

    def joint_axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World anchors ``(n, 3)`` and unit axes ``(n, 3)`` of the chain's hinges."""
        return (self.data.xanchor[self.joint_ids].copy(), self.data.xaxis[self.joint_ids].copy())

    def joint_axes_at(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World anchors ``(n, 3)`` and unit axes ``(n, 3)`` of the chain's hinges with the
        chain at ``q`` (the scratch data's joints are put back)."""
        keep = self.q
        self.set_q(self.check_q(q))
        anchors, axes = self.joint_axes()
        self.set_q(keep)
        return anchors, axes / np.linalg.norm(axes, axis=1, keepdims=True)

    @property
    def base(self) -> NDArray[np.float64]:
        """The chain's base point ``(3,)`` [m]: its first joint's anchor, from the last
        kinematics pass (a view)."""
        return self.data.xanchor[self.joint_ids[0]]

    def reach(self) -> tuple[NDArray[np.float64], float]:
        """The chain's base point ``(3,)`` [m] and its reach [m]: the largest distance from
        the base that the end effector attains with the joints inside their ranges.

        The base is the first joint's anchor at the current pose. The reach is sampled
        (:data:`REACH_METHOD`): MuJoCo FK at :data:`REACH_SAMPLES` seeded uniform joint
        vectors in the ranges (unlimited joints in [-pi, pi]), then projected gradient
        ascent on the distance from the :data:`REACH_STARTS` farthest, joints off the
        chain held. It is at most :meth:`reach_bound`, and that bound when within 0.01 %
        of it (the true reach lies between the two). Kept in the robot's workspace
        (:meth:`derived`) while the joints off the chain keep their values; the chain is
        left as it was.
        """
        return self.base.copy(), self._sampled()[0]

    def reach_mean(self) -> NDArray[np.float64]:
        """The mean offset ``(3,)`` [m] of the end effector from the base over the samples
        of :meth:`reach`: the side toward which the chain reaches."""
        return self._sampled()[1].copy()

    def reach_bound(self) -> float:
        """An upper bound of :meth:`reach` [m]: the length of the polyline through the
        distinct joint anchors to the end effector, ``sum |a_{k+1} - a_k| + |p - a_last|``
        (hinges keep these distances), attained only when the chain can straighten."""
        self.set_q(self.q)
        anchors, _ = self.joint_axes()
        pts = [anchors[0]]
        for a in anchors[1:]:
            if float(np.linalg.norm(a - pts[-1])) > 1e-9:
                pts.append(a)
        pts.append(self.position.copy())
        return float(sum(np.linalg.norm(b - a) for a, b in zip(pts[:-1], pts[1:], strict=True)))

    def _sampled(self) -> tuple[float, NDArray[np.float64]]:
        self.set_q(self.q)
        state = self.base_state()
        return self.derived(("reach", None if state is None else tuple(state)), _sample_reach)

    def _sample_box(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Where joint vectors are sampled: the ranges, ``[-pi, pi]`` for an unlimited joint."""
        lo = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        return lo, np.where(np.isfinite(self.upper), self.upper, math.pi)

    def load(self, data: mujoco.MjData) -> None:
        """Copy the caller's ``qpos`` (every joint) into the robot's scratch data
        (:meth:`Robot.load`). ``data`` is only read.

        Raises:
            ChainError: ``data`` belongs to another model.
        """
        self.robot.load(data)

    def check_data(self, data: mujoco.MjData) -> None:
        """Refuse an ``MjData`` made for another model (:meth:`Robot.check_data`).

        Raises:
            ChainError: ``data`` is not an ``MjData`` of a model like the chain's.
        """
        self.robot.check_data(data)

    def apply(self, q: ArrayLike, data: mujoco.MjData) -> None:
        """Write chain joints ``q`` into the caller's ``data`` and run ``mj_forward`` on it.

        Raises:
            ChainError: ``data`` belongs to another model (it is left unchanged).
            TargetError: a bad ``q``.
        """
        self.check_data(data)
        qq = self.check_q(q)
        data.qpos[self.qpos_adr] = qq
        mujoco.mj_forward(data.model, data)

    # ----------------------------------------------------------------- limits
    def clip(self, q: ArrayLike, out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """``q`` moved inside the joint ranges: a new array, or ``out`` (may be ``q``) written."""
        # np.minimum/np.maximum: np.clip's wrapper costs more than the clipping here
        low = np.maximum(np.asarray(q, dtype=np.float64), self.lower, out=out)
        return np.minimum(low, self.upper, out=low)

    def within_limits(self, q: ArrayLike, tol: float = 1e-9) -> bool:
        """True when every joint lies inside its range (with ``tol`` [rad])."""
        arr = np.asarray(q)
        return bool(np.all(arr >= self.lower - tol) and np.all(arr <= self.upper + tol))

    def limit_margin(self, q: ArrayLike) -> float:
        """Smallest distance [rad] of any joint to its nearest range end (negative outside)."""
        qs = np.asarray(q, dtype=np.float64).tolist()  # a few joints: plain floats are quicker
        m = math.inf  # the first smallest, as min(min(x - a, b - x) for ...) takes it
        for x, a, b in zip(qs, self.lower.tolist(), self.upper.tolist(), strict=True):
            below, above = x - a, b - x
            m = below if below < m else m
            m = above if above < m else m
        return m

    def random_q(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """A uniform joint vector inside the ranges (unlimited joints in [-pi, pi])."""
        return rng.uniform(*self._sample_box())

    def __repr__(self) -> str:
        return f"Chain({self.ee_kind}='{self.ee_name}', joints=[{', '.join(self.joint_names)}])"


def _sample_reach(chain: Chain) -> tuple[float, NDArray[np.float64]]:
    """``(reach [m], mean offset (3,) [m])`` of the end effector from the base, sampled as
    :meth:`Chain.reach` says; the chain is left as it was."""
    m, d, keep, base = chain.model, chain.data, chain.q, chain.base.copy()
    rng = np.random.default_rng(_REACH_SEED)
    qs = rng.uniform(*chain._sample_box(), size=(REACH_SAMPLES, chain.n))
    pts, xpos = np.empty((REACH_SAMPLES, 3)), d.site_xpos if chain.ee_kind == "site" else d.xpos
    for i, q in enumerate(qs):  # a plain loop: ~5-10 us a pose
        d.qpos[chain.qpos_adr] = q
        mujoco.mj_kinematics(m, d)
        pts[i] = xpos[chain.ee_id]
    offsets = pts - base
    dist = np.linalg.norm(offsets, axis=1)
    best = float(dist.max())
    for k in np.argsort(dist)[-REACH_STARTS:]:
        best = max(best, _climb(chain, base, qs[k], float(dist[k])))
    chain.set_q(keep)
    bound = chain.reach_bound()
    return (bound if best > bound * (1.0 - 1e-4) else best), offsets.mean(axis=0)


def _climb(chain: Chain, base: NDArray[np.float64], q: NDArray[np.float64], dist: float) -> float:
    """Projected gradient ascent of the end effector's distance from ``base`` [m], from
    ``q`` (at distance ``dist``) inside the ranges, until a step gains less than 0.1 um
    per metre; returns the largest distance reached."""
    lo, hi, step = chain.lower, chain.upper, 0.1
    chain.set_q(q)
    for _ in range(40 if dist > 1e-12 else 0):  # an effector on the base has no gradient
        grad = chain.current_jacobian()[:3].T @ ((chain.position - base) / dist)
        grad[((q <= lo) & (grad < 0)) | ((q >= hi) & (grad > 0))] = 0.0
        norm, start = float(np.linalg.norm(grad)), dist
        while step > 1e-9 and norm > 1e-12:
            trial = np.minimum(np.maximum(q + (step / norm) * grad, lo), hi)
            chain.set_q(trial)
            far = float(np.linalg.norm(chain.position - base))
            if far > dist:
                q, dist, step = trial, far, 2.0 * step
                break
            step /= 2.0
        if dist - start < 1e-7 * dist:
            break
        chain.set_q(q)  # the kinematics at q (a failed trial may be the last pass)
    return dist
