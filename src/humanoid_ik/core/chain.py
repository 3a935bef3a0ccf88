"""A kinematic chain of hinge joints on any MuJoCo model.

MuJoCo is the single source of truth for where things are: the chain writes ``qpos``,
runs ``mj_kinematics`` and reads ``site_xpos``/``site_xmat`` (or ``xpos``/``xmat`` for a
body end effector) and ``mj_jacSite``/``mj_jacBody``. The chain owns a scratch ``MjData``;
the caller's ``MjData`` is read with :meth:`Chain.load` and only written by
:meth:`Chain.apply`.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Hashable, Sequence
from typing import Any, TypeVar

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.checks import float_array
from humanoid_ik.core.models import home_qpos, load_model, reset_to_home
from humanoid_ik.errors import (
    ChainError,
    ModelError,
    NameNotFoundError,
    TargetError,
    UnsupportedJointError,
)

__all__ = ["Chain", "DEFAULT_SITE"]

T = TypeVar("T")

DEFAULT_SITE = "right_palm_site"
_JOINT_TYPE_NAMES = {
    mujoco.mjtJoint.mjJNT_FREE: "free",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
}


# what the chain and the caches derived from it read from the model: when one of these
# changes on a live MjModel, the chain re-reads its ranges and drops its caches (sync)
_KINEMATIC_FIELDS = (
    "jnt_range",
    "jnt_limited",
    "jnt_axis",
    "jnt_pos",
    "body_pos",
    "body_quat",
    "site_pos",
    "site_quat",
    "qpos0",
)
# what makes an MjData fit a model: its joints, in order, and the tree they move
_STRUCTURE_FIELDS = ("jnt_type", "jnt_qposadr", "jnt_bodyid", "body_parentid")


def _snapshot(model: mujoco.MjModel, fields: Sequence[str]) -> tuple[bytes, ...]:
    # a list, not a generator: every solve calls this, and a generator per call left
    # garbage for the cyclic collector (the heap of a long run grew until it ran)
    return tuple([getattr(model, f).tobytes() for f in fields])


def _check_args(model: Any, site: Any, body: Any, joints: Any) -> None:
    """One :class:`ChainError` for a model, end effector or joint list of the wrong type."""
    if model is not None and not isinstance(model, (mujoco.MjModel, str, os.PathLike)):
        raise ChainError(
            f"model must be a mujoco.MjModel or a model file path, got {type(model).__name__}"
        )
    for what, value in (("site", site), ("body", body)):
        if value is not None and not isinstance(value, str):
            raise ChainError(f"{what} must be a name (a string), got {value!r}")
    if joints is None or isinstance(joints, str):
        return
    if not isinstance(joints, Sequence) or not all(isinstance(j, str) for j in joints):
        raise ChainError(f"joints must be a list of joint names, got {joints!r}")


def _names(model: mujoco.MjModel, objtype: mujoco.mjtObj, count: int) -> list[str]:
    out = []
    for i in range(count):
        name = mujoco.mj_id2name(model, objtype, i)
        if name:
            out.append(name)
    return out


class Chain:
    """Hinge joints from a root to an end-effector site or body.

    Args:
        model: an ``MjModel``, an MJCF path, or ``None`` for the bundled humanoid (an
            MJCF string: :meth:`from_xml_string`).
        site: end-effector site name (default ``right_palm_site`` when ``body`` is unset).
        joints: joint names; by default the hinge joints on the path from the end
            effector's body to the root, stopping at a free joint.
        body: end-effector body name, instead of a site.

    Raises:
        ModelError, NameNotFoundError, UnsupportedJointError, ChainError.
    """

    def __init__(
        self,
        model: mujoco.MjModel | str | os.PathLike | None = None,
        site: str | None = None,
        joints: Sequence[str] | None = None,
        *,
        body: str | None = None,
    ):
        _check_args(model, site, body, joints)
        self.model = load_model(model)
        m = self.model
        if site is not None and body is not None:
            raise ChainError("give an end-effector site or a body, not both")
        if body is not None:
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)
            if bid < 0:
                raise NameNotFoundError("body", body, _names(m, mujoco.mjtObj.mjOBJ_BODY, m.nbody))
            self.ee_kind, self.ee_id, self.ee_name = "body", bid, body
            ee_body = bid
        else:
            site = DEFAULT_SITE if site is None else site
            sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
            if sid < 0:
                raise NameNotFoundError("site", site, _names(m, mujoco.mjtObj.mjOBJ_SITE, m.nsite))
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
        self.joint_names = [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}" for j in ids
        ]
        self.qpos_adr = m.jnt_qposadr[self.joint_ids].astype(np.int64)
        self.dof_adr = m.jnt_dofadr[self.joint_ids].astype(np.int64)
        self._read_ranges()
        self.data = mujoco.MjData(m)
        self.q_home = self._home()
        self.reset()
        self._kinematics = _snapshot(m, _KINEMATIC_FIELDS)
        self._structure = _snapshot(m, _STRUCTURE_FIELDS)
        self._busy = threading.Lock()
        self.version = 0
        """How many times :meth:`refresh` re-read the model: a cache held outside the
        chain (a solver's own) compares it to know whether it is still current."""
        # (6, nv) Jacobian buffer; rows 0-2 and 3-5 are C-contiguous views for mj_jacSite
        self._jac = np.zeros((6, m.nv))
        self._jacp, self._jacr = self._jac[:3], self._jac[3:]
        dofs = self.dof_adr
        contiguous = bool(np.all(np.diff(dofs) == 1))
        # chain columns: a view of the buffer when the dofs are contiguous, else a copy
        self._dof_slice = slice(int(dofs[0]), int(dofs[-1]) + 1) if contiguous else None
        self._J = self._jac[:, self._dof_slice] if contiguous else np.zeros((6, self.n))
        self._derived: dict[Hashable, Any] = {}
        self._base_qpos = self._qpos_off_chain()

    def _read_ranges(self) -> None:
        m = self.model
        limited = m.jnt_limited[self.joint_ids].astype(bool)
        rng = m.jnt_range[self.joint_ids]
        self.lower = np.where(limited, rng[:, 0], -np.inf)
        self.upper = np.where(limited, rng[:, 1], np.inf)

    def sync(self) -> bool:
        """Follow changes made to the live ``MjModel`` since the chain last looked (joint
        ranges, axes, body and site placements, ``qpos0``): re-read the ranges and the home
        pose and drop every :meth:`derived` cache. Every solve calls it; cheap when nothing
        changed (a byte comparison of those arrays).

        Returns:
            True when the model had changed.
        """
        now = _snapshot(self.model, _KINEMATIC_FIELDS)
        if now == self._kinematics:
            return False
        self.refresh(now)
        return True

    def refresh(self, snapshot: tuple[bytes, ...] | None = None) -> None:
        """Re-read everything the chain took from the model and drop the caches derived
        from it (see :meth:`sync`, which calls this when the model changed)."""
        self._kinematics = snapshot or _snapshot(self.model, _KINEMATIC_FIELDS)
        self._read_ranges()
        self._derived.clear()
        self.version += 1
        q = self.q
        self.q_home = self._home()
        self.set_q(self.clip(q))

    def claim(self) -> None:
        """Mark the chain busy for one solve (:meth:`release` ends it).

        A chain holds scratch data, so one chain serves one thread at a time: give each
        thread its own ``Chain`` (cheap), or guard a shared one with a lock.

        Raises:
            ChainError: another thread is solving on this chain right now.
        """
        if not self._busy.acquire(blocking=False):
            raise ChainError(
                f"{self!r} is in use by another thread; give each thread its own Chain "
                "or guard a shared one with a lock"
            )

    def release(self) -> None:
        """End the solve that :meth:`claim` began."""
        self._busy.release()

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
        """The scratch ``qpos`` of the path's joints outside the chain, which move the
        chain's base (``None`` when nothing does): what a cache of world-frame geometry
        compares to know whether it is still current."""
        return None if self._base_qpos is None else self.data.qpos[self._base_qpos].tolist()

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
            ModelError: ``xml`` is not a string, or MuJoCo cannot compile it (MuJoCo's
                message is kept).
            NameNotFoundError, UnsupportedJointError, ChainError: as :class:`Chain`.
        """
        if not isinstance(xml, str):
            raise ModelError(f"MJCF must be a string of XML, got {type(xml).__name__}")
        try:
            model = mujoco.MjModel.from_xml_string(xml)
        except ValueError as exc:
            msg = " ".join(str(exc).split())
            raise ModelError(f"MJCF string does not compile: {msg}") from exc
        return cls(model, site, joints, body=body)

    def derived(self, key: Hashable, build: Callable[[Chain], T]) -> T:
        """A value derived from the chain's fixed kinematics, built by ``build(self)`` on
        the first call for ``key`` and kept for the chain's life.

        The rule: what is computed from the chain's joints and the model's kinematics alone
        (a solver's seed poses, its geometry) stays valid until the model changes, and
        :meth:`sync` (run by every solve) drops it then; ``build`` must leave the scratch
        data's joint values as it found them.
        """
        if key not in self._derived:
            self._derived[key] = build(self)
        return self._derived[key]

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
        name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
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

    def _named_joints(self, names: Sequence[str], path: list[int]) -> list[int]:
        m = self.model
        if isinstance(names, str):
            names = [names]
        ids = []
        all_names = _names(m, mujoco.mjtObj.mjOBJ_JOINT, m.njnt)
        for name in names:
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

    def _home(self) -> NDArray[np.float64]:
        """Chain joints at the ``home`` keyframe if there is one, else ``qpos0``, inside ranges."""
        return self.clip(home_qpos(self.model)[self.qpos_adr])

    def reset(self) -> None:
        """Scratch data to the home pose: the ``home`` key (or ``qpos0``) for every joint."""
        reset_to_home(self.model, self.data)
        self.data.qpos[self.qpos_adr] = self.q_home
        mujoco.mj_kinematics(self.model, self.data)

    # ----------------------------------------------------------------- properties
    @property
    def n(self) -> int:
        """Number of joints in the chain."""
        return int(self.joint_ids.shape[0])

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
        return self._jacobian().copy()

    def _jacobian(self) -> NDArray[np.float64]:
        """Fills the reused ``(6, n)`` buffer; ``mj_kinematics`` must be current."""
        m, d = self.model, self.data
        mujoco.mj_comPos(m, d)
        if self.ee_kind == "site":
            mujoco.mj_jacSite(m, d, self._jacp, self._jacr, self.ee_id)
        else:
            mujoco.mj_jacBody(m, d, self._jacp, self._jacr, self.ee_id)
        if self._dof_slice is None:
            np.take(self._jac, self.dof_adr, axis=1, out=self._J)
        return self._J

    def joint_axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World anchors ``(n, 3)`` and unit axes ``(n, 3)`` of the chain's hinges."""
        return (self.data.xanchor[self.joint_ids].copy(), self.data.xaxis[self.joint_ids].copy())

    def load(self, data: mujoco.MjData) -> None:
        """Copy the caller's ``qpos`` (every joint) into the scratch data. ``data`` is only read.

        Raises:
            ChainError: ``data`` belongs to another model.
        """
        self.check_data(data)
        self.data.qpos[:] = data.qpos
        self.data.mocap_pos[:] = data.mocap_pos
        self.data.mocap_quat[:] = data.mocap_quat
        mujoco.mj_kinematics(self.model, self.data)

    def check_data(self, data: mujoco.MjData) -> None:
        """Refuse an ``MjData`` made for another model: one of another size, or of a model
        whose joints or tree differ (an ``MjData`` of a copy of the same model is fine).

        Raises:
            ChainError: ``data`` is not an ``MjData`` of a model like the chain's.
        """
        if not isinstance(data, mujoco.MjData):
            raise ChainError(f"expected a mujoco.MjData, got {type(data).__name__}")
        other = data.model
        if other is self.model:
            return
        if other.nq != self.model.nq or other.njnt != self.model.njnt:
            raise ChainError(
                f"MjData has nq={other.nq} and {other.njnt} joints, the chain's model has "
                f"nq={self.model.nq} and {self.model.njnt}: it belongs to another model"
            )
        if _snapshot(other, _STRUCTURE_FIELDS) != self._structure or _names(
            other, mujoco.mjtObj.mjOBJ_JOINT, other.njnt
        ) != _names(self.model, mujoco.mjtObj.mjOBJ_JOINT, self.model.njnt):
            raise ChainError(
                "MjData belongs to another model (its joints or bodies differ from the "
                "chain's); make it with mujoco.MjData(chain.model)"
            )

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
    def clip(self, q: ArrayLike) -> NDArray[np.float64]:
        """``q`` moved inside the joint ranges."""
        # np.minimum/np.maximum: np.clip's wrapper costs more than the clipping here
        return np.minimum(np.maximum(np.asarray(q, dtype=np.float64), self.lower), self.upper)

    def within_limits(self, q: ArrayLike, tol: float = 1e-9) -> bool:
        """True when every joint lies inside its range (with ``tol`` [rad])."""
        arr = np.asarray(q)
        return bool(np.all(arr >= self.lower - tol) and np.all(arr <= self.upper + tol))

    def limit_margin(self, q: ArrayLike) -> float:
        """Smallest distance [rad] of any joint to its nearest range end (negative outside)."""
        arr = np.asarray(q)
        return float(np.min(np.minimum(arr - self.lower, self.upper - arr)))

    def random_q(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """A uniform joint vector inside the ranges (unlimited joints in [-pi, pi])."""
        lo = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, math.pi)
        return rng.uniform(lo, hi)

    def __repr__(self) -> str:
        return f"Chain({self.ee_kind}='{self.ee_name}', joints=[{', '.join(self.joint_names)}])"
