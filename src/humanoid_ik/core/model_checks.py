"""Checks of a compiled model that MuJoCo does not make: every number of its geometry,
axes, ranges and home pose finite (``pos="nan 0 0"`` compiles), and an MJCF joint's
``range`` that MuJoCo drops (``range="0.5 0.5"``, or inverted, becomes unlimited under
``autolimits``): a zero-width range locks the joint, an inverted one is refused. Called
by :func:`~humanoid_ik.core.models.load_model`.
"""

from __future__ import annotations

import os
import warnings

import mujoco
import numpy as np

from humanoid_ik.core.mujoco_warnings import mujoco_warnings
from humanoid_ik.core.names import joint_name
from humanoid_ik.core.robot_files import ModelWarning
from humanoid_ik.errors import ModelError

__all__ = ["LOCKED_HALF_WIDTH", "check_finite", "check_ranges"]

LOCKED_HALF_WIDTH = 1e-9
"""Half the range [rad or m] a joint locked by its file (URDF ``lower == upper``, MJCF
``range="v v"``) keeps: it stays where the file locks it (MuJoCo would drop the limit
and let it move freely)."""

_FINITE = (
    ("body_pos", mujoco.mjtObj.mjOBJ_BODY, "body", "pos"),
    ("body_quat", mujoco.mjtObj.mjOBJ_BODY, "body", "quat"),
    ("body_ipos", mujoco.mjtObj.mjOBJ_BODY, "body", "inertial pos"),
    ("jnt_pos", mujoco.mjtObj.mjOBJ_JOINT, "joint", "pos"),
    ("jnt_axis", mujoco.mjtObj.mjOBJ_JOINT, "joint", "axis"),
    ("jnt_range", mujoco.mjtObj.mjOBJ_JOINT, "joint", "range"),
    ("geom_pos", mujoco.mjtObj.mjOBJ_GEOM, "geom", "pos"),
    ("geom_size", mujoco.mjtObj.mjOBJ_GEOM, "geom", "size"),
    ("site_pos", mujoco.mjtObj.mjOBJ_SITE, "site", "pos"),
    ("site_quat", mujoco.mjtObj.mjOBJ_SITE, "site", "quat"),
    ("qpos0", None, "qpos0", ""),
    ("key_qpos", mujoco.mjtObj.mjOBJ_KEY, "keyframe", "qpos"),
)
"""The model arrays whose numbers must be finite: (array, object type, element, field)."""


def check_finite(model: mujoco.MjModel, what: str) -> None:
    """Refuse a model with a NaN or an infinity in its geometry, axes, ranges or home
    pose (``pos="nan 0 0"`` compiles, and every solver then reports NaN errors).

    Raises:
        ModelError: one line naming the element, the field and its values.
    """
    for attr, objtype, element, field in _FINITE:
        values = np.asarray(getattr(model, attr))
        if values.size == 0 or np.isfinite(values).all():
            continue
        rows = values.reshape(len(values), -1)
        row = int(np.nonzero((~np.isfinite(rows)).any(axis=1))[0][0])
        shown = " ".join(f"{v:g}" for v in rows[row])
        if objtype is None:
            where = f"qpos0 [{row}]"
        else:
            name = mujoco.mj_id2name(model, objtype, row) or f"#{row}"
            where = f"{element} '{name}' {field}"
        raise ModelError(f"{what}: {where} is not finite ({shown}); every number must be")


def check_ranges(model: mujoco.MjModel, path: str | os.PathLike, *, xml: str | None = None) -> None:
    """What an MJCF file's dropped joint ranges mean: a hinge or slide whose ``range``
    has lower = upper (not the default ``0 0``) and no ``limited`` of its own is locked
    there, in ``model`` (just compiled from ``path``, or from the MJCF string ``xml``,
    ``path`` then naming it in the messages), with one :class:`ModelWarning`; lower >
    upper is refused.

    Raises:
        ModelError: a joint whose range is inverted, naming it and its range.
    """
    moving = (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    dropped = [
        j
        for j in range(model.njnt)
        if int(model.jnt_type[j]) in moving
        and not model.jnt_limited[j]
        and model.jnt_range[j].any()
        and model.jnt_range[j][0] >= model.jnt_range[j][1]
    ]
    if not dropped:
        return
    with mujoco_warnings():  # was limited="false" written?
        spec = (
            mujoco.MjSpec.from_string(xml)
            if xml is not None
            else mujoco.MjSpec.from_file(str(path))
        )
    locked = []
    for j in dropped:
        name = joint_name(model, j)
        given = spec.joint(name) if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) else None
        if given is not None and given.limited != mujoco.mjtLimited.mjLIMITED_AUTO:
            continue
        lower, upper = (float(v) for v in model.jnt_range[j])
        if lower > upper:
            raise ModelError(
                f"model '{path}': joint '{name}' has range {lower:g} {upper:g} (lower > "
                "upper, which MuJoCo would take as unlimited); swap them"
            )
        model.jnt_limited[j] = 1
        model.jnt_range[j] = [lower - LOCKED_HALF_WIDTH, upper + LOCKED_HALF_WIDTH]
        locked.append(f"'{name}' at {lower:g}")
    if locked:
        shown = ", ".join(locked[:3]) + (f" and {len(locked) - 3} more" if len(locked) > 3 else "")
        warnings.warn(
            f"model '{path}': {len(locked)} joint(s) locked (range lower = upper, which "
            f"MuJoCo would take as unlimited; give a range to let them move): {shown}",
            ModelWarning,
            3,
        )
