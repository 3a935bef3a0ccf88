"""Human motion capture made here: BVH clips of a procedural human skeleton.

The tests and the retargeting examples need real-looking human motion but cannot
download any. :func:`human_bvh` writes a BVH clip of a 1.75 m human (hips, a three-part
spine, neck, head, clavicles, upper arms, forearms, hands, legs and feet) in a T-pose
rest, with the joint names of the CMU database (``Hips``, ``LowerBack``, ``Spine``,
``Spine1``, ``Neck``, ``Head``, ``LeftShoulder``, ``LeftArm``, ``LeftForeArm``,
``LeftHand``, ``LeftUpLeg``, ...) or of Mixamo (``mixamorig:Hips``,
``mixamorig:LeftArm``, ...), and the conventions a caller chooses: the up axis (Y as
CMU and Mixamo, or Z), the unit (cm as CMU and Mixamo files, or m), the rotation
channel order and whether every joint carries position channels (Mixamo-style) or only
the root (CMU-style).

Motions (:data:`HUMAN_MOTIONS`), at 120 frames/s by default, smooth (every joint angle
follows minimum-jerk segments between held poses, or sinusoids eased in and out) and in
human ranges of motion:

- ``reach``: the right arm reaches to five points in turn (forward, up, across the
  body, high to the side, low), 2 s each, the torso leaning and turning and the head
  looking toward the hand, the left arm swinging a little;
- ``wave``: the right arm raised to the side, the forearm up, waving at 2 Hz;
- ``arm_circles``: both arms out to the sides drawing circles at 0.75 Hz.

The angles of a joint are built in anatomical terms (elevation, plane of elevation,
axial rotation, elbow flexion) as rotation matrices, then written in the file's channel
order (:func:`~humanoid_ik.motion.bvh.euler_angles`). The shipped clips of ``motions/``
are :data:`SHIPPED`, made by ``python -m humanoid_ik.motion.human motions``.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.errors import MotionError, choices
from humanoid_ik.motion.bvh import UNITS, Z_UP_FROM_Y_UP, axis_rotations, euler_angles

__all__ = ["HUMAN_MOTIONS", "SHIPPED", "STYLES", "HumanStyle", "human_bvh", "write_shipped"]

HUMAN_MOTIONS = ("reach", "wave", "arm_circles")
"""The motions :func:`human_bvh` makes."""
MAX_SECONDS = 600.0
"""The longest clip [s]."""


@dataclass(frozen=True)
class HumanStyle:
    """A family of BVH files: joint names and their defaults.

    Attributes:
        prefix: put before every joint name (``mixamorig:``).
        names: the family's name of each part of the skeleton (:data:`_BONES` keys).
        order: the rotation channel order of every joint.
        positions: ``root`` (position channels on the root only) or ``all``.
    """

    prefix: str
    names: dict[str, str]
    order: str
    positions: str


_SIDES = {"Shoulder": "clav", "Arm": "arm", "ForeArm": "fore", "Hand": "hand"}
_LEGS = {"UpLeg": "thigh", "Leg": "shin", "Foot": "foot", "ToeBase": "toe"}


def _sided(spine: tuple[str, str, str]) -> dict[str, str]:
    out = {"hips": "Hips", "spine0": spine[0], "spine1": spine[1], "chest": spine[2]}
    out |= {"neck": "Neck", "head": "Head"}
    for side, word in (("l", "Left"), ("r", "Right")):
        out |= {f"{side}_{part}": f"{word}{name}" for name, part in {**_SIDES, **_LEGS}.items()}
    return out


STYLES = {
    "cmu": HumanStyle("", _sided(("LowerBack", "Spine", "Spine1")), "ZYX", "root"),
    "mixamo": HumanStyle("mixamorig:", _sided(("Spine", "Spine1", "Spine2")), "ZXY", "all"),
}
"""The joint-name families: CMU (``Zrotation Yrotation Xrotation`` channels, positions
on the root) and Mixamo (``Zrotation Xrotation Yrotation``, positions on every joint)."""

# part -> (parent, offset [m] in the canonical frame: Y up, facing +Z, left +X), in file
# order (depth first); the end sites after their joint
_BONES: dict[str, tuple[str, tuple[float, float, float]]] = {
    "hips": ("", (0.0, 0.95, 0.0)),
    "spine0": ("hips", (0.0, 0.10, -0.01)),
    "spine1": ("spine0", (0.0, 0.12, 0.0)),
    "chest": ("spine1", (0.0, 0.14, 0.01)),
    "neck": ("chest", (0.0, 0.16, 0.0)),
    "head": ("neck", (0.0, 0.10, 0.02)),
}
for _s, _x in (("l", 1.0), ("r", -1.0)):
    _BONES |= {
        f"{_s}_clav": ("chest", (0.03 * _x, 0.12, 0.0)),
        f"{_s}_arm": (f"{_s}_clav", (0.15 * _x, 0.0, 0.0)),
        f"{_s}_fore": (f"{_s}_arm", (0.29 * _x, 0.0, 0.0)),
        f"{_s}_hand": (f"{_s}_fore", (0.26 * _x, 0.0, 0.0)),
    }
for _s, _x in (("l", 1.0), ("r", -1.0)):
    _BONES |= {
        f"{_s}_thigh": ("hips", (0.09 * _x, -0.05, 0.0)),
        f"{_s}_shin": (f"{_s}_thigh", (0.0, -0.43, 0.0)),
        f"{_s}_foot": (f"{_s}_shin", (0.0, -0.42, 0.0)),
        f"{_s}_toe": (f"{_s}_foot", (0.0, -0.04, 0.13)),
    }
_ENDS = {"head": (0.0, 0.18, 0.0), "l_hand": (0.09, 0.0, 0.0), "r_hand": (-0.09, 0.0, 0.0)}
_ENDS |= {"l_toe": (0.0, 0.0, 0.05), "r_toe": (0.0, 0.0, 0.05)}
_ORDER = [b for b in _BONES if b.startswith(("hips", "spine", "chest", "neck", "head"))]
_ORDER += [b for b in _BONES if b[2:] in _SIDES.values()]
_ORDER += [b for b in _BONES if b[2:] in _LEGS.values()]


def _children(part: str) -> list[str]:
    return [b for b in _ORDER if _BONES[b][0] == part]


# --------------------------------------------------------------------------- angles


def _minjerk(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """The minimum-jerk blend ``10 u^3 - 15 u^4 + 6 u^5`` of ``u`` clipped to [0, 1]."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u * u)


def _keys(t: NDArray[np.float64], keys: list[tuple[float, float]]) -> NDArray[np.float64]:
    """A curve through held values ``keys`` (time [s], value), minimum jerk between
    consecutive keys, held before the first and after the last."""
    out = np.full(t.shape, keys[0][1])
    for (t0, v0), (t1, v1) in zip(keys[:-1], keys[1:], strict=True):
        out = np.where(t >= t0, v0 + (v1 - v0) * _minjerk((t - t0) / max(t1 - t0, 1e-9)), out)
    return out


_NEUTRAL = {"plane": 15.0, "elev": 10.0, "ext": 0.0, "elbow": 15.0}
_REACHES = [  # right arm (plane, elev, ext, elbow); torso (lean, twist); head (yaw, pitch)
    ((60.0, 80.0, 0.0, 10.0), (8.0, -10.0), (-20.0, 0.0)),
    ((45.0, 115.0, 10.0, 20.0), (3.0, -6.0), (-15.0, -15.0)),
    ((95.0, 55.0, -10.0, 35.0), (6.0, 10.0), (10.0, 10.0)),
    ((10.0, 105.0, 20.0, 10.0), (0.0, -12.0), (-35.0, -5.0)),
    ((50.0, 40.0, 0.0, 5.0), (14.0, -8.0), (-15.0, 20.0)),
]


def _reach(t: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    names = ("plane", "elev", "ext", "elbow")
    keys: dict[str, list[tuple[float, float]]] = {f"r_{n}": [(0.0, _NEUTRAL[n])] for n in names}
    for n in ("lean", "twist", "head_yaw", "head_pitch"):
        keys[n] = [(0.0, 0.0)]
    k, start = 0, 0.05
    while start < float(t[-1]) + 1e-9:
        arm, torso, head = _REACHES[k % len(_REACHES)]
        out, back = start + 0.85, start + 1.05
        for n, v in zip(names, arm, strict=True):
            keys[f"r_{n}"] += [(out, v), (back, v), (back + 0.85, _NEUTRAL[n])]
        for n, v in zip(("lean", "twist", "head_yaw", "head_pitch"), torso + head, strict=True):
            keys[n] += [(out, v), (back, v), (back + 0.85, 0.0)]
        k, start = k + 1, start + 2.0
    a = {n: _keys(t, v) for n, v in keys.items()}
    swing = 6.0 * np.sin(2 * math.pi * 0.5 * t) * _minjerk(t / 0.5)
    a |= {"l_plane": _NEUTRAL["plane"] + swing, "l_elbow": _NEUTRAL["elbow"] + 0.5 * swing}
    return a


def _eased(t: NDArray[np.float64], ramp: float) -> NDArray[np.float64]:
    """1 in the middle of the clip, eased from 0 over ``ramp`` [s] at both ends."""
    return _minjerk(t / ramp) * _minjerk((t[-1] - t) / ramp)


def _wave(t: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    up = _eased(t, 1.2)
    waving = _eased(t, 1.6) * np.sin(2 * math.pi * 2.0 * t)
    a = {
        f"r_{n}": _NEUTRAL[n] + (v - _NEUTRAL[n]) * up
        for n, v in {"plane": 25.0, "elev": 95.0, "ext": 85.0, "elbow": 80.0}.items()
    }
    a["r_ext"] = a["r_ext"] + 22.0 * waving
    a["r_elbow"] = a["r_elbow"] + 6.0 * waving
    a |= {"head_yaw": -15.0 * up, "head_pitch": -5.0 * up, "twist": -6.0 * up, "bend": 3.0 * up}
    return a


def _circles(t: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    out = _eased(t, 1.0)
    w = 2 * math.pi * 0.75 * t
    a: dict[str, NDArray[np.float64]] = {}
    for s in ("l", "r"):
        a[f"{s}_elev"] = 10.0 + (80.0 + 18.0 * np.cos(w)) * out
        a[f"{s}_plane"] = 15.0 + (-3.0 + 18.0 * np.sin(w)) * out
        a[f"{s}_elbow"] = 15.0 - 10.0 * out
        a[f"{s}_ext"] = 0.0 * t
    a["lean"] = 2.0 * np.sin(w) * out
    return a


_MAKERS = {"reach": _reach, "wave": _wave, "arm_circles": _circles}


def _local(part: str, a: dict[str, NDArray[np.float64]], F: int) -> NDArray[np.float64]:
    """``(F, 3, 3)`` the rotation of ``part`` relative to its parent (canonical axes)."""

    def get(name: str, default: float = 0.0) -> NDArray[np.float64]:
        return a.get(name, np.full(F, default))

    R = axis_rotations
    side, kind = part[:1], part[2:]
    m = 1.0 if side == "l" else -1.0  # the mirror: rotations about Y and Z change sign
    if kind == "arm":
        plane, elev = get(f"{side}_plane", 15.0), get(f"{side}_elev", 10.0)
        return R("Y", -m * plane) @ R("Z", m * (elev - 90.0)) @ R("X", -get(f"{side}_ext"))
    if kind == "fore":
        return R("Y", -m * get(f"{side}_elbow", 15.0))
    if kind == "clav":
        # the clavicle lifts with an arm raised past 60 degrees (a smooth softplus)
        lift = 5.0 * np.logaddexp(0.0, (get(f"{side}_elev", 10.0) - 80.0) / 12.0)
        return R("Z", m * lift)
    if kind == "hand":
        return R("Z", -m * 0.15 * get(f"{side}_elbow", 15.0))
    if part in ("spine0", "spine1", "chest"):
        third = 1.0 / 3.0
        lean = get("lean") + 0.8 * np.sin(2 * math.pi * 0.25 * a["t"])  # breathing
        return R("Y", third * get("twist")) @ R("X", third * lean) @ R("Z", third * get("bend"))
    if part in ("neck", "head"):
        share = 0.4 if part == "neck" else 0.6
        return R("Y", share * get("head_yaw")) @ R("X", share * get("head_pitch"))
    if part == "hips":
        return R("Y", 2.0 * np.sin(2 * math.pi * 0.2 * a["t"]))
    if kind == "shin":
        return R("X", np.full(F, 4.0))
    if kind == "thigh":
        return R("X", np.full(F, -2.0))
    if kind == "foot":
        return R("X", np.full(F, -2.0))
    return R("X", np.zeros(F))


# --------------------------------------------------------------------------- the file


def _check(motion: str, style: str, up: str, units: str, order: str, positions: str) -> None:
    for field, value, valid in (
        ("motion", motion, HUMAN_MOTIONS),
        ("style", style, tuple(STYLES)),
        ("up", up, ("y", "z")),
        ("units", units, tuple(UNITS)),
        ("positions", positions, ("root", "all")),
    ):
        if value not in valid:
            raise MotionError(field, f"one of {choices(valid)}", value)
    if sorted(order.upper()) != ["X", "Y", "Z"]:
        raise MotionError("order", "the three axes X, Y, Z in some order (e.g. ZXY)", order)


def human_bvh(
    motion: str = "reach",
    *,
    style: str = "cmu",
    up: str = "y",
    units: str = "cm",
    order: str | None = None,
    positions: str | None = None,
    seconds: float = 10.0,
    fps: float = 120.0,
    decimals: int = 4,
) -> str:
    """A BVH clip of the procedural human doing ``motion`` (see the module docstring).

    Args:
        motion: one of :data:`HUMAN_MOTIONS`.
        style: ``cmu`` or ``mixamo`` (:data:`STYLES`): the joint names and the defaults
            of ``order`` and ``positions``.
        up: the file's up axis, ``y`` or ``z`` (Z-up files use :data:`Z_UP_FROM_Y_UP`).
        units: the file's length unit (a key of :data:`~humanoid_ik.motion.bvh.UNITS`).
        order: the rotation channel order of every joint, e.g. ``ZXY``.
        positions: ``root`` or ``all`` (position channels on every joint).
        seconds: the clip's length [s] (``seconds * fps`` frames, rounded, at least 2).
        fps: frames per second.
        decimals: digits after the decimal point of every value written.

    Raises:
        MotionError: a bad parameter (its name, the valid values and what was given).
    """
    st = STYLES.get(style)
    order = (order or (st.order if st else "ZYX")).upper()
    positions = positions or (st.positions if st else "root")
    _check(motion, style, up, units, order, positions)
    assert st is not None
    if not (isinstance(fps, (int, float)) and 1.0 <= fps <= 1000.0):
        raise MotionError("fps", "a number from 1 to 1000", fps)
    if not (isinstance(seconds, (int, float)) and 0.0 < seconds <= MAX_SECONDS):
        raise MotionError("seconds", f"a number > 0 and <= {MAX_SECONDS:g}", seconds)
    F = max(2, round(seconds * fps))
    t = np.arange(F) / fps
    a = _MAKERS[motion](t) | {"t": t}
    scale = 1.0 / UNITS[units]
    A = Z_UP_FROM_Y_UP if up == "z" else np.eye(3)
    cols: list[NDArray[np.float64]] = []
    lines = ["HIERARCHY"]
    rot_names = " ".join(f"{c}rotation" for c in order)

    def off(v: NDArray[np.float64] | tuple[float, ...]) -> str:
        return " ".join(f"{x:.{decimals}f}" for x in scale * (A @ np.asarray(v)))

    def emit(part: str, depth: int) -> None:
        pad = "  " * depth
        offset = np.asarray(_BONES[part][1])
        kind = "ROOT" if depth == 0 else "JOINT"
        lines.extend([f"{pad}{kind} {st.prefix}{st.names[part]}", f"{pad}{{"])
        lines.append(f"{pad}  OFFSET {off(offset)}")
        moved = depth == 0 or positions == "all"
        n = 6 if moved else 3
        lines.append(
            f"{pad}  CHANNELS {n} "
            + ("Xposition Yposition Zposition " if moved else "")
            + rot_names
        )
        if moved:
            p = np.tile(offset, (F, 1))
            if depth == 0:  # the hips sway and bob a little
                p = p + np.stack(
                    [
                        0.01 * np.sin(2 * math.pi * 0.2 * t),
                        0.004 * np.sin(2 * math.pi * 0.4 * t),
                        0 * t,
                    ],
                    axis=1,
                )
            cols.extend((scale * p @ A.T).T)
        local = A @ _local(part, a, F) @ A.T
        cols.extend(euler_angles(local, order).T)
        for child in _children(part):
            emit(child, depth + 1)
        if part in _ENDS:
            lines.extend(
                [
                    f"{pad}  End Site",
                    f"{pad}  {{",
                    f"{pad}    OFFSET {off(_ENDS[part])}",
                    f"{pad}  }}",
                ]
            )
        lines.append(f"{pad}}}")

    emit("hips", 0)
    lines += ["MOTION", f"Frames: {F}", f"Frame Time: {1.0 / fps:.10f}"]
    table = np.stack(cols, axis=1)
    table[np.abs(table) < 0.5 * 10.0**-decimals] = 0.0  # no "-0.0000"
    fmt = " ".join([f"%.{decimals}f"] * table.shape[1])
    lines.extend(fmt % tuple(row) for row in table)
    return "\n".join(lines) + "\n"


SHIPPED: dict[str, dict[str, object]] = {
    "reach_cmu.bvh": {"motion": "reach", "style": "cmu", "seconds": 2.0, "decimals": 3},
    "wave_mixamo.bvh": {"motion": "wave", "style": "mixamo", "seconds": 2.0, "decimals": 3},
    "arm_circles_zup_m.bvh": {
        "motion": "arm_circles",
        "style": "cmu",
        "up": "z",
        "units": "m",
        "seconds": 2.0,
        "decimals": 5,
    },
}
"""The clips of the repository's ``motions/`` folder: file name -> :func:`human_bvh`
arguments (short clips at 120 frames/s; longer ones are one call away)."""


def write_shipped(folder: str | os.PathLike[str]) -> list[Path]:
    """Write the :data:`SHIPPED` clips into ``folder`` (made if missing); returns their
    paths."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, kwargs in SHIPPED.items():
        path = out / name
        path.write_text(human_bvh(**kwargs), encoding="utf-8")  # type: ignore[arg-type]
        paths.append(path)
    return paths


if __name__ == "__main__":  # python -m humanoid_ik.motion.human [FOLDER]
    for p in write_shipped(sys.argv[1] if len(sys.argv) > 1 else "motions"):
        print(p)
