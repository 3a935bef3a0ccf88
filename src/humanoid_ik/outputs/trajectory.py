"""Trajectory files: ``trajectory.npz`` (NumPy arrays and a JSON header) and
``trajectory.csv`` (one row per frame, the same header as a first ``#`` line), each
written atomically, and :func:`load_trajectory`, which reads either back as a typed
:class:`~humanoid_ik.run.trajectory.Trajectory`. The columns, units and conventions are
in ``docs/formats.md``."""

from __future__ import annotations

import csv
import io
import json
import os
import zipfile
import zlib
from dataclasses import asdict, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.models import load_model
from humanoid_ik.core.names import check_name
from humanoid_ik.core.robot_files import PackagePaths
from humanoid_ik.errors import MotionError, TrajectoryFileError
from humanoid_ik.outputs.atomic import atomic_path, json_text, write_text
from humanoid_ik.outputs.stage import trajectory_stage
from humanoid_ik.outputs.trajectory_layout import (
    HEADER_ARRAY,
    MAX_HEADER_CHARS,
    MAX_MEMBERS,
    MAX_TRAJECTORY_BYTES,
    QUAT,
    SAMPLES,
    Array,
    column_prefix,
    layout,
    read_member,
    zip_entries,
)
from humanoid_ik.run.trajectory import (
    TRAJECTORY_FORMAT,
    TRAJECTORY_VERSION,
    EffectorTrack,
    Trajectory,
    check_trajectory_model,
)

if TYPE_CHECKING:
    from humanoid_ik.outputs.trajectory_schema import Header

__all__ = ["load_trajectory", "open_trajectory", "trajectory_csv", "write_trajectory"]


def _header_doc(traj: Trajectory) -> dict[str, Any]:
    """What a trajectory file says about itself (everything but the per-frame arrays)."""
    return {
        "format": TRAJECTORY_FORMAT,
        "version": TRAJECTORY_VERSION,
        "scene": traj.scene,
        "scene_file": traj.scene_file,
        "model_file": traj.model_file,
        "model_sha256": traj.model_sha256,
        "fps": traj.fps,
        "frames": traj.n_frames,
        "interrupted": traj.interrupted,
        "qpos_names": list(traj.qpos_names),
        "joint_names": list(traj.joint_names),
        "render": {**asdict(traj.render), "snapshots": list(traj.render.snapshots)},
        "stage_points": traj.stage_points.tolist(),
        "effectors": [
            {
                e.kind: e.site,
                "target": e.target_name,
                "task": e.task,
                "solver": e.solver,
                "joints": list(e.joints),
                "pose_target": e.target_quat is not None,
            }
            for e in traj.effectors
        ],
    }


def _npz_arrays(traj: Trajectory) -> dict[str, Any]:
    out: dict[str, Any] = {
        "header": np.array(json_text(_header_doc(traj), indent=None)),
        "time": traj.time,
        "qpos": traj.qpos,
        "stage_points": traj.stage_points,
    }
    for k, e in enumerate(traj.effectors):
        out[f"effector{k}_q"] = e.q
        out[f"effector{k}_target"] = e.target
        if e.target_quat is not None:
            out[f"effector{k}_target_quat"] = e.target_quat
        out[f"effector{k}_achieved"] = e.achieved
        out[f"effector{k}_position_error"] = e.position_error
        out[f"effector{k}_on_target"] = e.on_target
        out[f"effector{k}_reachable"] = e.reachable
        out[f"effector{k}_status"] = np.array(e.status, dtype=np.str_)
        for name in SAMPLES:
            out[f"effector{k}_{name}"] = getattr(e, name)
    return out


def _columns(traj: Trajectory) -> list[str]:
    """The CSV columns: frame, time, every ``qpos`` entry, then per effector (prefixed
    with its site's or body's name, ``<name>.``, or ``site:<name>.``/``body:<name>.``
    when a site and a body of one name are both effectors: :func:`column_prefix`)
    target, target orientation (pose targets), achieved, error, flags, samples."""
    cols = ["frame", "time_s", *traj.qpos_names]
    ends = [(e.kind, e.site) for e in traj.effectors]
    for k, e in enumerate(traj.effectors):
        p = column_prefix(ends, k)
        cols += [f"{p}target_{c}" for c in "xyz"]
        if e.target_quat is not None:
            cols += [f"{p}target_{c}" for c in QUAT]
        cols += [f"{p}achieved_{c}" for c in "xyz"]
        cols += [f"{p}position_error_m", f"{p}on_target", f"{p}reachable", f"{p}status"]
        cols += [f"{p}{c}" for c in SAMPLES.values()]
    return cols


def trajectory_csv(traj: Trajectory) -> str:
    """The CSV text: the header as JSON on a first ``#`` line, then the column names and
    one row per frame (numbers written in full precision, so reading it back is exact)."""
    buf = io.StringIO()
    buf.write("# " + json_text(_header_doc(traj), indent=None) + "\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(_columns(traj))
    for i in range(traj.n_frames):
        row: list[Any] = [i, repr(float(traj.time[i])), *map(repr, traj.qpos[i].tolist())]
        for e in traj.effectors:
            row += [repr(v) for v in e.target[i].tolist()]
            if e.target_quat is not None:
                row += [repr(v) for v in e.target_quat[i].tolist()]
            row += [repr(v) for v in e.achieved[i].tolist()]
            row += [repr(float(e.position_error[i])), int(e.on_target[i]), int(e.reachable[i])]
            row.append(e.status[i])
            row += [repr(getattr(e, name)[i].item()) for name in SAMPLES]
        w.writerow(row)
    return buf.getvalue()


def write_trajectory(traj: Trajectory, folder: str | os.PathLike) -> tuple[Path, Path]:
    """Write ``trajectory.npz`` and ``trajectory.csv`` into ``folder``, each atomically.

    Returns:
        The two files.

    Raises:
        TrajectoryFileError: the scene's name is not a :data:`~humanoid_ik.core.names.NAME`
            (the file could not be read back: its name becomes a file's).
    """
    try:
        check_name("scene", traj.scene)
    except MotionError as exc:
        raise TrajectoryFileError(f"trajectory {exc}") from None
    folder = Path(folder)
    npz = folder / "trajectory.npz"
    with atomic_path(npz) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **_npz_arrays(traj))
    return npz, write_text(folder / "trajectory.csv", trajectory_csv(traj))


def load_trajectory(path: str | os.PathLike) -> Trajectory:
    """Read a ``trajectory.npz`` or ``trajectory.csv`` written by :func:`write_trajectory`.

    Every header field is checked for its type and bound and every array for its shape,
    type and values (``outputs/trajectory_schema.py``; ``docs/formats.md``): at most
    :data:`~humanoid_ik.config.specs.MAX_FRAMES` frames, finite joint values, times,
    targets and stage points, the ``render`` block as a scene file's. Only the members
    the header implies are read from an ``.npz``, each after its size is checked from
    the archive's directory and its array header, so no file makes the reader hold more
    than :data:`~humanoid_ik.outputs.trajectory_layout.MAX_TRAJECTORY_BYTES` of arrays.

    Raises:
        TrajectoryFileError: the file does not exist, is neither, or breaks a rule (one
            line naming the field, the value and the rule).
    """
    p = Path(path)
    if not p.is_file():
        raise TrajectoryFileError(f"trajectory file '{p}' does not exist")
    try:
        if p.suffix.lower() == ".csv":
            return _read_csv(p)
        if p.suffix.lower() == ".npz":
            return _read_npz(p)
    except OSError as exc:
        raise TrajectoryFileError(f"cannot read trajectory '{p}': {exc.strerror or exc}") from None
    raise TrajectoryFileError(f"trajectory file '{p}' is neither .npz nor .csv")


def _header(text: str, path: Path) -> Header:
    """The header from its JSON text."""
    from humanoid_ik.outputs.trajectory_schema import parse_header

    try:
        doc = json.loads(text)
    except (ValueError, RecursionError):
        raise TrajectoryFileError(f"'{path}' has a header that is not JSON") from None
    return parse_header(doc, str(path))


def _trajectory(header: Header, arrays: dict[str, np.ndarray]) -> Trajectory:
    """The :class:`Trajectory` of a checked header and its checked arrays."""
    tracks = []
    for k, e in enumerate(header.effectors):
        a = {
            key[len(f"effector{k}_") :]: v
            for key, v in arrays.items()
            if key.startswith(f"effector{k}_")
        }
        tracks.append(
            EffectorTrack(
                site=e.name,
                kind=e.kind,
                target_name=e.target,
                task=e.task,
                solver=e.solver,
                joints=tuple(e.joints),
                q=a["q"],
                target=a["target"],
                target_quat=a.get("target_quat"),
                achieved=a["achieved"],
                position_error=a["position_error"],
                on_target=a["on_target"],
                reachable=a["reachable"],
                status=tuple(str(s) for s in a["status"]),
                **{name: a.get(name) for name in SAMPLES},
            )
        )
    points = arrays.get("stage_points")
    return Trajectory(
        time=arrays["time"],
        qpos=arrays["qpos"],
        qpos_names=tuple(header.qpos_names),
        joint_names=tuple(header.joint_names),
        effectors=tuple(tracks),
        fps=header.fps,
        scene=header.scene,
        scene_file=header.scene_file,
        model_file=header.model_file,
        model_sha256=header.model_sha256,
        render=header.render.spec,
        interrupted=header.interrupted,
        stage_points=np.array(header.stage_points, dtype=float).reshape(-1, 3)
        if points is None
        else points,
    )


def _consistent(header: Header, arrays: dict[str, np.ndarray], path: Path) -> None:
    """Times that never go back; each effector's ``q`` from the ``qpos`` columns of its
    joints (the CSV holds them once), or, read from an ``.npz``, checked equal to them."""
    back = np.flatnonzero(np.diff(arrays["time"]) < 0)
    if back.size:
        i = int(back[0]) + 1
        t = arrays["time"]
        raise TrajectoryFileError(
            f"trajectory '{path}': time[{i}] (frame {i}): expected a time >= the frame "
            f"before's ({float(t[i - 1])!r}), got {float(t[i])!r}"
        )
    for k, e in enumerate(header.effectors):
        q = arrays["qpos"][:, [header.qpos_names.index(j) for j in e.joints]]
        key = f"effector{k}_q"
        if key in arrays and not np.array_equal(arrays[key], q):
            raise TrajectoryFileError(
                f"trajectory '{path}': {key}: expected the qpos columns of its joints "
                f"({', '.join(e.joints)}), got other values"
            )
        arrays[key] = q


# ------------------------------------------------------------------------------ .npz
def _read_npz(path: Path) -> Trajectory:
    entries = zip_entries(path)
    if entries > MAX_MEMBERS:
        raise TrajectoryFileError(
            f"trajectory '{path}' lists {entries} members; expected at most {MAX_MEMBERS}"
        )
    try:
        with zipfile.ZipFile(path) as zf:
            members = {i.filename: i for i in zf.infolist()}
            if "header.npy" not in members:
                raise TrajectoryFileError(f"'{path}' is not a humanoid-ik trajectory file")
            text = read_member(zf, members["header.npy"], HEADER_ARRAY, 4 * MAX_HEADER_CHARS, path)
            header = _header(str(text[()]), path)
            arrays: dict[str, np.ndarray] = {}
            budget = MAX_TRAJECTORY_BYTES
            for a in layout(header):
                info = members.get(f"{a.name}.npy")
                if info is None:
                    if a.optional:
                        continue
                    raise TrajectoryFileError(f"trajectory '{path}' lacks the array '{a.name}'")
                raw = read_member(zf, info, a, budget, path)
                budget -= raw.nbytes
                arrays[a.name] = a.check(raw, str(path))
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        NotImplementedError,
        RuntimeError,
        EOFError,
        ValueError,
        zlib.error,
    ) as exc:
        if isinstance(exc, TrajectoryFileError):
            raise
        raise TrajectoryFileError(
            f"cannot read trajectory '{path}': {' '.join(str(exc).split())}"
        ) from None
    _consistent(header, arrays, path)
    return _trajectory(header, arrays)


# ------------------------------------------------------------------------------ .csv
def _read_csv(path: Path) -> Trajectory:
    try:
        with open(path, encoding="utf-8", newline="") as fh:
            first = fh.readline(MAX_HEADER_CHARS + 2)
            if not first.startswith("#"):
                raise TrajectoryFileError(f"'{path}' is not a humanoid-ik trajectory file")
            if not first.endswith("\n"):
                raise TrajectoryFileError(
                    f"trajectory '{path}': the header line is longer than {MAX_HEADER_CHARS} "
                    "characters (or the file has nothing after it)"
                )
            header = _header(first[1:], path)
            lines = _lines(fh, path)
            names = next(csv.reader(lines), None)
            if names is None:
                raise TrajectoryFileError(f"trajectory '{path}' has no line of column names")
            plan = _match_columns(header, names, path)
            arrays = _csv_rows(header, plan, csv.reader(lines), path, len(names))
    except UnicodeDecodeError:
        raise TrajectoryFileError(
            f"'{path}' is not a humanoid-ik trajectory file (not UTF-8)"
        ) from None
    except csv.Error as exc:
        raise TrajectoryFileError(f"trajectory '{path}': {exc}") from None
    _consistent(header, arrays, path)
    return _trajectory(header, arrays)


def _lines(fh: Any, path: Path) -> Any:
    """The file's lines, none longer than :data:`MAX_LINE` characters."""
    number = 1
    while True:
        line = fh.readline(MAX_LINE + 1)
        number += 1
        if not line:
            return
        if len(line) > MAX_LINE:
            raise TrajectoryFileError(
                f"trajectory '{path}': line {number} is longer than {MAX_LINE} characters"
            )
        yield line


def _is_sample(a: Array) -> bool:
    """A sample field's array (``effector{k}_iterations`` ...)."""
    return any(a.name.endswith("_" + name) for name in SAMPLES)


def _csv_rows(
    header: Header, plan: list[Array], rows: Any, path: Path, width: int
) -> dict[str, np.ndarray]:
    """The arrays of ``plan`` from the CSV's rows: exactly ``header.frames`` rows of
    ``width`` cells, ``frame`` counting from 0, numbers where numbers belong, ``0``/``1``
    flags; then each array checked by its rule."""
    f = header.frames
    store: dict[str, Any] = {
        a.name: np.empty(a.shape, dtype=np.float64)
        if a.kind not in ("status", "bool")
        else (np.empty(f, dtype=bool) if a.kind == "bool" else [""] * f)
        for a in plan
    }
    i = -1
    for i, row in enumerate(rows):
        line = i + 3
        if i >= f:
            raise TrajectoryFileError(
                f"trajectory '{path}' has more than {f} rows; its header says frames = {f}"
            )
        if len(row) != width:
            raise TrajectoryFileError(
                f"trajectory '{path}': line {line} has {len(row)} cells; expected {width} "
                "(one per column)"
            )
        if row[0] != str(i):
            raise TrajectoryFileError(
                f"trajectory '{path}': line {line}, column 'frame': expected {i}, got {row[0]!r}"
            )
        j = 1
        for a in plan:
            cells = row[j : j + len(a.columns)]
            try:
                if a.kind == "status":
                    store[a.name][i] = cells[0]
                elif a.kind == "bool":
                    if cells[0] not in ("0", "1"):
                        raise ValueError
                    store[a.name][i] = cells[0] == "1"
                else:
                    store[a.name][i] = (
                        [float(c) for c in cells] if len(a.shape) > 1 else float(cells[0])
                    )
            except ValueError:
                bad = next(c for c in cells if not _number(c)) if a.kind != "bool" else cells[0]
                col = a.columns[cells.index(bad)]
                rule = "0 or 1" if a.kind == "bool" else "a number"
                raise TrajectoryFileError(
                    f"trajectory '{path}': line {line}, column {col!r}: expected {rule}, "
                    f"got {bad!r}"
                ) from None
            j += len(a.columns)
    if i + 1 != f:
        raise TrajectoryFileError(
            f"trajectory '{path}' has {i + 1} row(s); its header says frames = {f}"
        )
    return {a.name: a.check(np.asarray(store[a.name]), str(path)) for a in plan}


def _number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


MAX_LINE = 4_000_000
"""Longest CSV line after the header [characters]."""


def _match_columns(header: Header, names: list[str], path: Path) -> list[Array]:
    """The arrays the CSV's column names hold, in order: every array of the header's
    layout with CSV columns (the four sample columns of each effector all or none, as
    files of an earlier release lack them), named as this release writes them or, for a
    file written before effectors sharing a name were told apart, ``<name>.``.

    Raises:
        TrajectoryFileError: a column is missing, unknown, twice or out of place.
    """
    tried = {}
    for legacy in (False, True):
        arrays = [a for a in layout(header, legacy) if a.columns]
        for samples in (True, False):
            kept = [a for a in arrays if samples or not _is_sample(a)]
            want = ["frame", *[c for a in kept for c in a.columns]]
            if names == want:
                return kept
            tried[legacy, samples] = want
    samples = any(n.endswith("." + SAMPLES["iterations"]) for n in names)
    want = tried[False, samples]
    seen: dict[str, int] = {}
    for i, n in enumerate(names):
        if n in seen and names.count(n) > want.count(n):
            raise TrajectoryFileError(
                f"trajectory '{path}': column {n!r} appears twice (columns {seen[n] + 1} and "
                f"{i + 1})"
            )
        seen.setdefault(n, i)
    missing = [c for c in want if c not in names]
    if missing:
        raise TrajectoryFileError(f"trajectory '{path}' lacks column {missing[0]!r}")
    unknown = [c for c in names if c not in want]
    if unknown:
        raise TrajectoryFileError(
            f"trajectory '{path}' has column {unknown[0]!r}, which its header does not imply"
        )
    i = next(i for i, (a, b) in enumerate(zip(names, want, strict=False)) if a != b)
    raise TrajectoryFileError(
        f"trajectory '{path}': column {i + 1} is {names[i]!r}; expected {want[i]!r}"
    )


def open_trajectory(
    path: str | os.PathLike,
    model_file: str | os.PathLike | None = None,
    staged: bool = False,
    *,
    packages: PackagePaths | None = None,
) -> tuple[Trajectory, mujoco.MjModel, str]:
    """A trajectory with the model it was recorded on, checked against each other.

    Args:
        path: the ``trajectory.npz`` or ``.csv``.
        model_file: the model file (default: the one the trajectory names).
        staged: place the model in the default stage as the run did (for filming: the
            same lights, floor and cameras, framed on the trajectory's stage points).
        packages: ROS package folders of a URDF's ``package://`` paths
            (``--package-path``; see ``docs/robots.md``).

    Returns:
        The trajectory, the compiled model and the model file's digest.

    Raises:
        TrajectoryFileError: the file cannot be read, the model file does not exist, or
            the trajectory does not fit it (other joints, another digest).
        ModelError: the model does not compile.
    """
    traj = load_trajectory(path)
    mfile = traj.model_file if model_file is None else str(model_file)
    if not Path(mfile).is_file():
        if model_file is not None:
            raise TrajectoryFileError(f"model file '{mfile}' does not exist")
        raise TrajectoryFileError(
            f"model file '{mfile}' of trajectory '{path}' does not exist; pass the model it "
            "was recorded on with --model"
        )
    model = load_model(mfile, packages=packages)
    digest = model_digest(mfile, packages=packages)
    # the messages name the model checked: the one given, else the trajectory's
    check_trajectory_model(
        traj if model_file is None else replace(traj, model_file=mfile), model, digest
    )
    if staged:
        aspect = traj.render.width / traj.render.height
        model = trajectory_stage(mfile, traj, aspect, model, packages=packages)
    return traj, model, digest
