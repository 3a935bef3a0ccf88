"""Reading BVH motion capture (Biovision hierarchy): the skeleton and, per frame, the
world position and orientation of every joint and end site.

A BVH file is a ``HIERARCHY`` (one ``ROOT``, nested ``JOINT``s and ``End Site``s, each
with an ``OFFSET`` from its parent and, for joints, a ``CHANNELS`` list) and a
``MOTION`` table (``Frames:``, ``Frame Time:``, then one row of channel values per
frame). Any channel order is read, per joint:

- rotations are intrinsic, composed in the order the channels are listed: a joint with
  ``Zrotation Xrotation Yrotation`` turns by ``Rz(a) Rx(b) Ry(c)`` relative to its
  parent (``a, b, c`` in degrees), as every common tool reads them (and as
  ``outputs/bvh.py`` writes them);
- position channels replace the matching component of the joint's ``OFFSET`` (the
  root's, or every joint's in files that carry positions on every joint); a missing one
  keeps the offset's component;
- a joint's world pose is ``p = p_parent + R_parent t``, ``R = R_parent R_local``;
  an end site sits at ``p_parent + R_parent offset`` and turns with its joint.

Units and up axis: a file does not say them. :func:`read_bvh` guesses them from the
skeleton (:func:`detect_up`: the head above the feet, by joint names, else the longer
of the Y and Z extents; :func:`detect_units`: the height of a standing human, 1 to 3
units tall in metres, 50 to 300 in centimetres) and reports the guess in
:attr:`BVHClip.detected`; ``units=`` and ``up=`` force them. By default the clip is
converted to MuJoCo's conventions, metres and Z up, with the axis map of
``outputs/bvh.py`` (BVH ``(X, Y, Z)`` is MuJoCo ``(y, z, x)``, a proper rotation:
:data:`Z_UP_FROM_Y_UP`), so that a file exported by ``humanoid-ik export-bvh`` reads
back in the model's world frame. ``convert=False`` keeps the file's units and axes.

Errors are one line naming the file, the line and what was expected there
(:class:`~humanoid_ik.errors.BVHError`). One skeleton per file: a second ``ROOT`` is
refused.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.errors import BVHError, choices

__all__ = [
    "BVHClip",
    "BVHSkeleton",
    "CHANNELS",
    "UNITS",
    "Z_UP_FROM_Y_UP",
    "detect_units",
    "axis_rotations",
    "detect_up",
    "euler_angles",
    "parse_bvh",
    "read_bvh",
    "y_up_to_z_up",
]

CHANNELS = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
"""The channel names of BVH (read without regard to case)."""
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
"""Length units a BVH file may use and their size [m]."""
UP_AXES = ("y", "z")
"""The up axes a file may use: ``y`` (the BVH standard, CMU, Mixamo) or ``z`` (Blender,
robotics)."""
Z_UP_FROM_Y_UP = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""A Y-up vector in Z-up axes: ``(X, Y, Z) -> (Z, X, Y)`` (forward +Z becomes +x, left
+X becomes +y, up +Y becomes +z), the inverse of ``outputs/bvh.py``'s map."""
_CANON = {c.lower(): c for c in CHANNELS}
_TOKEN = re.compile(r"[{}]|[^\s{}]+")
_UP_WORDS = ("head",)
_DOWN_WORDS = ("foot", "toe", "ankle")


def y_up_to_z_up(v: ArrayLike) -> NDArray[np.float64]:
    """Vectors ``(..., 3)`` of a Y-up file in Z-up axes (:data:`Z_UP_FROM_Y_UP`)."""
    return np.asarray(v, dtype=np.float64) @ Z_UP_FROM_Y_UP.T


@dataclass(frozen=True)
class BVHSkeleton:
    """The hierarchy of a BVH file, in file order (depth first), end sites included.

    Attributes:
        names: every node's name; an end site is named after its joint, ``<joint>_end``.
        parents: each node's parent index (``-1`` for the root).
        offsets: ``(N, 3)`` each node's ``OFFSET`` from its parent, in the file's units
            and axes.
        channels: each node's channel names in file order (empty for an end site).
        end_sites: whether each node is an ``End Site``.
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: NDArray[np.float64]
    channels: tuple[tuple[str, ...], ...]
    end_sites: tuple[bool, ...]

    @property
    def joints(self) -> tuple[str, ...]:
        """The names of the joints (every node but the end sites)."""
        return tuple(n for n, e in zip(self.names, self.end_sites, strict=True) if not e)

    @property
    def n_channels(self) -> int:
        """The values of one frame row."""
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """The index of node ``name``.

        Raises:
            BVHError: no such node (the names are listed).
        """
        if name in self.names:
            return self.names.index(name)
        raise BVHError(
            "skeleton", 0, f"joint '{name}' not in the BVH; joints: {choices(self.names)}"
        )

    def rest_positions(self) -> NDArray[np.float64]:
        """``(N, 3)`` every node with all channels zero but the offsets kept (file units
        and axes, the root at its ``OFFSET``)."""
        out = np.zeros((len(self.names), 3))
        for i, p in enumerate(self.parents):
            out[i] = self.offsets[i] + (out[p] if p >= 0 else 0.0)
        return out


@dataclass(frozen=True)
class BVHClip:
    """A BVH file read: its skeleton and every node's world pose in every frame.

    Attributes:
        skeleton: the hierarchy.
        frame_time: seconds per frame.
        values: ``(F, C)`` the channel values as written (degrees, file units).
        positions: ``(F, N, 3)`` world positions of every node (metres, Z up unless read
            with ``convert=False``).
        rotations: ``(F, N, 3, 3)`` world orientations (columns: the node's axes), in
            the same axes; an end site has its joint's.
        units: the file's length unit (a key of :data:`UNITS`).
        up: the file's up axis, ``y`` or ``z``.
        detected: how ``units`` and ``up`` were chosen (guessed, and from what, or given).
        converted: whether positions and rotations are in metres and Z up.
        source: the file as the caller named it.
    """

    skeleton: BVHSkeleton
    frame_time: float
    values: NDArray[np.float64]
    positions: NDArray[np.float64]
    rotations: NDArray[np.float64]
    units: str
    up: str
    detected: str
    converted: bool
    source: str

    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])

    @property
    def fps(self) -> float:
        """Frames per second, ``1 / frame_time``."""
        return 1.0 / self.frame_time

    @property
    def names(self) -> tuple[str, ...]:
        return self.skeleton.names

    @property
    def scale(self) -> float:
        """Metres per file unit when converted, else 1."""
        return UNITS[self.units] if self.converted else 1.0

    @property
    def axes(self) -> NDArray[np.float64]:
        """The matrix that took the file's axes to the clip's (identity, or
        :data:`Z_UP_FROM_Y_UP` for a converted Y-up file)."""
        return Z_UP_FROM_Y_UP if self.converted and self.up == "y" else np.eye(3)

    @cached_property
    def quaternions(self) -> NDArray[np.float64]:
        """``(F, N, 4)`` the world orientations as unit quaternions ``(w, x, y, z)``,
        ``w >= 0`` (:func:`~humanoid_ik.core.rotations.mat_to_quat`)."""
        flat = self.rotations.reshape(-1, 3, 3)
        out = np.array([mat_to_quat(R) for R in flat]).reshape(*self.rotations.shape[:2], 4)
        return out

    def rest(self) -> NDArray[np.float64]:
        """``(N, 3)`` the rest pose (every channel zero, offsets kept) in the clip's
        units and axes: the bone lengths of the skeleton."""
        return self.scale * self.skeleton.rest_positions() @ self.axes.T

    def position(self, name: str) -> NDArray[np.float64]:
        """``(F, 3)`` the world positions of node ``name`` (:meth:`BVHSkeleton.index`)."""
        return self.positions[:, self.skeleton.index(name)]

    def rotation(self, name: str) -> NDArray[np.float64]:
        """``(F, 3, 3)`` the world orientations of node ``name``."""
        return self.rotations[:, self.skeleton.index(name)]


# --------------------------------------------------------------------------- parsing


class _Tokens:
    """The hierarchy's words with their line numbers; braces are words of their own."""

    def __init__(self, path: str, lines: list[str]):
        self.path = path
        self.items = [(t, k + 1) for k, ln in enumerate(lines) for t in _TOKEN.findall(ln)]
        self.at = 0
        self.last_line = len(lines)

    def peek(self) -> tuple[str, int]:
        if self.at < len(self.items):
            return self.items[self.at]
        return "", self.last_line

    def take(self, expected: str) -> tuple[str, int]:
        """The next word; the error says ``expected`` at the end of the hierarchy."""
        word, line = self.peek()
        if not word:
            raise BVHError(self.path, line, f"the hierarchy ends early; expected {expected}")
        self.at += 1
        return word, line

    def word(self, want: str) -> int:
        """Take the word ``want`` (any case); returns its line."""
        got, line = self.take(f"'{want}'")
        if got.lower() != want.lower():
            raise BVHError(self.path, line, f"expected '{want}', got '{got}'")
        return line

    def rest_of_line(self, line: int) -> list[str]:
        """The words left on ``line`` (not a brace)."""
        out = []
        while self.peek()[1] == line and self.peek()[0] not in ("{", "}", ""):
            out.append(self.take("a name")[0])
        return out

    def number(self, what: str) -> float:
        got, line = self.take(what)
        try:
            value = float(got)
        except ValueError:
            raise BVHError(self.path, line, f"expected {what}, got '{got}'") from None
        if not math.isfinite(value):
            raise BVHError(self.path, line, f"expected {what} (finite), got '{got}'")
        return value

    def error(self, message: str) -> BVHError:
        return BVHError(self.path, self.peek()[1], message)


class _Nodes:
    """The skeleton as it is parsed."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.end: list[bool] = []

    def add(self, name: str, parent: int, end: bool) -> int:
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append([0.0, 0.0, 0.0])
        self.channels.append(())
        self.end.append(end)
        return len(self.names) - 1


def _offset(tok: _Tokens, nodes: _Nodes, i: int) -> None:
    nodes.offsets[i] = [tok.number(f"OFFSET value {k + 1} of 3 (a number)") for k in range(3)]


def _channels(tok: _Tokens, nodes: _Nodes, i: int) -> None:
    got, line = tok.take("the number of channels")
    if not got.isdigit() or int(got) > 6:
        raise BVHError(tok.path, line, f"expected the number of channels (0 to 6), got '{got}'")
    names = []
    for _ in range(int(got)):
        word, wline = tok.take(f"{got} channel names")
        name = _CANON.get(word.lower())
        if name is None:
            raise BVHError(
                tok.path, wline, f"channel '{word}' unknown; channels: {choices(CHANNELS)}"
            )
        if name in names:
            raise BVHError(tok.path, wline, f"channel '{name}' listed twice")
        names.append(name)
    nodes.channels[i] = tuple(names)


def _joint(tok: _Tokens, nodes: _Nodes, parent: int, line: int) -> None:
    """One ``ROOT``/``JOINT`` block, its keyword taken on ``line``."""
    words = tok.rest_of_line(line)
    if not words:
        raise BVHError(tok.path, line, "expected a joint name after ROOT/JOINT")
    name = " ".join(words)
    if name in nodes.names:
        raise BVHError(tok.path, line, f"joint name '{name}' used twice")
    i = nodes.add(name, parent, False)
    tok.word("{")
    seen = set()
    while True:
        word, wline = tok.take("OFFSET, CHANNELS, JOINT, End Site or '}'")
        key = word.upper()
        if key in ("OFFSET", "CHANNELS") and key in seen:
            raise BVHError(tok.path, wline, f"{key} given twice for joint '{name}'")
        if key == "OFFSET":
            _offset(tok, nodes, i)
        elif key == "CHANNELS":
            _channels(tok, nodes, i)
        elif key == "JOINT":
            _joint(tok, nodes, i, wline)
        elif key == "END":
            tok.word("Site")
            e = nodes.add(f"{name}_end", i, True)
            tok.word("{")
            tok.word("OFFSET")
            _offset(tok, nodes, e)
            tok.word("}")
        elif word == "}":
            break
        else:
            raise BVHError(
                tok.path, wline, f"expected OFFSET, CHANNELS, JOINT, End Site or '}}', got '{word}'"
            )
        seen.add(key)
    if "OFFSET" not in seen:
        raise BVHError(tok.path, wline, f"joint '{name}' has no OFFSET")


def _hierarchy(path: str, lines: list[str]) -> BVHSkeleton:
    tok = _Tokens(path, lines)
    tok.word("HIERARCHY")
    nodes = _Nodes()
    line = tok.word("ROOT")
    _joint(tok, nodes, -1, line)
    word, line = tok.peek()
    if word.upper() == "ROOT":
        raise BVHError(
            path, line, "a second ROOT; this reader takes one skeleton per file (one ROOT)"
        )
    if word:
        raise BVHError(path, line, f"expected MOTION after the ROOT's '}}', got '{word}'")
    return BVHSkeleton(
        names=tuple(nodes.names),
        parents=tuple(nodes.parents),
        offsets=np.array(nodes.offsets, dtype=np.float64).reshape(-1, 3),
        channels=tuple(nodes.channels),
        end_sites=tuple(nodes.end),
    )


def _header(path: str, lines: list[str], k: int, key: str) -> tuple[str, int]:
    """The value after ``key`` (``Frames:``, ``Frame Time:``) on line ``k`` (0-based)."""
    while k < len(lines) and not lines[k].strip():
        k += 1
    if k >= len(lines):
        raise BVHError(path, len(lines), f"the file ends; expected '{key} ...'")
    text = lines[k].strip()
    if not text.lower().startswith(key.lower()):
        raise BVHError(path, k + 1, f"expected '{key} ...', got '{text[:40]}'")
    return text[len(key) :].strip(), k


def _motion(path: str, lines: list[str], start: int, width: int) -> tuple[float, NDArray]:
    """The frame time and the ``(F, width)`` values of the MOTION section, whose first
    line after ``MOTION`` is ``lines[start]``."""
    got, k = _header(path, lines, start, "Frames:")
    if not got.isdigit():
        raise BVHError(path, k + 1, f"expected 'Frames: N' with N a whole number, got '{got}'")
    n = int(got)
    got, k = _header(path, lines, k + 1, "Frame Time:")
    try:
        dt = float(got)
    except ValueError:
        dt = math.nan
    if not (math.isfinite(dt) and dt > 0):
        raise BVHError(path, k + 1, f"expected 'Frame Time: T' with T > 0 seconds, got '{got}'")
    rows = lines[k + 1 :]
    while rows and not rows[-1].strip():
        rows.pop()
    if len(rows) != n:
        where = k + 2 + min(len(rows), n)
        raise BVHError(
            path, where, f"'Frames: {n}' declares {n} frame rows; the file has {len(rows)}"
        )
    split = [r.split() for r in rows]
    for f, r in enumerate(split):
        if len(r) != width:
            raise BVHError(
                path,
                k + 2 + f,
                f"frame {f} has {len(r)} values; expected {width} (the channels of the hierarchy)",
            )
    try:
        values = np.array(split, dtype=np.float64).reshape(n, width)
    except ValueError:
        values = np.empty((n, width))
        for f, r in enumerate(split):
            for c, v in enumerate(r):
                try:
                    values[f, c] = float(v)
                except ValueError:
                    raise BVHError(path, k + 2 + f, f"expected a number, got '{v}'") from None
    bad = np.argwhere(~np.isfinite(values))
    if len(bad):
        f, c = (int(v) for v in bad[0])
        raise BVHError(path, k + 2 + f, f"expected a finite number, got '{split[f][c]}'")
    return dt, values


# --------------------------------------------------------------------------- kinematics

_AXIS = {"X": 0, "Y": 1, "Z": 2}


def axis_rotations(axis: str, degrees: ArrayLike) -> NDArray[np.float64]:
    """``(F, 3, 3)`` rotations by ``degrees`` ``(F,)`` about coordinate axis ``axis``
    (``X``, ``Y`` or ``Z``): one rotation channel's matrices over the frames."""
    a = _AXIS[axis.upper()]
    t = np.radians(np.asarray(degrees, dtype=np.float64).reshape(-1))
    c, s = np.cos(t), np.sin(t)
    out = np.zeros((len(t), 3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][a]
    out[:, a, a] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = -s
    out[:, j, i] = s
    return out


def euler_angles(R: ArrayLike, order: str) -> NDArray[np.float64]:
    """``(F, 3)`` the channel values [deg] of rotations ``R`` ``(F, 3, 3)`` in the
    intrinsic ``order`` (three distinct axes, e.g. ``ZXY``):
    ``R = A(a) B(b) C(c)``, the inverse of reading three rotation channels.

    With axes ``i, j, k`` and ``e = +1`` for a cyclic order (``XYZ``, ``YZX``, ``ZXY``),
    else ``-1``: ``b = asin(e R[i, k])``, ``a = atan2(-e R[j, k], R[k, k])``,
    ``c = atan2(-e R[i, j], R[i, i])``; ``a`` and ``c`` are unwrapped over the frames,
    so the curves are continuous (away from ``|b| = 90`` degrees, where ``a`` and ``c``
    are not separable).
    """
    m = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    i, j, k = (_AXIS[c] for c in order.upper())
    e = 1.0 if (j - i) % 3 == 1 else -1.0
    b = np.arcsin(np.clip(e * m[:, i, k], -1.0, 1.0))
    a = np.unwrap(np.arctan2(-e * m[:, j, k], m[:, k, k]))
    c = np.unwrap(np.arctan2(-e * m[:, i, j], m[:, i, i]))
    return np.degrees(np.stack([a, b, c], axis=1))


def _forward(sk: BVHSkeleton, values: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """World positions ``(F, N, 3)`` and rotations ``(F, N, 3, 3)`` of every node (file
    units and axes)."""
    F, N = values.shape[0], len(sk.names)
    pos = np.zeros((F, N, 3))
    rot = np.zeros((F, N, 3, 3))
    col = 0
    for i, parent in enumerate(sk.parents):
        t = np.tile(sk.offsets[i], (F, 1))
        R = np.broadcast_to(np.eye(3), (F, 3, 3)).copy()
        for name in sk.channels[i]:
            a = _AXIS[name[0]]
            if name.endswith("position"):
                t[:, a] = values[:, col]
            else:
                R = R @ axis_rotations(name[0], values[:, col])
            col += 1
        if parent < 0:
            pos[:, i], rot[:, i] = t, R
        else:
            Rp = rot[:, parent]
            pos[:, i] = pos[:, parent] + np.einsum("fij,fj->fi", Rp, t)
            rot[:, i] = Rp @ R
    return pos, rot


# --------------------------------------------------------------------------- conventions


def _matches(name: str, words: tuple[str, ...]) -> bool:
    low = name.lower()
    return any(w in low for w in words)


def detect_up(sk: BVHSkeleton) -> tuple[str, str]:
    """The file's likely up axis (``y`` or ``z``) and why.

    A joint named like a head lies above the feet (``foot``, ``toe``, ``ankle``) or the
    root in the rest pose: the up axis is the larger of that vector's Y and Z
    components. Without such names: the axis, of Y and Z, along which the rest pose is
    longer (a standing skeleton is taller than it is deep).
    """
    rest = sk.rest_positions()
    heads = [i for i, n in enumerate(sk.names) if _matches(n, _UP_WORDS)]
    if heads:
        feet = [i for i, n in enumerate(sk.names) if _matches(n, _DOWN_WORDS)]
        low = rest[feet].mean(axis=0) if feet else rest[0]
        v = rest[heads].mean(axis=0) - low
        axis = "y" if v[1] >= v[2] else "z"
        return axis, f"up {axis} (the head above the {'feet' if feet else 'root'})"
    extent = np.ptp(rest, axis=0)
    axis = "y" if extent[1] >= extent[2] else "z"
    return axis, f"up {axis} (the longer rest extent of Y and Z; no head joint named)"


def detect_units(sk: BVHSkeleton, up: str) -> tuple[str, str]:
    """The file's likely length unit (``m``, ``cm`` or ``mm``) and why: the skeleton's
    rest height along ``up`` (its largest extent if that is flat) read as a human's,
    below 5 units metres, below 500 centimetres, else millimetres."""
    extent = np.ptp(sk.rest_positions(), axis=0)
    height = float(extent[_AXIS[up.upper()]])
    if height < 0.1 * float(extent.max()):
        height = float(extent.max())
    unit = "m" if height < 5.0 else "cm" if height < 500.0 else "mm"
    return unit, f"units {unit} (the skeleton is {height:.4g} units tall)"


def _choose(path: str, sk: BVHSkeleton, units: str, up: str) -> tuple[str, str, str]:
    if up not in ("auto", *UP_AXES):
        raise BVHError(path, 0, f"up axis '{up}' unknown; choices: {choices(('auto', *UP_AXES))}")
    if units not in ("auto", *UNITS):
        raise BVHError(path, 0, f"units '{units}' unknown; choices: {choices(('auto', *UNITS))}")
    up, why_up = detect_up(sk) if up == "auto" else (up, f"up {up} (given)")
    units, why_units = (
        detect_units(sk, up) if units == "auto" else (units, f"units {units} (given)")
    )
    return units, up, f"{why_units}; {why_up}"


def parse_bvh(
    text: str,
    *,
    units: str = "auto",
    up: str = "auto",
    convert: bool = True,
    source: str = "<text>",
) -> BVHClip:
    """A BVH file's text read into a clip (see the module's conventions).

    Args:
        text: the whole file.
        units: the file's length unit, ``auto`` (guessed: :func:`detect_units`) or a key
            of :data:`UNITS`.
        up: the file's up axis, ``auto`` (:func:`detect_up`), ``y`` or ``z``.
        convert: give positions in metres and Z up (MuJoCo's world); ``False`` keeps the
            file's units and axes.
        source: the name errors give the file.

    Raises:
        BVHError: a syntax error (its line and what was expected), a second ROOT, an
            unknown unit or up axis.
    """
    lines = text.splitlines()
    k = next((i for i, ln in enumerate(lines) if ln.strip().upper() == "MOTION"), None)
    if k is None:
        raise BVHError(source, len(lines), "no MOTION line; a BVH file has HIERARCHY then MOTION")
    sk = _hierarchy(source, lines[:k])
    dt, values = _motion(source, lines, k + 1, sk.n_channels)
    unit, axis, why = _choose(source, sk, units, up)
    pos, rot = _forward(sk, values)
    if convert:
        A = Z_UP_FROM_Y_UP if axis == "y" else np.eye(3)
        pos = UNITS[unit] * pos @ A.T
        rot = A @ rot @ A.T
    return BVHClip(sk, dt, values, pos, rot, unit, axis, why, convert, source)


def read_bvh(
    path: str | os.PathLike[str], *, units: str = "auto", up: str = "auto", convert: bool = True
) -> BVHClip:
    """A BVH file read into a clip (:func:`parse_bvh`; errors name ``path``).

    Raises:
        BVHError: the file cannot be read or is not valid BVH.
    """
    try:
        with open(path, encoding="utf-8-sig", errors="strict") as fh:
            text = fh.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise BVHError(path, 0, f"cannot read the file ({exc.__class__.__name__}: {exc})") from None
    return parse_bvh(text, units=units, up=up, convert=convert, source=os.fspath(path))
