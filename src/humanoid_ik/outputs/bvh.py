"""A trajectory as a BVH file (Biovision hierarchy) for animation tools.

The skeleton is the model's body tree: the root is the body that holds every jointed
body (the humanoid's ``torso_link``); every body with hinge joints is a BVH ``JOINT``
at its body origin, with one rotation channel per hinge, in the model's joint order;
every site away from its body's origin (the palms, the gaze point, the torso site)
is a ``JOINT`` without channels, so tools show the hands and the head. Offsets are
the model's lengths.

Conventions (``docs/formats.md``): Y up. BVH ``(X, Y, Z)`` is MuJoCo's ``(y, z, x)``:
the humanoid faces +Z (MuJoCo +x), its left is +X (MuJoCo +y) and up is +Y (MuJoCo +z),
a proper rotation of the axes, so a MuJoCo hinge about ``+x``, ``+y``, ``+z`` is a
``Zrotation``, ``Xrotation``, ``Yrotation`` and a hinge about ``-a`` writes the
negated angle. Angles in degrees; lengths in metres (or centimetres). Channels are
intrinsic: a joint's rotation is the product of its channels' rotations in the order
listed, as MuJoCo composes the joints of one body. At all channels zero the skeleton
is in the model's ``qpos = 0`` pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.trajectory import Trajectory

__all__ = ["BVH_UNITS", "bvh_text"]

BVH_UNITS = {"m": 1.0, "cm": 100.0}
"""Length units of a BVH file and their scale from metres."""
_LETTER = ("Z", "X", "Y")
"""The BVH rotation channel of a MuJoCo axis x, y, z."""
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")


def _to_bvh(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """A MuJoCo vector ``(x, y, z)`` in BVH axes ``(y, z, x)``."""
    return np.array([v[1], v[2], v[0]], dtype=np.float64)


@dataclass
class _Node:
    """A BVH joint: its name, offset from the parent [m, MuJoCo axes], channels as
    ``(qpos address, axis letter, sign)`` and children."""

    name: str
    offset: NDArray[np.float64]
    channels: list[tuple[int, str, float]] = field(default_factory=list)
    children: list[_Node] = field(default_factory=list)


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, i: int, fallback: str) -> str:
    return mujoco.mj_id2name(model, kind, i) or f"{fallback}{i}"


def _channels(model: mujoco.MjModel, body: int) -> list[tuple[int, str, float]]:
    """The rotation channels of ``body``'s joints.

    Raises:
        TrajectoryFileError: a joint is not a hinge at the body origin along one of the
            body's axes.
    """
    out = []
    for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
        name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
        if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
            raise TrajectoryFileError(
                f"BVH export takes hinge joints only; joint '{name}' is not a hinge"
            )
        axis = np.asarray(model.jnt_axis[j], dtype=np.float64)
        a = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[a]) - 1.0) > 1e-9 or np.linalg.norm(model.jnt_pos[j]) > 1e-12:
            raise TrajectoryFileError(
                f"BVH export takes hinges at the body origin along its x, y or z axis; "
                f"joint '{name}' has axis {axis.tolist()} at {model.jnt_pos[j].tolist()}"
            )
        out.append((int(model.jnt_qposadr[j]), _LETTER[a], float(np.sign(axis[a]))))
    return out


def _check_frame(model: mujoco.MjModel, body: int) -> None:
    if not np.allclose(model.body_quat[body], (1, 0, 0, 0), atol=1e-12):
        name = _name(model, mujoco.mjtObj.mjOBJ_BODY, body, "body")
        raise TrajectoryFileError(
            f"BVH export needs bodies without a rest rotation; body '{name}' has quat "
            f"{model.body_quat[body].tolist()}"
        )


def _skeleton(model: mujoco.MjModel) -> _Node:
    """The BVH skeleton of ``model`` (bodies without joints are merged into their parent).

    Raises:
        TrajectoryFileError: the model has no hinge joints, or one that BVH cannot hold.
    """
    jointed = [b for b in range(1, model.nbody) if model.body_jntnum[b] > 0]
    if not jointed:
        raise TrajectoryFileError("BVH export needs a model with hinge joints; it has none")
    # the root: the deepest body above every jointed body that has no joint itself
    paths = []
    for b in jointed:
        path = [b]
        while path[-1] != 0:
            path.append(int(model.body_parentid[path[-1]]))
        paths.append(path[::-1])
    common = [b for k, b in enumerate(paths[0]) if all(len(p) > k and p[k] == b for p in paths)]
    root_body = next(b for b in reversed(common) if model.body_jntnum[b] == 0)
    _check_frame(model, root_body)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    root = _Node(_name(model, mujoco.mjtObj.mjOBJ_BODY, root_body, "body"), data.xpos[root_body])
    _grow(model, root_body, root, np.zeros(3))
    return root


def _grow(model: mujoco.MjModel, body: int, node: _Node, shift: NDArray[np.float64]) -> None:
    """Add ``body``'s sites and child bodies under ``node`` (``shift``: where ``body``'s
    origin is in ``node``'s frame, for bodies merged into it)."""
    for s in range(model.nsite):
        if model.site_bodyid[s] == body and np.linalg.norm(model.site_pos[s]) > 1e-12:
            name = _name(model, mujoco.mjtObj.mjOBJ_SITE, s, "site")
            node.children.append(_Node(name, shift + model.site_pos[s]))
    for child in range(1, model.nbody):
        if model.body_parentid[child] != body or child == body:
            continue
        _check_frame(model, child)
        offset = shift + model.body_pos[child]
        if model.body_jntnum[child] == 0:
            _grow(model, child, node, offset)
            continue
        sub = _Node(_name(model, mujoco.mjtObj.mjOBJ_BODY, child, "body"), offset)
        sub.channels = _channels(model, child)
        node.children.append(sub)
        _grow(model, child, sub, np.zeros(3))


def _hierarchy(node: _Node, scale: float, depth: int, lines: list[str]) -> None:
    pad = "  " * depth
    kind = "ROOT" if depth == 0 else "JOINT"
    off = " ".join(f"{v:.10f}" for v in _to_bvh(node.offset) * scale)
    lines += [f"{pad}{kind} {node.name}", f"{pad}{{", f"{pad}  OFFSET {off}"]
    names = list(_ROOT_CHANNELS) if depth == 0 else [f"{c[1]}rotation" for c in node.channels]
    lines.append(f"{pad}  CHANNELS {len(names)}" + "".join(f" {n}" for n in names))
    for child in node.children:
        _hierarchy(child, scale, depth + 1, lines)
    if not node.children:
        lines += [f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET 0 0 0", f"{pad}  }}"]
    lines.append(f"{pad}}}")


def _frame(node: _Node, qpos: NDArray[np.float64], scale: float, root: bool) -> list[float]:
    vals: list[float] = []
    if root:
        vals += list(_to_bvh(node.offset) * scale) + [0.0, 0.0, 0.0]
    else:
        vals += [math.degrees(sign * float(qpos[adr])) for adr, _, sign in node.channels]
    for child in node.children:
        vals += _frame(child, qpos, scale, False)
    return vals


def bvh_text(traj: Trajectory, model: mujoco.MjModel, units: str = "m") -> str:
    """The BVH file of ``traj`` recorded on ``model`` (see the module's conventions).

    Args:
        traj: the trajectory (checked against ``model`` by the caller).
        model: its model.
        units: ``m`` or ``cm`` (:data:`BVH_UNITS`).

    Raises:
        TrajectoryFileError: the model has joints BVH cannot hold (not hinges, hinges
            off a body axis, bodies with a rest rotation).
    """
    if units not in BVH_UNITS:
        raise TrajectoryFileError(f"units '{units}' unknown; units: {', '.join(BVH_UNITS)}")
    scale = BVH_UNITS[units]
    root = _skeleton(model)
    lines = ["HIERARCHY"]
    _hierarchy(root, scale, 0, lines)
    lines += ["MOTION", f"Frames: {traj.n_frames}", f"Frame Time: {1.0 / traj.fps:.10f}"]
    for q in traj.qpos:
        lines.append(" ".join(f"{v:.10f}" for v in _frame(root, q, scale, True)))
    return "\n".join(lines) + "\n"
