"""A humanoid's limbs found from its model: the arms, the head, the torso and the legs.

:func:`find_limbs` reads the kinematic tree and the names of the joints, bodies, sites
and cameras, and returns a :class:`Profile`: for each limb its joints (in tree order,
root first) and its end frame. The rules, in order:

- **Names.** A joint's name is split into lower-case words (``LShoulderPitch`` ->
  ``l shoulder pitch``, ``arm_left_1_joint`` -> ``arm left 1 joint``, ``RARM_ELBOW``
  -> ``r arm elbow``) and sorted into a kind by its words: a finger (``finger``,
  ``thumb``, ``gripper``, ``hand`` ...: a hand's own joints are not the arm's), a leg
  (``hip``, ``knee``, ``ankle``, ``leg`` ...), the head (``head``, ``neck``,
  ``cervical``), the torso (``torso``, ``waist``, ``trunk``, ``spine``, ``chest`` ...),
  an arm (``shoulder``, ``elbow``, ``wrist``, ``arm``, Baxter's ``s0 .. w2``), or none
  (wheels, casters, sensor mounts). Its side comes from a ``left``/``right``, ``l``/``r``
  or ``L``/``R`` word.
- **The tree.** An arm is the hinge joints on the path from its first to its last arm
  joint (a side's arm joints must lie on one path from the root); the torso is the
  moving joints between the root and the point where the two arms branch; the head the
  head joints on one path. An arm without a side word is given one by geometry: the
  side of the body it is on, seen from the robot's forward direction (+x unless both
  arms have side words, which then give the forward direction).
- **End frames.** An arm's end frame is chosen among the sites and bodies rigidly
  attached past its last joint, by name: a palm, a tool point or grasp frame, a hand,
  a gripper's base, in that order, farthest from the wrist on a tie; frames of
  sensors, cameras, IMUs, force-torque sensors and fingers are never hands. The head's
  gaze frame is a gaze or eye site, else a camera rigidly on the head, else the head
  body (its forward axis: the robot's forward direction at home, in the frame).

A :class:`Profile` can be written to TOML (:meth:`Profile.to_toml`) and edited; a file
``<model>.limbs.toml`` beside the model, or one given explicitly, overrides what was
found, limb by limb (:func:`profile_for`).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import home_qpos
from humanoid_ik.core.names import KIND_ORDER, KIND_WORDS, frame_role, name_words
from humanoid_ik.core.robot import Robot
from humanoid_ik.errors import ChainError, ModelError

__all__ = [
    "LIMB_NAMES",
    "Limb",
    "Profile",
    "find_limbs",
    "limb_chain",
    "profile_file",
    "profile_for",
]

LIMB_NAMES = ("left_arm", "right_arm", "head", "torso", "left_leg", "right_leg", "arm")
"""Limb names a profile may hold (``arm``: the one arm of a robot without sides)."""

_SIDES = {"left": "left", "l": "left", "lft": "left", "right": "right", "r": "right"}
_END_SCORES = (
    ({"palm"}, 6),
    ({"tcp", "grasp", "grasping", "ee", "effector", "end"}, 5),
    ({"tool"}, 4),
    ({"hand"}, 3),
    ({"gripper"}, 2),
    ({"wrist", "flange", "nub"}, 1),
)
_GAZE_WORDS = frozenset("gaze eye eyes".split())


def _kind(words: Sequence[str]) -> str | None:
    ws = set(words)
    for kind in KIND_ORDER:
        if ws & KIND_WORDS[kind]:
            return kind
    if any(a in "sew" and b.isdigit() for a, b in zip(words, words[1:], strict=False)):
        return "arm"  # Baxter's s0, s1, e0, e1, w0, w1, w2
    return None


def _side(words: Sequence[str]) -> str | None:
    for w in words:
        if w in _SIDES:
            return _SIDES[w]
    return None


@dataclass(frozen=True)
class Limb:
    """One limb of a robot.

    Attributes:
        name: one of :data:`LIMB_NAMES`.
        joints: the limb's joint names, root first (empty for a fixed head).
        frame: the end frame's kind, ``"site"``, ``"body"`` or ``"camera"`` (``""``
            for the torso and legs, which are named, not reached with).
        frame_name: the end frame's name.
        axis: for the head, the gaze's forward axis in the end frame ``(3,)``.
        source: how it was found (``"names"``, ``"geometry"``, ``"profile"``).
    """

    name: str
    joints: tuple[str, ...]
    frame: str = ""
    frame_name: str = ""
    axis: tuple[float, float, float] | None = None
    source: str = "names"

    def end(self) -> dict[str, str]:
        """The end frame as the keyword a chain takes (``{"site": ...}`` or
        ``{"body": ...}``; a camera's body for a camera)."""
        if self.frame == "site":
            return {"site": self.frame_name}
        return {"body": self.frame_name}


@dataclass(frozen=True)
class Profile:
    """The limbs of one model, and its forward direction.

    Attributes:
        limbs: the limbs found, by name.
        forward: the robot's forward direction in the world at home ``(3,)`` (unit,
            horizontal): THE forward direction (scene placements, the stage's cameras).
        notes: what was decided and why, one line each.
        forward_from: what gave ``forward``: ``"arms"`` (``left x up`` from the sided
            arms' shoulders), ``"profile"`` (a profile file), ``""`` (none: +x assumed).
    """

    limbs: Mapping[str, Limb]
    forward: tuple[float, float, float] = (1.0, 0.0, 0.0)
    notes: tuple[str, ...] = field(default=())
    forward_from: str = ""

    def limb(self, name: str) -> Limb:
        """The limb called ``name``.

        Raises:
            ChainError: the model has no such limb (the message names those it has).
        """
        if name not in self.limbs:
            have = ", ".join(self.limbs) or "(none found)"
            raise ChainError(f"limb '{name}' not found in the model; limbs: {have}")
        return self.limbs[name]

    def to_toml(self) -> str:
        """The profile as TOML a user can edit and pass back (:func:`profile_for`)."""
        lines = [
            "# limbs of the model, as found by humanoid-ik; edit and keep beside the model",
            f"forward = [{', '.join(f'{v:.4g}' for v in self.forward)}]",
        ]
        for limb in self.limbs.values():
            lines += ["", f"[limbs.{limb.name}]"]
            lines.append("joints = [" + ", ".join(f'"{j}"' for j in limb.joints) + "]")
            if limb.frame:
                lines.append(f'{limb.frame} = "{limb.frame_name}"')
            if limb.axis is not None:
                lines.append(f"axis = [{', '.join(f'{v:.4g}' for v in limb.axis)}]")
        return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------- tree
class _Tree:
    """The model's bodies, joints and frames, with the home pose's kinematics."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.m = model
        self.d = mujoco.MjData(model)
        self.d.qpos[:] = home_qpos(model)
        mujoco.mj_kinematics(model, self.d)
        mujoco.mj_camlight(model, self.d)
        self.parent = model.body_parentid

    def name(self, obj: mujoco.mjtObj, i: int) -> str:
        return mujoco.mj_id2name(self.m, obj, i) or ""

    def ancestors(self, body: int) -> list[int]:
        """``body`` and its ancestors up to the world, ``body`` first."""
        out = [body]
        while out[-1] != 0:
            out.append(int(self.parent[out[-1]]))
        return out

    def path_joints(self, top: int, bottom: int) -> list[int]:
        """Joints of the bodies from below ``top`` down to ``bottom`` (both bodies'
        joints included when ``top`` is on the path), root first."""
        bodies = self.ancestors(bottom)
        if top in bodies:
            bodies = bodies[: bodies.index(top) + 1]
        js: list[int] = []
        for b in reversed(bodies):
            adr, num = self.m.body_jntadr[b], self.m.body_jntnum[b]
            js += list(range(adr, adr + num))
        return js

    def rigid_below(self, body: int) -> list[int]:
        """``body`` and the bodies attached to it (recursively) by no joint."""
        out, todo = [], [body]
        while todo:
            b = todo.pop()
            out.append(b)
            todo += [
                c
                for c in range(1, self.m.nbody)
                if self.parent[c] == b and self.m.body_jntnum[c] == 0 and c != b
            ]
        return out


def _moving(m: mujoco.MjModel, j: int) -> bool:
    return int(m.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)


def _hinge(m: mujoco.MjModel, j: int) -> bool:
    return int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_HINGE


def find_limbs(model: mujoco.MjModel) -> Profile:
    """The limbs of ``model`` found from its tree and names (see the module's rules).

    A limb that cannot be found is left out (a robot with one arm and no sides gets an
    ``arm``; a model with no arm joints, none); what was decided is in the profile's
    notes.
    """
    t = _Tree(model)
    m = model
    notes: list[str] = []
    info: dict[int, tuple[str | None, str | None]] = {}
    for j in range(m.njnt):
        if not _moving(m, j):
            continue
        words = name_words(t.name(mujoco.mjtObj.mjOBJ_JOINT, j))
        info[j] = (_kind(words), _side(words))

    arm_js = {s: [j for j, (k, sd) in info.items() if k == "arm" and sd == s] for s in _SIDE_NAMES}
    unsided = [j for j, (k, sd) in info.items() if k == "arm" and sd is None]
    source, forward_from = "names", ""
    forward = np.array([1.0, 0.0, 0.0])
    if arm_js["left"] and arm_js["right"]:
        left = t.d.xanchor[arm_js["left"][0]] - t.d.xanchor[arm_js["right"][0]]
        left[2] = 0.0
        if np.linalg.norm(left) > 1e-6:
            fwd = np.cross(left, [0.0, 0.0, 1.0])
            forward, forward_from = fwd / np.linalg.norm(fwd), "arms"
    elif unsided and len({_branch_key(t, j, unsided) for j in unsided}) == 2:
        arm_js, source = _sides_by_geometry(t, unsided, forward), "geometry"
        notes.append("the arms' joints name no side: sides from geometry, +x forward")

    limbs: dict[str, Limb] = {}
    firsts: list[int] = []
    for side in _SIDE_NAMES:
        js = _arm_path(t, arm_js[side], info)
        if js:
            end_kind, end_name = _hand_frame(t, int(m.jnt_bodyid[js[-1]]))
            limbs[f"{side}_arm"] = Limb(
                f"{side}_arm", tuple(_jname(t, j) for j in js), end_kind, end_name, None, source
            )
            firsts.append(int(m.jnt_bodyid[js[0]]))
    if not limbs:
        single = _single_arm(t, info)
        if single:
            end_kind, end_name = _hand_frame(t, int(m.jnt_bodyid[single[-1]]))
            limbs["arm"] = Limb("arm", tuple(_jname(t, j) for j in single), end_kind, end_name)
            notes.append("no left/right arm joints: the longest hinge path is the arm")

    branch = _common_ancestor(t, firsts) if len(firsts) == 2 else None
    if branch is not None:
        torso = [
            j
            for j in t.path_joints(0, branch)
            if j in info and info[j][0] not in ("leg", "finger", "head")
        ]
        if torso:
            limbs["torso"] = Limb("torso", tuple(_jname(t, j) for j in torso), source="tree")
    head = _head(t, info, forward)
    if head is not None:
        limbs["head"] = head
        if not head.joints:
            notes.append(
                f"the head has no joints: fixed, gaze frame {head.frame} '{head.frame_name}'"
            )
    for side in _SIDE_NAMES:
        leg = [j for j, (k, sd) in info.items() if k == "leg" and sd == side]
        if leg:
            limbs[f"{side}_leg"] = Limb(f"{side}_leg", tuple(_jname(t, j) for j in sorted(leg)))
    order = {n: i for i, n in enumerate(LIMB_NAMES)}
    ordered = dict(sorted(limbs.items(), key=lambda kv: order[kv[0]]))
    fwd3 = (float(forward[0]), float(forward[1]), float(forward[2]))
    return Profile(ordered, fwd3, tuple(notes), forward_from)


_SIDE_NAMES = ("left", "right")


def _jname(t: _Tree, j: int) -> str:
    return t.name(mujoco.mjtObj.mjOBJ_JOINT, j)


def _sides_by_geometry(
    t: _Tree, joints: list[int], forward: NDArray[np.float64]
) -> dict[str, list[int]]:
    """Arm joints without a side word split by the side of the robot their first joint
    is on (``left`` = up x forward)."""
    left_dir = np.cross([0.0, 0.0, 1.0], forward)
    root = t.d.xpos[1] if t.m.nbody > 1 else np.zeros(3)
    groups: dict[int, list[int]] = {}
    for j in joints:  # group by branch: the body below the arms' common ancestor
        groups.setdefault(_branch_key(t, j, joints), []).append(j)
    out: dict[str, list[int]] = {"left": [], "right": []}
    for js in groups.values():
        y = float(np.dot(t.d.xanchor[min(js)] - root, left_dir))
        out["left" if y > 0 else "right"] += js
    return out


def _branch_key(t: _Tree, j: int, joints: list[int]) -> int:
    """The topmost body among ``joints``' bodies that is an ancestor of ``j``'s body."""
    mine = t.ancestors(int(t.m.jnt_bodyid[j]))
    bodies = {int(t.m.jnt_bodyid[k]) for k in joints}
    top = [b for b in mine if b in bodies]
    return top[-1]


def _arm_path(
    t: _Tree, joints: list[int], info: Mapping[int, tuple[str | None, str | None]]
) -> list[int]:
    """The hinge joints from the first to the last of ``joints`` along the tree (the
    deepest one's path), without fingers; empty when ``joints`` is."""
    if not joints:
        return []
    deepest = max(joints, key=lambda j: len(t.ancestors(int(t.m.jnt_bodyid[j]))))
    path = t.path_joints(0, int(t.m.jnt_bodyid[deepest]))
    on = [j for j in path if j in joints]
    if not on:
        return []
    first = path.index(on[0])
    last = path.index(on[-1])
    return [
        j for j in path[first : last + 1] if _hinge(t.m, j) and info.get(j, (None,))[0] != "finger"
    ]


def _single_arm(t: _Tree, info: Mapping[int, tuple[str | None, str | None]]) -> list[int]:
    """The longest path of hinges (not fingers, legs or the head) from the root: the arm
    of a robot without sides."""
    best: list[int] = []
    for b in range(1, t.m.nbody):
        js = [
            j
            for j in t.path_joints(0, b)
            if _hinge(t.m, j) and info.get(j, (None,))[0] not in ("finger", "leg", "head")
        ]
        if len(js) > len(best):
            best = js
    return best


def _common_ancestor(t: _Tree, bodies: Sequence[int]) -> int:
    paths = [t.ancestors(b)[::-1] for b in bodies]
    common = 0
    for level in zip(*paths, strict=False):
        if len(set(level)) != 1:
            break
        common = level[0]
    return int(t.parent[common]) if common in bodies else common


def _frames_on(t: _Tree, bodies: Sequence[int]) -> list[tuple[str, str, int]]:
    """(kind, name, body) of every named site and body among ``bodies``."""
    out = [("body", t.name(mujoco.mjtObj.mjOBJ_BODY, b), b) for b in bodies]
    for s in range(t.m.nsite):
        if int(t.m.site_bodyid[s]) in bodies:
            out.append(("site", t.name(mujoco.mjtObj.mjOBJ_SITE, s), int(t.m.site_bodyid[s])))
    return [f for f in out if f[1]]


def _frame_pos(t: _Tree, kind: str, name: str) -> NDArray[np.float64]:
    if kind == "site":
        return np.asarray(t.d.site(name).xpos)
    if kind == "camera":
        return np.asarray(t.d.cam(name).xpos)
    return np.asarray(t.d.body(name).xpos)


def _hand_frame(t: _Tree, body: int) -> tuple[str, str]:
    """The end frame of an arm whose last joint moves ``body`` (see the module)."""
    cands = _frames_on(t, t.rigid_below(body))
    wrist = np.asarray(t.d.xpos[body])

    def score(f: tuple[str, str, int]) -> tuple[int, int, float]:
        words = set(name_words(f[1]))
        if frame_role(f[1]) not in (None, "hand"):  # a sensor, camera, finger, part ...
            return (-1, 0, 0.0)
        s = max((v for ws, v in _END_SCORES if words & ws), default=0)
        dist = float(np.linalg.norm(_frame_pos(t, f[0], f[1]) - wrist))
        return (s, 1 if f[0] == "site" else 0, dist)

    best = max(cands, key=score)
    if score(best)[0] <= 0:
        return "body", t.name(mujoco.mjtObj.mjOBJ_BODY, body)
    return best[0], best[1]


def _head(
    t: _Tree, info: Mapping[int, tuple[str | None, str | None]], forward: NDArray[np.float64]
) -> Limb | None:
    """The head: its joints on one path and its gaze frame; a head body without joints
    is a fixed head."""
    js = sorted(j for j, (k, _) in info.items() if k == "head")
    if js:
        deepest = max(js, key=lambda j: len(t.ancestors(int(t.m.jnt_bodyid[j]))))
        path = t.path_joints(0, int(t.m.jnt_bodyid[deepest]))
        js = [j for j in path if j in js and _hinge(t.m, j)]
        body = int(t.m.jnt_bodyid[js[-1]])
    else:
        heads = [
            b
            for b in range(1, t.m.nbody)
            if "head" in name_words(t.name(mujoco.mjtObj.mjOBJ_BODY, b))
        ]
        if not heads:
            return None
        body = min(heads, key=lambda b: len(t.ancestors(b)))
    below = t.rigid_below(body)
    frames = _frames_on(t, below)
    gaze = [f for f in frames if set(name_words(f[1])) & _GAZE_WORDS and f[0] == "site"]
    cams = [
        ("camera", t.name(mujoco.mjtObj.mjOBJ_CAMERA, c), int(t.m.cam_bodyid[c]))
        for c in range(t.m.ncam)
        if int(t.m.cam_bodyid[c]) in below and t.name(mujoco.mjtObj.mjOBJ_CAMERA, c)
    ]
    gaze_bodies = [f for f in frames if set(name_words(f[1])) & {"gaze"} and f[0] == "body"]
    if gaze:
        kind, name, _ = gaze[0]
    elif cams:
        kind, name, _ = cams[0]
    elif gaze_bodies:
        kind, name, _ = gaze_bodies[0]
    else:
        kind, name = "body", t.name(mujoco.mjtObj.mjOBJ_BODY, body)
    if kind == "camera":  # the gaze is the camera's view (its -z) in its body's frame
        cam = t.m.camera(name).id
        body_id = int(t.m.cam_bodyid[cam])
        view = t.d.cam_xmat[cam].reshape(3, 3) @ np.array([0.0, 0.0, -1.0])
        axis = t.d.xmat[body_id].reshape(3, 3).T @ view
        kind, name = "body", t.name(mujoco.mjtObj.mjOBJ_BODY, body_id)
    else:
        xmat = t.d.site_xmat[t.m.site(name).id] if kind == "site" else t.d.xmat[t.m.body(name).id]
        axis = xmat.reshape(3, 3).T @ forward
    axis = axis / np.linalg.norm(axis)
    return Limb(
        "head",
        tuple(_jname(t, j) for j in js),
        kind,
        name,
        (float(axis[0]), float(axis[1]), float(axis[2])),
    )


# ----------------------------------------------------------------------------- profiles
def profile_file(model_path: str | os.PathLike) -> Path:
    """Where the profile of the model file ``model_path`` is looked for: beside it,
    ``<stem>.limbs.toml``."""
    p = Path(model_path)
    return p.with_name(p.name.split(".")[0] + ".limbs.toml")


def profile_for(
    model: mujoco.MjModel,
    model_path: str | os.PathLike | None = None,
    override: str | os.PathLike | None = None,
) -> Profile:
    """The limbs of ``model``: those found (:func:`find_limbs`), each replaced by the
    profile file's where it names that limb. The profile file is ``override`` if given,
    else ``<stem>.limbs.toml`` beside ``model_path`` if there is one.

    Raises:
        ModelError: the profile file is missing (an explicit ``override``), is not
            TOML, or names a limb, joint or frame the model lacks.
    """
    found = find_limbs(model)
    path: Path | None = Path(override) if override is not None else None
    if path is None and model_path is not None and profile_file(model_path).is_file():
        path = profile_file(model_path)
    if path is None:
        return found
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ModelError(f"limb profile '{path}' cannot be read: {exc.strerror}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(f"limb profile '{path}' is not TOML: {exc}") from exc
    return _merge(model, found, data, path)


def _merge(model: mujoco.MjModel, found: Profile, data: Mapping[str, Any], path: Path) -> Profile:
    limbs = dict(found.limbs)
    table = data.get("limbs", {})
    if not isinstance(table, dict):
        raise ModelError(f"{path}: limbs: must be a table of limbs")
    for name, entry in table.items():
        if name not in LIMB_NAMES:
            raise ModelError(
                f"{path}: limbs.{name}: not a limb name; valid: {', '.join(LIMB_NAMES)}"
            )
        if not isinstance(entry, dict):
            raise ModelError(f"{path}: limbs.{name}: must be a table")
        old = limbs.get(name)
        joints = entry.get("joints", list(old.joints) if old else [])
        for j in joints:
            if not isinstance(j, str) or mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) < 0:
                raise ModelError(f"{path}: limbs.{name}.joints: no joint '{j}' in the model")
        frame, frame_name = (old.frame, old.frame_name) if old else ("", "")
        for kind, obj in (("site", mujoco.mjtObj.mjOBJ_SITE), ("body", mujoco.mjtObj.mjOBJ_BODY)):
            if kind in entry:
                if mujoco.mj_name2id(model, obj, str(entry[kind])) < 0:
                    raise ModelError(
                        f"{path}: limbs.{name}.{kind}: no {kind} '{entry[kind]}' in the model"
                    )
                frame, frame_name = kind, str(entry[kind])
        axis = entry.get("axis", old.axis if old else None)
        if axis is not None:
            a = np.asarray(axis, dtype=np.float64)
            if (
                a.shape != (3,)
                or not math.isfinite(float(np.linalg.norm(a)))
                or np.linalg.norm(a) == 0
            ):
                raise ModelError(f"{path}: limbs.{name}.axis: must be 3 numbers, not all zero")
            a = a / np.linalg.norm(a)
            axis = (float(a[0]), float(a[1]), float(a[2]))
        limbs[name] = Limb(name, tuple(joints), frame, frame_name, axis, "profile")
    fwd = data.get("forward", found.forward)
    src = "profile" if "forward" in data else found.forward_from
    return Profile(limbs, tuple(float(v) for v in fwd), found.notes, src)  # type: ignore[arg-type]


def limb_chain(
    robot: Robot | mujoco.MjModel,
    limb: str,
    *,
    with_torso: bool = False,
    profile: Profile | None = None,
) -> Chain:
    """The chain of ``robot``'s limb ``limb`` (an arm or the head): its joints, with the
    torso's before them when ``with_torso``, ending at the limb's end frame.

    Raises:
        ChainError: the model has no such limb, or it has no joints (a fixed head).
    """
    robot = robot if isinstance(robot, Robot) else Robot(robot)
    prof = profile if profile is not None else find_limbs(robot.model)
    found = prof.limb(limb)
    if not found.frame:
        raise ChainError(
            f"limb '{limb}' has no end frame to reach with; limbs that have: "
            + ", ".join(n for n, lb in prof.limbs.items() if lb.frame)
        )
    joints = list(found.joints)
    if with_torso and "torso" in prof.limbs:
        joints = list(prof.limbs["torso"].joints) + joints
    if not joints:
        raise ChainError(f"limb '{limb}' has no joints (it is fixed): nothing to solve")
    return Chain(robot, joints=joints, **found.end())
