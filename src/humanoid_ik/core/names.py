"""What the names of a model's joints, bodies and sites say: their words, and the
vocabularies that tell a limb's joints (``shoulder``, ``hip``, ``neck`` ...) and a
frame's role (a sensor, a camera, a finger, a hand) from them. Used by the limbs
(``core/limbs.py``) and ``inspect``'s end effectors alike. Also the one fallback for an
unnamed joint (:func:`joint_name`), and the one rule for the names the package makes
paths of (:data:`NAME`: a scene's name becomes ``renders/<name>``, ``<name>.mp4``,
``renders/<name>_replay``; a sweep's ``renders/sweeps/<name>``), wherever the name comes
from: a TOML file, a trajectory file's header, a script.
"""

from __future__ import annotations

import re

import mujoco

from humanoid_ik.errors import MotionError

__all__ = [
    "FRAME_WORDS",
    "HAND_WORDS",
    "KIND_ORDER",
    "KIND_WORDS",
    "MAX_NAME",
    "NAME",
    "NAME_PATTERN",
    "check_name",
    "frame_role",
    "joint_name",
    "name_ok",
    "name_words",
]

MAX_NAME = 100
"""Longest name [characters]: ``<name>_replay``, ``<name>.mp4`` stay well within the
255 bytes a file name may have."""
NAME_PATTERN = re.compile(rf"[A-Za-z0-9][A-Za-z0-9_.-]{{0,{MAX_NAME - 1}}}")
"""A name the package may make a file or folder name of: no separator, never ``.``,
``..``, a hidden name or an option-like ``-x``, never empty."""
NAME = (
    f"a name of letters, digits, '_', '-' or '.' (at most {MAX_NAME}, starting with a "
    "letter or digit)"
)
"""What a name (of a scene, a sweep, a target set) must be, as messages say it."""

KIND_WORDS: dict[str, frozenset[str]] = {
    "finger": frozenset(
        "finger fingers thumb pinky mrl knuckle gripper grip claw hand hands fingertip tip "
        "nail palm jaw".split()
    ),
    "leg": frozenset("hip knee ankle leg legs foot toe toes sole thigh shin calf".split()),
    "head": frozenset("head neck cervical".split()),
    "torso": frozenset("torso waist trunk spine chest lumbar thoracic abdomen pelvis body".split()),
    "arm": frozenset("shoulder sh elbow wrist wr arm forearm upperarm lowerarm".split()),
}
KIND_ORDER = ("finger", "leg", "head", "torso", "arm")
"""The first kind whose words a name has wins (``hand_left_index`` is a finger, though
``left`` is a side, and ``arm_left_7`` an arm)."""

FRAME_WORDS: dict[str, frozenset[str]] = {
    "sensor": frozenset(
        "sensor sensors imu ft accelerometer accel gyro gyrometer gyroscope magnetometer "
        "sonar lidar laser range fsr touch skin force torque bumper mid360".split()
    ),
    "camera": frozenset(
        "camera cameras cam optical depth rgb rgbd stereo realsense kinect xtion d435 d455 "
        "t265".split()
    ),
    "finger": frozenset(
        "finger fingers fingertip thumb index middle ring little pinky knuckle nail phalanx".split()
    ),
    "helper": frozenset("visual collision dummy logo display screen itb dh antenna world".split()),
}
"""Words that make a frame a sensor, a camera, a finger or a helper (a visual or
collision stand-in, a display, a reference or world frame), never an end effector. A
word of five letters or more also matches the words it begins (``dummyhead``), one of
six or more the words that hold it (``leftfinger``); a letter word followed by a number
word is also read joined (``d435``, ``mid360``)."""
HAND_WORDS = frozenset("hand hands gripper tool palm flange tcp ee eef effector end grasp".split())
"""Words that name a hand link or a tool frame."""
_PART_WORDS = frozenset(
    "motor inner outer double single jaw coupler spring driver follower pad lever".split()
)
"""Words that, with a hand word, name a part of a gripper's mechanism."""


def name_words(name: str) -> list[str]:
    """``name`` split into lower-case words at separators, case changes and digits, with
    a side letter glued to a known word split off (``RARM`` -> ``r arm``)."""
    parts = re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+", name)
    out: list[str] = []
    known = set().union(*KIND_WORDS.values())
    for p in parts:
        w = p.lower()
        if len(w) > 1 and w[0] in "lr" and w not in known and w[1:] in known:
            out += [w[0], w[1:]]
        else:
            out.append(w)
    # ``LShoulder``: the regex gives ``L`` then ``Shoulder`` already
    return out


def _words(name: str) -> set[str]:
    """The words of ``name``, plus each letter word joined with the number after it."""
    ws = name_words(name)
    joined = {a + b for a, b in zip(ws, ws[1:], strict=False) if a.isalpha() and b.isdigit()}
    return set(ws) | joined


def _contains(word: str, vocab_word: str) -> bool:
    """``word`` begins with a vocabulary word of 5 letters or more (``dummyhead``), or
    holds one of 6 or more (``leftfinger``)."""
    n = len(vocab_word)
    return (n >= 5 and word.startswith(vocab_word)) or (n >= 6 and vocab_word in word)


def frame_role(name: str) -> str | None:
    """What a frame's name says it is: ``sensor``, ``camera``, ``finger``, ``helper``
    (:data:`FRAME_WORDS`), ``part`` (a gripper's mechanism: a hand word with a part
    word), ``hand`` (:data:`HAND_WORDS`), or ``None`` (nothing said)."""
    words = _words(name)
    for role, vocab in FRAME_WORDS.items():
        if words & vocab or any(_contains(w, v) for w in words for v in vocab):
            return role
    if words & HAND_WORDS:
        return "part" if words & _PART_WORDS else "hand"
    return None


def name_ok(value: object, *, first_alphanumeric: bool = True) -> bool:
    """``value`` is a :data:`NAME` (:data:`NAME_PATTERN`). ``first_alphanumeric`` is
    accepted for the callers that asked for the first character's rule, which every
    name now follows."""
    return isinstance(value, str) and NAME_PATTERN.fullmatch(value) is not None


def check_name(what: str, value: object) -> str:
    """``value`` if it is a :data:`NAME`, else :class:`~humanoid_ik.errors.MotionError`
    ``(what, NAME, value)`` (the convention of the ``check_*`` of ``core/checks.py``:
    callers name the file or the object)."""
    if not name_ok(value):
        raise MotionError(what, NAME, value)
    return str(value)


def joint_name(model: mujoco.MjModel, j: int) -> str:
    """Joint ``j``'s name, or ``joint<j>`` for an unnamed joint: the one fallback."""
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j)) or f"joint{int(j)}"
