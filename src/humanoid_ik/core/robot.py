"""A robot: one MuJoCo model and the one scratch state every chain on it works in.

In the spirit of ``mink.Configuration``: the :class:`Robot` owns the ``MjModel`` (as the
user gave it, unmodified), ONE scratch ``MjData``, the ``(6, nv)`` Jacobian buffer and
the workspace where solvers keep what they build for this state (seed libraries,
buffers, QP problems). A :class:`~humanoid_ik.core.chain.Chain` is a light view over a
robot (``Chain(robot, site)``): joint ids, addresses and an end-effector frame;
several chains of one robot share its state, so a multi-effector goal is several
chains over one state and a scene holds one ``MjData`` however many effectors it has.

One thread at a time: a solve claims the robot (:meth:`Robot.claim`) for its duration.
Give each thread its own ``Robot`` (cheap: one ``MjData``); solver objects hold no
state and may be shared.

The caller's ``MjData`` is only read (:meth:`Robot.load`) and written by
:meth:`Chain.apply <humanoid_ik.core.chain.Chain.apply>`.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Hashable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.models import load_model, reset_to_home
from humanoid_ik.core.names import joint_name
from humanoid_ik.errors import ChainError

__all__ = ["Robot", "joint_name", "names"]

T = TypeVar("T")

# what the chains and the caches derived from them read from the model: when one of
# these changes on a live MjModel, the robot drops its workspace (sync)
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
    "key_qpos",
)
# what makes an MjData fit a model: its joints, in order, and the tree they move
_STRUCTURE_FIELDS = ("jnt_type", "jnt_qposadr", "jnt_bodyid", "body_parentid")


def _snapshot(model: mujoco.MjModel, fields: Sequence[str]) -> tuple[bytes, ...]:
    # a list, not a generator: every solve calls this, and a generator per call left
    # garbage for the cyclic collector (the heap of a long run grew until it ran)
    return tuple([getattr(model, f).tobytes() for f in fields])


def names(model: mujoco.MjModel, objtype: mujoco.mjtObj, count: int) -> list[str]:
    """The non-empty names of the first ``count`` objects of ``objtype``."""
    out = []
    for i in range(count):
        name = mujoco.mj_id2name(model, objtype, i)
        if name:
            out.append(name)
    return out


class Robot:
    """One model and its one scratch state, shared by every chain on it.

    Args:
        model: an ``MjModel`` (used as given, never modified), an MJCF, URDF or xacro
            path, or ``None`` for the bundled humanoid.
        packages: ROS package folders ``{NAME: DIR}`` for a URDF's ``package://``
            meshes (:func:`~humanoid_ik.core.models.load_model`).

    Attributes:
        model: the ``MjModel``.
        data: the scratch ``MjData`` every chain and solver on this robot works in;
            it starts at the ``home`` keyframe (``qpos0`` without one), limited joints
            moved inside their ranges.
        jac: the ``(6, nv)`` Jacobian buffer (rows 0-2 linear, 3-5 angular; each half
            C-contiguous for ``mj_jacSite``).
        version: how many times the robot followed a change of the live model
            (:meth:`sync`): a cache held outside compares it.
    """

    def __init__(
        self,
        model: mujoco.MjModel | str | os.PathLike | None = None,
        *,
        packages: Mapping[str, Path] | None = None,
    ):
        if model is not None and not isinstance(model, (mujoco.MjModel, str, os.PathLike)):
            raise ChainError(
                f"model must be a mujoco.MjModel or a model file path, got {type(model).__name__}"
            )
        self.model = load_model(model, packages=packages)
        self.data = mujoco.MjData(self.model)
        self.jac = np.zeros((6, self.model.nv))
        self.jacp, self.jacr = self.jac[:3], self.jac[3:]
        self.version = 0
        # the arrays view the model's memory, which stays where it is: read once, a
        # sync compares their bytes without MjModel's attribute lookups (half its cost)
        self._kinematic_arrays = [getattr(self.model, f) for f in _KINEMATIC_FIELDS]
        self._kinematics = self._kinematic_snapshot()
        self._structure = _snapshot(self.model, _STRUCTURE_FIELDS)
        self._busy = threading.Lock()
        self._workspace: dict[Hashable, Any] = {}
        types = self.model.jnt_type
        hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
        self._one_dof = np.flatnonzero((types == hinge) | (types == slide))
        self.reset()

    # ----------------------------------------------------------------- state
    def reset(self) -> None:
        """Scratch data to the home pose: the ``home`` key (or ``qpos0``) for every
        joint, each limited hinge or slide moved inside its range."""
        m, d = self.model, self.data
        reset_to_home(m, d)
        one = self._one_dof
        limited = one[m.jnt_limited[one] != 0]
        if limited.size:
            adr, rng = m.jnt_qposadr[limited], m.jnt_range[limited]
            d.qpos[adr] = np.minimum(np.maximum(d.qpos[adr], rng[:, 0]), rng[:, 1])
        mujoco.mj_kinematics(m, d)

    def load(self, data: mujoco.MjData) -> None:
        """Copy the caller's ``qpos`` (every joint) and mocap poses into the scratch data.
        ``data`` is only read.

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
            ChainError: ``data`` is not an ``MjData`` of a model like the robot's.
        """
        if not isinstance(data, mujoco.MjData):
            raise ChainError(f"expected a mujoco.MjData, got {type(data).__name__}")
        other = data.model
        if other is self.model:
            return
        m = self.model
        if other.nq != m.nq or other.njnt != m.njnt:
            raise ChainError(
                f"MjData has nq={other.nq} and {other.njnt} joints, the chain's model has "
                f"nq={m.nq} and {m.njnt}: it belongs to another model"
            )
        joint = mujoco.mjtObj.mjOBJ_JOINT
        if _snapshot(other, _STRUCTURE_FIELDS) != self._structure or names(
            other, joint, other.njnt
        ) != names(m, joint, m.njnt):
            raise ChainError(
                "MjData belongs to another model (its joints or bodies differ from the "
                "chain's); make it with mujoco.MjData(chain.model)"
            )

    # ----------------------------------------------------------------- live model
    def sync(self) -> bool:
        """Follow changes made to the live ``MjModel`` since the robot last looked (joint
        ranges, axes, body and site placements, ``qpos0``, keyframes): drop the
        workspace and count a new :attr:`version`. Every solve calls it; cheap when
        nothing changed (a byte comparison of those arrays).

        Returns:
            True when the model had changed.
        """
        now = self._kinematic_snapshot()
        if now == self._kinematics:
            return False
        self.refresh(now)
        return True

    def refresh(self, snapshot: tuple[bytes, ...] | None = None) -> None:
        """Drop everything built from the model (the workspace) and count a new
        :attr:`version` (see :meth:`sync`, which calls this when the model changed)."""
        self._kinematics = snapshot or self._kinematic_snapshot()
        self._workspace.clear()
        self.version += 1

    def _kinematic_snapshot(self) -> tuple[bytes, ...]:
        # a list, not a generator (see _snapshot)
        return tuple([a.tobytes() for a in self._kinematic_arrays])

    def workspace(self, key: Hashable, build: Callable[[], T]) -> T:
        """What a solver builds for this robot state, by ``build()`` on the first call
        for ``key``, kept until the model changes (:meth:`sync` drops it).

        Buffers a solve writes, seed libraries, QP problems and compiled kernels live
        here rather than on the solver object: a robot serves one thread at a time
        (:meth:`claim`), so what is here is never shared by two solves at once.
        ``build`` must leave the scratch data's joint values as it found them.
        """
        try:
            return self._workspace[key]
        except KeyError:
            value = self._workspace[key] = build()
            return value

    def buffer(self, key: Hashable, shape: tuple[int, ...]) -> NDArray[np.float64]:
        """A float64 work buffer of ``shape`` in the workspace (see :meth:`workspace`),
        made once per ``(key, shape)``; its values are whatever the last solve left."""
        return self.workspace(("buffer", key, shape), lambda: np.zeros(shape))

    # ----------------------------------------------------------------- threads
    def claim(self) -> None:
        """Mark the robot busy for one solve (:meth:`release` ends it).

        Raises:
            ChainError: another thread is solving on this robot right now.
        """
        if not self._busy.acquire(blocking=False):
            raise ChainError(
                f"{self!r} is in use by another thread; give each thread its own Robot "
                "(or Chain) or guard a shared one with a lock"
            )

    def release(self) -> None:
        """End the solve that :meth:`claim` began."""
        self._busy.release()

    def __repr__(self) -> str:
        return f"Robot(nq={self.model.nq}, njnt={self.model.njnt})"
