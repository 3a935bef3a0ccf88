"""The human side of a retarget: which joints of a BVH skeleton are the arms, the head and
the hips, and what they do over the frames.

Joints are found by name, in the families of the common skeletons. A name is compared
without its namespace (``mixamorig:LeftArm`` -> ``LeftArm``), case, ``_``, ``-``, ``.``
or spaces, with a side word before or after it (``Left``/``L``, ``Right``/``R``:
``LeftArm``, ``lShldr``, ``upperarm_l``, ``upper_arm.L``). The part words, first match
wins:

- shoulder (the upper arm's joint: where the arm turns): ``Arm`` (CMU, Mixamo,
  LAFAN1), ``UpArm``, ``UpperArm``, ``Shldr`` (Poser), ``Humerus``, then ``Shoulder``
  (skeletons with no clavicle, whose shoulder joint is called so; CMU's, Mixamo's and
  LAFAN1's ``LeftShoulder`` is the clavicle and is only taken when nothing else is);
- elbow: ``ForeArm``, ``LowArm``, ``LowerArm``, ``Elbow``, ``Radius``;
- wrist: ``Hand``, ``Wrist``;
- the hand point (where the robot's hand frame goes): the mean of the wrist's children
  (its end site, or the finger roots: the middle of the palm's far edge);
- head ``Head``, neck ``Neck``; the heading from the thighs (``UpLeg``, ``Thigh``,
  ``UpperLeg``) when found, else from the shoulders.

A mapping file (TOML) overrides any of them by node name::

    [joints]
    left_shoulder = "LeftArm"
    left_elbow = "LeftForeArm"
    left_wrist = "LeftHand"
    left_hand = "LeftHand_end"      # the hand point
    head = "Head"

Keys: :data:`ROLES`. Optional ``limbs = "robot.limbs.toml"`` (a robot limb profile,
relative to the mapping file) names the robot's limbs where they are not found
(``core/limbs.py``).
"""

from __future__ import annotations

import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import RetargetError, choices
from humanoid_ik.motion.bvh import BVHClip, BVHError

__all__ = ["ROLES", "SIDES", "HumanArm", "HumanSide", "RetargetError", "find_human", "Mapping"]

SIDES = ("left", "right")
_PARTS = {
    "shoulder": ("arm", "uparm", "upperarm", "shldr", "humerus", "shoulder"),
    "elbow": ("forearm", "lowarm", "lowerarm", "elbow", "radius"),
    "wrist": ("hand", "wrist"),
    "thigh": ("upleg", "thigh", "upperleg"),
}
_SHOWN = {
    "shoulder": ("Arm", "UpArm", "UpperArm", "Shldr", "Humerus", "Shoulder"),
    "elbow": ("ForeArm", "LowArm", "LowerArm", "Elbow", "Radius"),
    "wrist": ("Hand", "Wrist"),
}
_SIDE_WORDS = {"left": ("left", "l"), "right": ("right", "r")}
ROLES = tuple(f"{s}_{p}" for s in SIDES for p in ("shoulder", "elbow", "wrist", "hand")) + (
    "head",
    "neck",
    "left_thigh",
    "right_thigh",
)
"""The roles a mapping file may name (``[joints]`` keys)."""


def _key(name: str) -> str:
    return re.sub(r"[\s_.\-]", "", name.rsplit(":", 1)[-1]).lower()


def _sided(side: str, part: str) -> list[str]:
    """Normalised names of ``part`` on ``side``: ``leftarm``, ``larm``, ``armleft``, ``arml``."""
    words = _PARTS[part]
    return [w2 for w in words for s in _SIDE_WORDS[side] for w2 in (s + w, w + s)]


@dataclass(frozen=True)
class Mapping:
    """What a mapping file says: node names by role, and a robot limb profile (or none)."""

    joints: dict[str, str]
    limbs: Path | None = None
    source: str = ""

    @classmethod
    def read(cls, path: str | os.PathLike[str]) -> Mapping:
        """A mapping file read (see the module).

        Raises:
            RetargetError: the file cannot be read, is not TOML, or has an unknown key.
        """
        p = Path(path)
        try:
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except OSError as exc:
            raise RetargetError(f"mapping file '{p}' cannot be read: {exc.strerror}") from None
        except tomllib.TOMLDecodeError as exc:
            raise RetargetError(f"mapping file '{p}' is not TOML: {exc}") from None
        bad = sorted(set(data) - {"joints", "limbs"})
        if bad:
            raise RetargetError(f"{p}: key '{bad[0]}' unknown; keys: joints, limbs")
        joints = data.get("joints", {})
        if not isinstance(joints, dict):
            raise RetargetError(f'{p}: joints: must be a table of role = "node name"')
        for role, name in joints.items():
            if role not in ROLES:
                raise RetargetError(f"{p}: joints.{role}: not a role; roles: {choices(ROLES)}")
            if not isinstance(name, str) or not name:
                raise RetargetError(f"{p}: joints.{role}: must be a node name (a string)")
        limbs = data.get("limbs")
        if limbs is not None and not isinstance(limbs, str):
            raise RetargetError(f"{p}: limbs: must be the path of a limb profile (a string)")
        return cls(dict(joints), None if limbs is None else p.parent / limbs, str(p))


@dataclass(frozen=True)
class HumanArm:
    """One human arm: the node indices of its shoulder, elbow and wrist and the nodes whose
    mean is the hand point, with its rest length [m] (upper arm + forearm + hand point)."""

    side: str
    shoulder: int
    elbow: int
    wrist: int
    hand: tuple[int, ...]
    length: float

    def hand_point(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(F, 3)`` the hand point over the frames of ``positions (F, N, 3)``."""
        return positions[:, list(self.hand)].mean(axis=1)


@dataclass(frozen=True)
class HumanSide:
    """What a retarget reads from the human: its arms, head and heading."""

    arms: dict[str, HumanArm]
    head: int | None
    neck: int | None
    heading_pair: tuple[int, int]
    names: dict[str, str]

    def heading(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(F, 3, 3)`` the human's heading frame per frame: columns forward, left, up
        (up = world z; left along the horizontal line from the right thigh, or shoulder,
        to the left one)."""
        left = positions[:, self.heading_pair[0]] - positions[:, self.heading_pair[1]]
        left[:, 2] = 0.0
        left /= np.maximum(np.linalg.norm(left, axis=1, keepdims=True), 1e-12)
        up = np.broadcast_to([0.0, 0.0, 1.0], left.shape)
        fwd = np.cross(left, up)
        return np.stack([fwd, left, up], axis=2)


def _find(names: tuple[str, ...], candidates: list[str], skip: set[int]) -> int | None:
    keys = [_key(n) for n in names]
    for c in candidates:
        for i, k in enumerate(keys):
            if k == c and i not in skip:
                return i
    return None


def find_human(clip: BVHClip, mapping: Mapping | None = None) -> HumanSide:
    """The arms, head and heading of ``clip``'s skeleton (see the module's rules).

    Raises:
        RetargetError: no arm found (the names looked for are listed), or a node the
            mapping names is not in the skeleton.
    """
    sk = clip.skeleton
    given = {} if mapping is None else mapping.joints
    for role, name in given.items():
        if name not in sk.names:
            raise RetargetError(
                f"{mapping.source if mapping else 'mapping'}: joints.{role}: node '{name}' "
                f"not in the BVH '{clip.source}'; nodes: {choices(sk.names)}"
            )
    found: dict[str, int] = {r: sk.names.index(n) for r, n in given.items()}
    joints_only = {i for i, e in enumerate(sk.end_sites) if e}
    for side in SIDES:
        for part in ("shoulder", "elbow", "wrist", "thigh"):
            role = f"{side}_{part}"
            if role not in found:
                i = _find(sk.names, _sided(side, part), joints_only | set(found.values()))
                if i is not None:
                    found[role] = i
    for role, words in (("head", ["head"]), ("neck", ["neck"])):
        if role not in found:
            i = _find(sk.names, words, joints_only)
            if i is not None:
                found[role] = i
    rest = clip.rest()
    arms: dict[str, HumanArm] = {}
    for side in SIDES:
        roles = [f"{side}_{p}" for p in ("shoulder", "elbow", "wrist")]
        if not all(r in found for r in roles):
            continue
        s, e, w = (found[r] for r in roles)
        if f"{side}_hand" in found:
            hand: tuple[int, ...] = (found[f"{side}_hand"],)
        else:
            kids = tuple(i for i, p in enumerate(sk.parents) if p == w)
            hand = kids or (w,)
        hp = rest[list(hand)].mean(axis=0)
        length = float(
            np.linalg.norm(rest[e] - rest[s])
            + np.linalg.norm(rest[w] - rest[e])
            + np.linalg.norm(hp - rest[w])
        )
        arms[side] = HumanArm(side, s, e, w, hand, length)
    if not arms:
        looked = "; ".join(f"{part} {'/'.join(_SHOWN[part])}" for part in _SHOWN)
        raise BVHError(
            clip.source,
            0,
            f"no arm found: looked for Left/Right (or L/R) + {looked} (CMU, Mixamo, LAFAN1 "
            "names); name them in a mapping file (--mapping)",
        )
    pair = None
    if "left_thigh" in found and "right_thigh" in found:
        pair = (found["left_thigh"], found["right_thigh"])
    elif len(arms) == 2:
        pair = (arms["left"].shoulder, arms["right"].shoulder)
    else:  # one arm, no thighs: the rest pose's heading is kept
        pair = None
    if pair is None:
        raise RetargetError(
            f"'{clip.source}': cannot tell the human's heading: no Left/RightUpLeg and only "
            "one arm; name left_thigh and right_thigh in a mapping file"
        )
    names = {r: sk.names[i] for r, i in found.items()}
    return HumanSide(arms, found.get("head"), found.get("neck"), pair, names)
