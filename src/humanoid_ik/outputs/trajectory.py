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
from dataclasses import asdict
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot_files import PackagePaths
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.outputs.atomic import atomic_path, json_text, write_text
from humanoid_ik.outputs.stage import trajectory_stage
from humanoid_ik.run.trajectory import (
    TRAJECTORY_FORMAT,
    TRAJECTORY_VERSION,
    EffectorTrack,
    Trajectory,
    check_trajectory_model,
)

__all__ = ["load_trajectory", "open_trajectory", "trajectory_csv", "write_trajectory"]

_QUAT = ("qw", "qx", "qy", "qz")
_SAMPLES = {
    "orientation_error": "orientation_error_rad",
    "iterations": "iterations",
    "solve_time": "solve_time_s",
    "limit_margin": "limit_margin_rad",
}
"""The per-frame sample fields kept beside the targets (array name -> CSV column): a
file written before they were kept reads without them (:class:`EffectorTrack`)."""


def _header(traj: Trajectory) -> dict[str, Any]:
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
        "header": np.array(json_text(_header(traj), indent=None)),
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
        for name in _SAMPLES:
            out[f"effector{k}_{name}"] = getattr(e, name)
    return out


def _columns(traj: Trajectory) -> list[str]:
    """The CSV columns: frame, time, every ``qpos`` entry, then per effector (prefixed
    with its site's or body's name, ``<name>.``) target, target orientation (pose
    targets), achieved, error, flags."""
    cols = ["frame", "time_s", *traj.qpos_names]
    for e in traj.effectors:
        p = f"{e.site}."
        cols += [f"{p}target_{c}" for c in "xyz"]
        if e.target_quat is not None:
            cols += [f"{p}target_{c}" for c in _QUAT]
        cols += [f"{p}achieved_{c}" for c in "xyz"]
        cols += [f"{p}position_error_m", f"{p}on_target", f"{p}reachable", f"{p}status"]
        cols += [f"{p}{c}" for c in _SAMPLES.values()]
    return cols


def trajectory_csv(traj: Trajectory) -> str:
    """The CSV text: the header as JSON on a first ``#`` line, then the column names and
    one row per frame (numbers written in full precision, so reading it back is exact)."""
    buf = io.StringIO()
    buf.write("# " + json_text(_header(traj), indent=None) + "\n")
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
            row += [repr(getattr(e, name)[i].item()) for name in _SAMPLES]
        w.writerow(row)
    return buf.getvalue()


def write_trajectory(traj: Trajectory, folder: str | os.PathLike) -> tuple[Path, Path]:
    """Write ``trajectory.npz`` and ``trajectory.csv`` into ``folder``, each atomically.

    Returns:
        The two files.
    """
    folder = Path(folder)
    npz = folder / "trajectory.npz"
    with atomic_path(npz) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **_npz_arrays(traj))
    return npz, write_text(folder / "trajectory.csv", trajectory_csv(traj))


def _check_header(header: Any, path: Path) -> dict[str, Any]:
    if not isinstance(header, dict) or header.get("format") != TRAJECTORY_FORMAT:
        raise TrajectoryFileError(f"'{path}' is not a humanoid-ik trajectory file")
    if header.get("version") != TRAJECTORY_VERSION:
        raise TrajectoryFileError(
            f"'{path}' is a trajectory of version {header.get('version')!r}; this humanoid-ik "
            f"reads version {TRAJECTORY_VERSION}"
        )
    return header


def _kind(effector: dict[str, Any]) -> str:
    """What an effector of a file's header names: ``body`` when it has a ``body`` key,
    else ``site`` (also a file written before the kind was kept, which said ``site``
    for a body too)."""
    return "body" if "body" in effector else "site"


def _trajectory(header: dict[str, Any], arrays: dict[str, Any], path: Path) -> Trajectory:
    """A :class:`Trajectory` from a header and its arrays (``effector{k}_*``, ``time``,
    ``qpos``); a missing key is a :class:`TrajectoryFileError` naming it."""
    try:
        tracks = []
        for k, e in enumerate(header["effectors"]):
            prefix = f"effector{k}_"
            a = {key[len(prefix) :]: v for key, v in arrays.items() if key.startswith(prefix)}
            kind = _kind(e)
            tracks.append(
                EffectorTrack(
                    site=e[kind],
                    kind=kind,
                    target_name=e["target"],
                    task=e["task"],
                    solver=e["solver"],
                    joints=tuple(e["joints"]),
                    q=a["q"],
                    target=a["target"],
                    target_quat=a["target_quat"] if e["pose_target"] else None,
                    achieved=a["achieved"],
                    position_error=a["position_error"],
                    on_target=a["on_target"],
                    reachable=a["reachable"],
                    status=tuple(str(s) for s in a["status"]),
                    **{name: a.get(name) for name in _SAMPLES},
                )
            )
        r = header["render"]
        render = RenderSpec(**{**r, "snapshots": tuple(r["snapshots"])})
        return Trajectory(
            time=arrays["time"],
            qpos=arrays["qpos"],
            qpos_names=tuple(header["qpos_names"]),
            joint_names=tuple(header["joint_names"]),
            effectors=tuple(tracks),
            fps=float(header["fps"]),
            scene=str(header["scene"]),
            scene_file=str(header["scene_file"]),
            model_file=str(header["model_file"]),
            model_sha256=str(header["model_sha256"]),
            render=render,
            interrupted=bool(header["interrupted"]),
            stage_points=arrays.get("stage_points", header["stage_points"]),
        )
    except (KeyError, TypeError) as exc:
        raise TrajectoryFileError(f"'{path}' lacks {exc} or has it of the wrong type") from None


def _read_npz(path: Path) -> Trajectory:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise TrajectoryFileError(f"cannot read trajectory '{path}': {exc}") from None
    if "header" not in arrays:
        raise TrajectoryFileError(f"'{path}' is not a humanoid-ik trajectory file")
    try:
        header = json.loads(str(arrays.pop("header")))
    except ValueError:
        raise TrajectoryFileError(f"'{path}' has a header that is not JSON") from None
    return _trajectory(_check_header(header, path), arrays, path)


def _read_csv(path: Path) -> Trajectory:
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise TrajectoryFileError(f"cannot read trajectory '{path}': {exc}") from None
    first, _, body = text.partition("\n")
    try:
        header = json.loads(first[1:]) if first.startswith("#") else None
    except ValueError:
        header = None
    header = _check_header(header, path)
    rows = list(csv.reader(io.StringIO(body)))
    cols, rows = rows[0], rows[1:]
    table = {c: [r[j] for r in rows] for j, c in enumerate(cols)}

    def floats(names: list[str]) -> np.ndarray:
        return np.array([table[n] for n in names], dtype=np.float64).T.reshape(len(rows), -1)

    arrays: dict[str, Any] = {"time": floats(["time_s"])[:, 0]}
    arrays["qpos"] = floats(list(header["qpos_names"]))
    try:
        for k, e in enumerate(header["effectors"]):
            p, key = f"{e[_kind(e)]}.", f"effector{k}_"
            arrays[key + "target"] = floats([f"{p}target_{c}" for c in "xyz"])
            if e["pose_target"]:
                arrays[key + "target_quat"] = floats([f"{p}target_{c}" for c in _QUAT])
            arrays[key + "achieved"] = floats([f"{p}achieved_{c}" for c in "xyz"])
            arrays[key + "position_error"] = floats([f"{p}position_error_m"])[:, 0]
            arrays[key + "on_target"] = np.array(table[f"{p}on_target"], dtype=int) == 1
            arrays[key + "reachable"] = np.array(table[f"{p}reachable"], dtype=int) == 1
            arrays[key + "status"] = table[f"{p}status"]
            if any(f"{p}{col}" in table for col in _SAMPLES.values()):  # all or none
                for name, col in _SAMPLES.items():
                    arrays[key + name] = floats([f"{p}{col}"])[:, 0]
            idx = [list(header["qpos_names"]).index(j) for j in e["joints"]]
            arrays[key + "q"] = arrays["qpos"][:, idx]
    except (KeyError, ValueError) as exc:
        raise TrajectoryFileError(f"'{path}' lacks column {exc}") from None
    return _trajectory(header, arrays, path)


def load_trajectory(path: str | os.PathLike) -> Trajectory:
    """Read a ``trajectory.npz`` or ``trajectory.csv`` written by :func:`write_trajectory`.

    Raises:
        TrajectoryFileError: the file does not exist, is neither, or misses a part.
    """
    p = Path(path)
    if not p.is_file():
        raise TrajectoryFileError(f"trajectory file '{p}' does not exist")
    if p.suffix.lower() == ".csv":
        return _read_csv(p)
    if p.suffix.lower() == ".npz":
        return _read_npz(p)
    raise TrajectoryFileError(f"trajectory file '{p}' is neither .npz nor .csv")


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
        raise TrajectoryFileError(
            f"model file '{mfile}' of trajectory '{path}' does not exist; pass the model it "
            "was recorded on with --model"
        )
    model = load_model(mfile, packages=packages)
    digest = model_digest(mfile, packages=packages)
    check_trajectory_model(traj, model, digest)
    if staged:
        aspect = traj.render.width / traj.render.height
        model = trajectory_stage(mfile, traj, aspect, model, packages=packages)
    return traj, model, digest
