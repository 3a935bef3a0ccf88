"""A trajectory as a BVH file (Biovision hierarchy) for animation tools.

The skeleton is the model's joint tree: the root is the body that holds every jointed
body (the humanoid's ``torso_link``, a robot's base link, or its floating base); every
body with hinge (or ball) joints is a BVH ``JOINT`` placed at its joints' anchor;
bodies without joints (a sensor, camera or tool link on a fixed joint) are folded into
the jointed body above them; every site away from its ``JOINT`` (the palms, the gaze
point, the torso site) is a ``JOINT`` without channels, so tools show the hands and the
head, and so is each end-effector frame of the trajectory (a site; a body at its
origin: a folded one such as G1's ``left_rubber_hand`` under its own name, a jointed one
whose origin is off its joints' anchor as ``<body>_origin``), so the hands a run moved
are in the file whatever the model calls them. Offsets are the model's lengths. A slide
joint that stays at its ``qpos0`` value in every frame of the trajectory (a gripper's
fingers the run never moved) is held fixed, its body folded the same way.

Frames: every ``JOINT``'s frame is aligned with the world at the model's reference pose
``qpos0`` (``qpos = 0`` for every hinge of a URDF), whatever rest rotation its body has,
so its offsets are world differences at that pose and at all channels zero the skeleton
stands in it. A hinge then turns its ``JOINT`` about the hinge's world axis at that pose
(:func:`_channels`): along a world axis (most robots: the bundled humanoid, G1, Talos)
that is one rotation channel, whose value is the joint's angle ``qpos - qpos0``; a body
with a hinge about a slanted axis or a ball joint gets three channels (``Zrotation
Xrotation Yrotation``) holding its rotation relative to its parent, decomposed each
frame. A floating base (a free joint on the root) drives the root's six channels.
BVH cannot hold a slide joint that moves, hinges of one body about different points or
a free joint below the root: such a model is refused with a pointer to
``export-keyframes``.

Conventions (``docs/formats.md``): Y up. BVH ``(X, Y, Z)`` is MuJoCo's ``(y, z, x)``:
the humanoid faces +Z (MuJoCo +x), its left is +X (MuJoCo +y) and up is +Y (MuJoCo +z),
a proper rotation of the axes, so a hinge about world ``+x``, ``+y``, ``+z`` is a
``Zrotation``, ``Xrotation``, ``Yrotation`` and a hinge about ``-a`` writes the
negated angle. Angles in degrees; lengths in metres (or centimetres). Channels are
intrinsic: a joint's rotation is the product of its channels' rotations in the order
listed, as MuJoCo composes the joints of one body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.rotations import decompose_three_axes
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.trajectory import Trajectory

__all__ = ["BVH_UNITS", "bvh_text"]

BVH_UNITS = {"m": 1.0, "cm": 100.0}
"""Length units of a BVH file and their scale from metres."""
_LETTER = ("Z", "X", "Y")
"""The BVH rotation channel of a MuJoCo axis x, y, z."""
_ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
_EULER = ("Zrotation", "Xrotation", "Yrotation")
"""The channels of a rotation decomposed each frame (the root's, a slanted hinge's)."""
_BVH_AXES = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
"""MuJoCo vector -> BVH vector: ``(x, y, z) -> (y, z, x)``."""
_ALIGNED = 1e-9
"""How far from 1 a world axis component may be for a hinge to count as along it."""
_KEYFRAMES = "; export-keyframes writes any model's motion (MuJoCo <key> elements)"


def _to_bvh(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """A MuJoCo vector ``(x, y, z)`` in BVH axes ``(y, z, x)``."""
    return np.array([v[1], v[2], v[0]], dtype=np.float64)


@dataclass
class _Node:
    """A BVH joint.

    Attributes:
        name: its name.
        offset: from the parent joint [m, MuJoCo world axes at ``qpos0``].
        body: the MuJoCo body it moves with (``-1`` for a site).
        channels: one per hinge along a world axis: ``(qpos address, axis letter,
            sign)``; empty with ``euler`` set, or for a site.
        euler: the rotation is decomposed each frame into :data:`_EULER`.
        children: its child joints.
    """

    name: str
    offset: NDArray[np.float64]
    body: int = -1
    channels: list[tuple[int, str, float]] = field(default_factory=list)
    euler: bool = False
    children: list[_Node] = field(default_factory=list)


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, i: int, fallback: str) -> str:
    return mujoco.mj_id2name(model, kind, i) or f"{fallback}{i}"


def _held(model: mujoco.MjModel, qpos: NDArray[np.float64]) -> set[int]:
    """The slide joints that stay at their ``qpos0`` value in every frame of ``qpos``
    ``(F, nq)``: held fixed in the skeleton."""
    out = set()
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            adr = int(model.jnt_qposadr[j])
            if np.all(qpos[:, adr] == model.qpos0[adr]):
                out.add(j)
    return out


def _joints(model: mujoco.MjModel, body: int, held: set[int]) -> list[int]:
    """``body``'s joints that the skeleton moves (all but the ``held`` ones)."""
    adr, num = int(model.body_jntadr[body]), int(model.body_jntnum[body])
    return [j for j in range(adr, adr + num) if j not in held]


def _channels(
    model: mujoco.MjModel, rest: mujoco.MjData, joints: list[int]
) -> tuple[list[tuple[int, str, float]], bool, NDArray[np.float64]]:
    """The rotation channels of one body's ``joints``, whether they are decomposed each
    frame instead, and where the joints turn (their anchor at ``qpos0``, world [m]).

    Raises:
        TrajectoryFileError: a joint BVH cannot hold (a slide that moves, a free joint
            below the root), or hinges about different points.
    """
    out = []
    euler = False
    anchor = np.array(rest.xanchor[joints[0]], dtype=np.float64)
    body = int(model.jnt_bodyid[joints[0]])
    bname = _name(model, mujoco.mjtObj.mjOBJ_BODY, body, "body")
    for j in joints:
        name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, j, "joint")
        jtype = int(model.jnt_type[j])
        if jtype not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL):
            what = (
                "a slide joint that moves in this trajectory"
                if jtype == mujoco.mjtJoint.mjJNT_SLIDE
                else "a free joint below the skeleton's root"
            )
            raise TrajectoryFileError(
                f"BVH holds rotations only; joint '{name}' is {what}{_KEYFRAMES}"
            )
        if np.linalg.norm(rest.xanchor[j] - anchor) > 1e-9:
            raise TrajectoryFileError(
                f"BVH turns a body about one point; the joints of body '{bname}' turn about "
                f"different points{_KEYFRAMES}"
            )
        if jtype == mujoco.mjtJoint.mjJNT_BALL:
            euler = True
            continue
        axis = np.asarray(rest.xaxis[j], dtype=np.float64)
        a = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[a]) - 1.0) > _ALIGNED:
            euler = True
        out.append((int(model.jnt_qposadr[j]), _LETTER[a], float(np.sign(axis[a]))))
    return ([] if euler else out), euler, anchor


def _root_body(model: mujoco.MjModel, held: set[int]) -> int:
    """The deepest body above every jointed body without joints of its own, or with only
    a free joint (a floating base).

    Raises:
        TrajectoryFileError: the model has no joint.
    """
    jointed = [b for b in range(1, model.nbody) if _joints(model, b, held)]
    if not jointed:
        raise TrajectoryFileError("BVH export needs a model with hinge joints; it has none")
    paths = []
    for b in jointed:
        path = [b]
        while path[-1] != 0:
            path.append(int(model.body_parentid[path[-1]]))
        paths.append(path[::-1])
    common = [b for k, b in enumerate(paths[0]) if all(len(p) > k and p[k] == b for p in paths)]
    for b in reversed(common):
        if not _joints(model, b, held) or _free_joint(model, b) is not None:
            return b
    return 0


def _free_joint(model: mujoco.MjModel, body: int) -> int | None:
    """``body``'s joint when it is exactly one free joint, else ``None``."""
    if model.body_jntnum[body] != 1:
        return None
    j = int(model.body_jntadr[body])
    return j if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE else None


@dataclass(frozen=True)
class _Ends:
    """The end-effector frames a trajectory names, each written as a ``JOINT`` without
    channels: ``sites`` (ids, even one that sits on its ``JOINT``) and ``bodies`` (ids:
    a body folded into the one above, or a jointed body whose origin is not at its
    joints' anchor, as ``<body>_origin``)."""

    sites: frozenset[int] = frozenset()
    bodies: frozenset[int] = frozenset()


def _ends(model: mujoco.MjModel, traj: Trajectory) -> _Ends:
    """The end-effector frames of ``traj``'s effectors on ``model``: a site of that name
    (a file from before effectors kept their kind says ``site`` for a body too), else a
    body of that name."""
    sites, bodies = set(), set()
    for e in traj.effectors:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, e.site)
        if e.kind == "site" and sid >= 0:
            sites.add(sid)
            continue
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, e.site)
        if bid > 0:
            bodies.add(bid)
    return _Ends(frozenset(sites), frozenset(bodies))


def _skeleton(
    model: mujoco.MjModel, rest: mujoco.MjData, held: set[int], ends: _Ends = _Ends()
) -> _Node:
    """The BVH skeleton of ``model`` (``rest``: its kinematics at ``qpos0``; ``held``: the
    joints held fixed; ``ends``: the end-effector frames written).

    Raises:
        TrajectoryFileError: the model has no joint, or one that BVH cannot hold.
    """
    root_body = _root_body(model, held)
    root = _Node(
        _name(model, mujoco.mjtObj.mjOBJ_BODY, root_body, "body"),
        np.array(rest.xpos[root_body], dtype=np.float64),
        body=root_body,
    )
    _grow(model, rest, held, ends, root_body, root, root.offset)
    return root


def _grow(
    model: mujoco.MjModel,
    rest: mujoco.MjData,
    held: set[int],
    ends: _Ends,
    body: int,
    node: _Node,
    at: NDArray[np.float64],
) -> None:
    """Add ``body``'s sites and child bodies under ``node``, which stands at ``at``
    (world, ``qpos0``) and which ``body`` is folded into unless it is ``node``'s."""
    if body in ends.bodies:  # an end-effector body: its frame's origin
        name = _name(model, mujoco.mjtObj.mjOBJ_BODY, body, "body")
        offset = rest.xpos[body] - at
        if body != node.body:  # folded into the node
            node.children.append(_Node(name, offset))
        elif np.linalg.norm(offset) > 1e-12:  # away from its joints' anchor
            node.children.append(_Node(f"{name}_origin", offset))
    for s in range(model.nsite):
        if model.site_bodyid[s] == body:
            offset = rest.site_xpos[s] - at
            if np.linalg.norm(offset) > 1e-12 or s in ends.sites:
                name = _name(model, mujoco.mjtObj.mjOBJ_SITE, s, "site")
                node.children.append(_Node(name, offset))
    for child in range(1, model.nbody):
        if model.body_parentid[child] != body or child == body:
            continue
        joints = _joints(model, child, held)
        if not joints:
            _grow(model, rest, held, ends, child, node, at)
            continue
        channels, euler, anchor = _channels(model, rest, joints)
        name = _name(model, mujoco.mjtObj.mjOBJ_BODY, child, "body")
        sub = _Node(name, anchor - at, child, channels, euler)
        node.children.append(sub)
        _grow(model, rest, held, ends, child, sub, anchor)


def _hierarchy(node: _Node, scale: float, depth: int, lines: list[str]) -> None:
    pad = "  " * depth
    kind = "ROOT" if depth == 0 else "JOINT"
    off = " ".join(f"{v:.10f}" for v in _to_bvh(node.offset) * scale)
    lines += [f"{pad}{kind} {node.name}", f"{pad}{{", f"{pad}  OFFSET {off}"]
    if depth == 0:
        names = list(_ROOT_CHANNELS)
    elif node.euler:
        names = list(_EULER)
    else:
        names = [f"{c[1]}rotation" for c in node.channels]
    lines.append(f"{pad}  CHANNELS {len(names)}" + "".join(f" {n}" for n in names))
    for child in node.children:
        _hierarchy(child, scale, depth + 1, lines)
    if not node.children:
        lines += [f"{pad}  End Site", f"{pad}  {{", f"{pad}    OFFSET 0 0 0", f"{pad}  }}"]
    lines.append(f"{pad}}}")


class _Frames:
    """The channel values of each frame, from MuJoCo's kinematics where a rotation is
    decomposed (the root, slanted hinges, ball joints)."""

    def __init__(self, model: mujoco.MjModel, root: _Node, rest: mujoco.MjData, scale: float):
        self.model, self.root, self.scale = model, root, scale
        self.qpos0 = np.array(model.qpos0, dtype=np.float64)
        self.rest_rot = {b: rest.xmat[b].reshape(3, 3).copy() for b in range(model.nbody)}
        self.data = mujoco.MjData(model)
        self.free = _free_joint(model, root.body)
        self.previous: dict[int, NDArray[np.float64]] = {}
        self.needs_fk = self.free is not None or _any_euler(root)

    def row(self, qpos: NDArray[np.float64]) -> list[float]:
        """The values of one frame, in the hierarchy's channel order."""
        if self.needs_fk:
            self.data.qpos[:] = qpos
            mujoco.mj_kinematics(self.model, self.data)
        vals: list[float] = []
        if self.free is None:
            vals += list(_to_bvh(self.root.offset) * self.scale) + [0.0, 0.0, 0.0]
        else:
            pos = np.array(self.data.xpos[self.root.body], dtype=np.float64)
            vals += list(_to_bvh(pos) * self.scale) + self._euler(self.root.body, np.eye(3))
        world = self._world(self.root.body)
        for child in self.root.children:
            self._node(child, qpos, world, vals)
        return vals

    def _world(self, body: int) -> NDArray[np.float64]:
        """The body's BVH rotation in the world (identity at ``qpos0``)."""
        if not self.needs_fk:
            return np.eye(3)
        return self.data.xmat[body].reshape(3, 3) @ self.rest_rot[body].T

    def _node(
        self,
        node: _Node,
        qpos: NDArray[np.float64],
        parent: NDArray[np.float64],
        vals: list[float],
    ) -> None:
        if node.body < 0:  # a site: no channels
            return
        if node.euler:
            vals += self._euler(node.body, parent)
        else:
            for adr, _, sign in node.channels:
                vals.append(math.degrees(sign * float(qpos[adr] - self.qpos0[adr])))
        world = self._world(node.body)
        for child in node.children:
            self._node(child, qpos, world, vals)

    def _euler(self, body: int, parent: NDArray[np.float64]) -> list[float]:
        """``body``'s rotation relative to ``parent`` (both world, MuJoCo axes) as
        ``Zrotation Xrotation Yrotation`` [deg]: the decomposition nearest the last frame's,
        unwrapped to it, so the curves are continuous."""
        local = _BVH_AXES @ (parent.T @ self._world(body)) @ _BVH_AXES.T
        eye = np.eye(3)
        sols = decompose_three_axes(local, eye[2], eye[0], eye[1])
        last = self.previous.get(body)
        if not sols:  # numerically at the edge: the identity's neighbour
            sols = [np.zeros(3) if last is None else last]
        if last is None:
            best = min(sols, key=lambda s: abs(float(s[1])))
        else:
            sols = [s + 2 * math.pi * np.round((last - s) / (2 * math.pi)) for s in sols]
            best = min(sols, key=lambda s: float(np.abs(s - last).sum()))
        self.previous[body] = best
        return [math.degrees(float(v)) for v in best]


def _any_euler(node: _Node) -> bool:
    return node.euler or any(_any_euler(c) for c in node.children)


def bvh_text(traj: Trajectory, model: mujoco.MjModel, units: str = "m") -> str:
    """The BVH file of ``traj`` recorded on ``model`` (see the module's conventions).

    Args:
        traj: the trajectory (checked against ``model`` by the caller).
        model: its model.
        units: ``m`` or ``cm`` (:data:`BVH_UNITS`).

    Raises:
        TrajectoryFileError: the model has joints BVH cannot hold (a slide joint that
            moves, hinges of one body about different points, a free joint below the
            root; the message points at ``export-keyframes``), or no joint at all.
    """
    if units not in BVH_UNITS:
        raise TrajectoryFileError(f"units '{units}' unknown; units: {', '.join(BVH_UNITS)}")
    scale = BVH_UNITS[units]
    rest = mujoco.MjData(model)
    mujoco.mj_kinematics(model, rest)
    root = _skeleton(model, rest, _held(model, traj.qpos), _ends(model, traj))
    lines = ["HIERARCHY"]
    _hierarchy(root, scale, 0, lines)
    lines += ["MOTION", f"Frames: {traj.n_frames}", f"Frame Time: {1.0 / traj.fps:.10f}"]
    frames = _Frames(model, root, rest, scale)
    for q in traj.qpos:
        lines.append(" ".join(f"{v:.10f}" for v in frames.row(q)))
    return "\n".join(lines) + "\n"
