"""What a trajectory file holds, from its header: every array (:class:`Array`) with its
shape, its type, its CSV columns and the rule of its values (:func:`layout`), so a
reader knows each member's size before it inflates it and checks every value it reads
(finite joint values, times, targets; the statuses a solver gives), and reads an
``.npz`` member only after its size is checked (:func:`read_member`). The header itself is
checked by ``outputs/trajectory_schema.py``; ``outputs/trajectory.py`` reads and writes
the files; ``docs/formats.md`` lists the rules and ``docs/limits.md`` the bounds.
"""

from __future__ import annotations

import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.lib import format as npformat
from numpy.typing import NDArray

from humanoid_ik.config.specs import MAX_FRAMES, MIN_FPS
from humanoid_ik.core.types import MAX_COORDINATE, STATUSES
from humanoid_ik.errors import TrajectoryFileError

if TYPE_CHECKING:
    from humanoid_ik.outputs.trajectory_schema import Header

__all__ = [
    "HEADER_ARRAY",
    "MAX_HEADER_CHARS",
    "MAX_MEMBERS",
    "MAX_TRAJECTORY_BYTES",
    "QUAT",
    "SAMPLES",
    "Array",
    "column_prefix",
    "layout",
    "read_member",
    "zip_entries",
]

MAX_HEADER_CHARS = 4_000_000
"""Longest header [characters] (the JSON of ``trajectory.npz``'s ``header``, the first
line of ``trajectory.csv``); a run's is a few kB plus its stage points."""
MAX_TRAJECTORY_BYTES = 512 * 2**20
"""Most memory the arrays of one trajectory file may take once read [bytes]: 100,000
frames of a 40-joint robot with four effectors need about 150 MB. A file is refused
before any array is inflated when its header implies more."""
MAX_STATUS = 32
"""Longest solver status read [characters] (``max_iterations`` has 14)."""
QUAT = ("qw", "qx", "qy", "qz")
SAMPLES = {
    "orientation_error": "orientation_error_rad",
    "iterations": "iterations",
    "solve_time": "solve_time_s",
    "limit_margin": "limit_margin_rad",
}
"""The per-frame sample fields kept beside the targets (array name -> CSV column): a
file written before they were kept reads without them."""


@dataclass(frozen=True)
class Array:
    """One array a trajectory file holds.

    Attributes:
        name: its ``.npz`` member (``qpos``, ``effector0_target``).
        shape: its shape, from the header.
        kind: ``float``, ``bool``, ``int`` or ``status``.
        columns: its CSV columns (empty: not in the CSV, ``effector{k}_q`` and
            ``stage_points``).
        optional: a file may lack it (the sample fields of an earlier release; a
            chain's ``q``, then taken from ``qpos``).
        low, high: the bounds of its values (``None``: none).
        nan: NaN is allowed (``no value``, e.g. the orientation error of a position
            target); ``inf``: infinities are.
    """

    name: str
    shape: tuple[int, ...]
    kind: str
    columns: tuple[str, ...] = ()
    optional: bool = False
    low: float | None = None
    high: float | None = None
    nan: bool = False
    inf: bool = False

    @property
    def dtype_kinds(self) -> str:
        """The NumPy dtype kinds its values may be stored as (never objects)."""
        return {"float": "fiu", "int": "iuf", "bool": "b", "status": "U"}[self.kind]

    @property
    def words(self) -> str:
        """What its values are, for a message."""
        return {"float": "numbers", "int": "whole numbers", "bool": "booleans"}.get(
            self.kind, "text"
        )

    @property
    def nbytes(self) -> int:
        """Its size once read [bytes]."""
        item = {"float": 8, "bool": 1, "int": 8, "status": 4 * MAX_STATUS}[self.kind]
        return int(np.prod(self.shape)) * item

    def check(self, values: Any, source: str) -> NDArray[Any]:
        """``values`` as this array's type, or a :class:`TrajectoryFileError` naming the
        first bad value and its rule."""
        arr = np.asarray(values)
        what = f"trajectory '{source}': {self.name}"
        if arr.shape != self.shape:
            raise TrajectoryFileError(f"{what}: expected shape {self.shape}, got {arr.shape}")
        if arr.dtype.kind not in self.dtype_kinds:
            raise TrajectoryFileError(f"{what}: expected {self.words}, got dtype {arr.dtype}")
        if self.kind == "status":
            bad = ~np.isin(arr, STATUSES)
            if bad.any():
                got = str(arr[bad].flat[0])
                raise TrajectoryFileError(
                    f"{what}: expected one of {', '.join(STATUSES)}, got {got!r}"
                )
            return arr
        if self.kind == "bool":
            return arr
        return self._numbers(arr.astype(np.float64), what)

    def _numbers(self, arr: NDArray[np.float64], what: str) -> NDArray[np.float64]:
        ok = np.isfinite(arr)
        if self.nan:
            ok |= np.isnan(arr)
        if self.inf:
            ok |= np.isinf(arr)
        with np.errstate(invalid="ignore"):
            if self.low is not None:
                ok &= ~(arr < self.low)
            if self.high is not None:
                ok &= ~(arr > self.high)
            if self.kind == "int":
                ok &= arr == np.round(arr)
        if not ok.all():
            index = tuple(int(i) for i in np.argwhere(~ok)[0])
            where = [] if self.name == "stage_points" else [f"frame {index[0]}"]
            if self.columns:
                where.append(f"column {self.columns[index[-1] if len(index) > 1 else 0]!r}")
            at = f"{what}[{', '.join(map(str, index))}]" + (
                f" ({', '.join(where)})" if where else ""
            )
            raise TrajectoryFileError(f"{at}: expected {_rule(self)}, got {arr[index].item()!r}")
        return arr


def _rule(a: Array) -> str:
    """What an array's values must be, for a message."""
    kind = "whole numbers" if a.kind == "int" else "finite numbers"
    parts = [kind]
    if a.low is not None:
        parts.append(f">= {a.low:g}")
    if a.high is not None:
        parts.append(f"{'and ' if a.low is not None else ''}<= {a.high:g}")
    extra = [w for w, on in (("NaN (none)", a.nan), ("infinity", a.inf)) if on]
    return " ".join(parts) + (f" (or {' or '.join(extra)})" if extra else "")


def layout(header: Header, legacy: bool = False) -> list[Array]:
    """Every array a file of ``header`` holds, in the CSV's column order (``frame``
    aside): its shape, type, CSV columns and the rule of its values (``legacy``: the
    CSV columns of files that named every effector ``<name>.``, :func:`column_prefix`).

    Raises:
        TrajectoryFileError: the arrays would take more than
            :data:`MAX_TRAJECTORY_BYTES` (the file is not read).
    """
    f = header.frames
    end = MAX_FRAMES / MIN_FPS
    out = [
        Array("time", (f,), "float", ("time_s",), low=0.0, high=end),
        Array("qpos", (f, len(header.qpos_names)), "float", tuple(header.qpos_names)),
        Array(
            "stage_points",
            (len(header.stage_points), 3),
            "float",
            optional=True,
            low=-MAX_COORDINATE,
            high=MAX_COORDINATE,
        ),
    ]
    far: dict[str, Any] = {"low": -MAX_COORDINATE, "high": MAX_COORDINATE}
    ends = [(e.kind, e.name) for e in header.effectors]
    for k, e in enumerate(header.effectors):
        m, p = f"effector{k}_", column_prefix(ends, k, legacy)
        out.append(Array(m + "q", (f, len(e.joints)), "float", optional=True))
        out.append(Array(m + "target", (f, 3), "float", _cols(p, "target_", "xyz"), **far))
        if e.pose_target:
            out.append(Array(m + "target_quat", (f, 4), "float", _cols(p, "target_", QUAT)))
        out += [
            Array(m + "achieved", (f, 3), "float", _cols(p, "achieved_", "xyz"), **far),
            Array(m + "position_error", (f,), "float", (p + "position_error_m",), low=0.0),
            Array(m + "on_target", (f,), "bool", (p + "on_target",)),
            Array(m + "reachable", (f,), "bool", (p + "reachable",)),
            Array(m + "status", (f,), "status", (p + "status",)),
            Array(
                m + "orientation_error",
                (f,),
                "float",
                (p + SAMPLES["orientation_error"],),
                optional=True,
                low=0.0,
                nan=True,
            ),
            Array(m + "iterations", (f,), "int", (p + "iterations",), optional=True, low=0.0),
            Array(
                m + "solve_time",
                (f,),
                "float",
                (p + SAMPLES["solve_time"],),
                optional=True,
                low=0.0,
                nan=True,
            ),
            Array(
                m + "limit_margin",
                (f,),
                "float",
                (p + SAMPLES["limit_margin"],),
                optional=True,
                nan=True,
                inf=True,
            ),
        ]
    total = sum(a.nbytes for a in out)
    if total > MAX_TRAJECTORY_BYTES:
        raise TrajectoryFileError(
            f"a trajectory of {f} frames, {len(header.qpos_names)} joint values and "
            f"{len(header.effectors)} effector(s) takes {total / 2**20:.0f} MiB; expected at "
            f"most {MAX_TRAJECTORY_BYTES // 2**20} MiB (MAX_TRAJECTORY_BYTES)"
        )
    return out


def _cols(prefix: str, middle: str, ends: Any) -> tuple[str, ...]:
    return tuple(f"{prefix}{middle}{c}" for c in ends)


def column_prefix(ends: Sequence[tuple[str, str]], k: int, legacy: bool = False) -> str:
    """Effector ``k``'s CSV column prefix, of the effectors' ``(kind, name)`` ``ends``:
    ``<name>.``, or ``<kind>:<name>.`` when another effector has the same name (a site
    and a body may; their columns are then told apart by the kind). ``legacy``:
    ``<name>.`` always, as files written before said it (read by position)."""
    kind, name = ends[k]
    if legacy or [n for _, n in ends].count(name) == 1:
        return f"{name}."
    return f"{kind}:{name}."


# ------------------------------------------------------------------------------ .npz
MAX_MEMBERS = 1024
"""Most members an ``.npz`` may list (a run's has 4 + 12 per effector)."""


def zip_entries(path: Path) -> int:
    """The number of members a zip archive's end record declares, read before the
    archive's directory is (a directory of millions of members would be held whole)."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        fh.seek(max(0, size - 65_557))
        tail = fh.read()
    at = tail.rfind(b"PK\x05\x06")
    if at < 0 or len(tail) < at + 22:
        raise TrajectoryFileError(f"cannot read trajectory '{path}': not an .npz (zip) archive")
    return int.from_bytes(tail[at + 10 : at + 12], "little")


def read_member(
    zf: zipfile.ZipFile, info: zipfile.ZipInfo, array: Array, budget: int, path: Path
) -> np.ndarray:
    """One ``.npy`` member of ``array``'s name, read only when its array header declares
    the array's shape, one of its dtypes (never objects) and at most ``budget`` bytes,
    exactly the size the archive's directory declares for the member. Nothing is
    inflated beyond what the shape needs."""
    name = array.name
    what = f"trajectory '{path}': {name}"
    with zf.open(info) as fh:
        version = npformat.read_magic(fh)
        if version == (1, 0):
            got, fortran, dtype = npformat.read_array_header_1_0(fh)
        elif version == (2, 0):
            got, fortran, dtype = npformat.read_array_header_2_0(fh)
        else:
            raise TrajectoryFileError(f"{what}: expected a .npy array of version 1 or 2")
        if dtype.hasobject or dtype.fields is not None or dtype.kind not in array.dtype_kinds:
            raise TrajectoryFileError(f"{what}: expected {array.words}, got dtype {dtype}")
        if tuple(got) != array.shape:
            raise TrajectoryFileError(f"{what}: expected shape {array.shape}, got {tuple(got)}")
        nbytes = int(np.prod(got)) * dtype.itemsize
        if nbytes > budget:
            raise TrajectoryFileError(
                f"{what}: takes {nbytes} bytes; expected at most {budget} (MAX_TRAJECTORY_BYTES "
                "or the header's size)"
            )
        if info.file_size != fh.tell() + nbytes:
            raise TrajectoryFileError(
                f"{what}: the archive declares {info.file_size} bytes for it; its array "
                f"takes {fh.tell() + nbytes}"
            )
        data = fh.read(nbytes)
    if len(data) != nbytes:
        raise TrajectoryFileError(f"{what}: cut short ({len(data)} of {nbytes} bytes)")
    return np.frombuffer(data, dtype=dtype).reshape(got, order="F" if fortran else "C")


HEADER_ARRAY = Array("header", (), "status")
"""The ``header`` member: a text scalar (the header JSON)."""
