"""A retarget run: read the clip, find both sides, solve every frame, write the outputs as
one set; and a folder of clips, resumable, with a summary table.

Files of one clip (``staged_outputs``: they replace the previous run's as one set):
``trajectory.npz``/``trajectory.csv`` (the robot's motion, as any run's: one effector
per hand, ``reach``, and the gaze, ``look_at``), ``keys.xml`` (MuJoCo keyframes, one per
frame), ``metrics.csv`` (per frame, :mod:`.metrics`), ``metrics.json`` (what was
mapped, the settings and the summary) and ``metrics.png``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.measures import ON_TARGET_ANGLE, ON_TARGET_DISTANCE, gaze_error
from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.models import load_model, model_file
from humanoid_ik.core.robot import joint_name
from humanoid_ik.errors import HumanoidIKError, RetargetError
from humanoid_ik.experiments.retarget.elbow import elbow_angle
from humanoid_ik.experiments.retarget.human import Mapping, find_human
from humanoid_ik.experiments.retarget.metrics import FrameTable, jerk, plot_retarget
from humanoid_ik.experiments.retarget.robot import RobotSide, model_label
from humanoid_ik.experiments.retarget.solve import Retargeter
from humanoid_ik.experiments.retarget.targets import BENT, REACH, Targets, scaled_targets
from humanoid_ik.motion.bvh import read_bvh
from humanoid_ik.outputs.atomic import published, staged_outputs, write_json, write_text
from humanoid_ik.outputs.keyframes import keyframes_xml
from humanoid_ik.outputs.trajectory import write_trajectory
from humanoid_ik.run.trajectory import EffectorTrack, Trajectory, qpos_names

__all__ = ["CLIP_FILES", "SUMMARY_FIELDS", "RetargetResult", "done", "retarget", "retarget_folder"]

CLIP_FILES = (
    "keys.xml",
    "metrics.csv",
    "metrics.json",
    "metrics.png",
    "trajectory.csv",
    "trajectory.npz",
)
"""The files one clip's retarget writes (``metrics.png`` only with the plot)."""


@dataclass
class RetargetResult:
    """One clip retargeted: the summary (what ``metrics.json`` holds), the files written,
    the trajectory and the per-frame table."""

    doc: dict[str, Any]
    files: list[Path]
    trajectory: Trajectory
    table: FrameTable

    @property
    def summary(self) -> dict[str, Any]:
        return dict(self.doc["summary"])


def _angle(R: np.ndarray, T: np.ndarray) -> float:
    c = (float(np.trace(R.T @ T)) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _settings(
    clip_path: Path,
    model: str | os.PathLike[str] | None,
    solver: str,
    frames: int | None,
    mapping: str | os.PathLike[str] | None,
    limbs: str | os.PathLike[str] | None,
    packages: dict[str, Path] | None,
) -> dict[str, Any]:
    mpath = model_file(model)
    import hashlib

    return {
        "clip": str(clip_path),
        "clip_sha256": hashlib.sha256(clip_path.read_bytes()).hexdigest()[:16]
        if clip_path.is_file()
        else "",
        "model": str(mpath),
        "model_sha256": model_digest(mpath, packages=packages),
        "solver": solver,
        "frames": frames,
        "mapping": None if mapping is None else str(mapping),
        "limbs": None if limbs is None else str(limbs),
    }


def retarget(
    clip_path: str | os.PathLike[str],
    model: str | os.PathLike[str] | None = None,
    out_dir: str | os.PathLike[str] | None = None,
    *,
    solver: str = "auto",
    mapping: str | os.PathLike[str] | None = None,
    frames: int | None = None,
    packages: dict[str, Path] | None = None,
    limbs: str | os.PathLike[str] | None = None,
    plot: bool = True,
    reach: float = REACH,
) -> RetargetResult:
    """Retarget the BVH clip ``clip_path`` onto ``model`` (a model file, ``None``: the
    bundled humanoid) and write its files into ``out_dir`` (``None``: nothing written).

    Args:
        solver: ``auto`` (exact per-arm solvers where they apply, ``lm`` otherwise, the QP
            for frames that would collide) or ``mink`` (the QP every frame).
        mapping: a mapping file (``human.py``): human joint names, a robot limb profile.
        frames: retarget the first ``frames`` frames only.
        packages: ROS package folders for a URDF's ``package://`` paths.
        limbs: a robot limb profile (``core/limbs.py``), over the mapping file's.
        plot: write ``metrics.png``.
        reach: the fraction of the robot's full-stretch arm length the human's full arm
            length maps onto (:data:`~.targets.REACH`).

    Raises:
        BVHError: a bad BVH file, or a skeleton without arms.
        RetargetError: a bad mapping file or solver, a robot without arms.
        ModelError: a bad model file.
    """
    clip_path = Path(clip_path)
    settings = _settings(clip_path, model, solver, frames, mapping, limbs, packages)
    if reach != REACH:
        settings["reach"] = reach
    if frames is not None and frames < 1:
        raise RetargetError(f"frames must be at least 1, got {frames}")
    if not (isinstance(reach, (int, float)) and 0.5 <= reach <= 1.0):
        raise RetargetError(f"reach must be a fraction in [0.5, 1], got {reach!r}")
    clip = read_bvh(clip_path)
    mp = None if mapping is None else Mapping.read(mapping)
    human = find_human(clip, mp)
    m = load_model(model, packages=packages)
    override = limbs if limbs is not None else (mp.limbs if mp is not None else None)
    profile = profile_for(m, None if model is None else model, override=override)
    robot = RobotSide(m, profile, settings["model"])
    targets = scaled_targets(clip, human, robot, frames, reach)
    if not targets.arms:
        raise RetargetError(
            f"no arm of the human ({', '.join(human.arms)}) matches an arm of the robot "
            f"({', '.join(robot.arms)})"
        )
    dt = clip.frame_time
    solver_ = Retargeter(robot, targets, dt, solver)
    table, qpos, samples = _run(solver_, robot, targets, dt)
    traj = _trajectory(clip_path, settings, robot, solver_, targets, qpos, samples, dt)
    source = {s: targets.arms[s].human_position for s in solver_.arms}
    doc = {
        "clip": str(clip_path),
        "model": settings["model"],
        "settings": settings,
        "human": {
            "names": human.names,
            "arm_length_m": {s: a.length for s, a in human.arms.items()},
            "detected": clip.detected,
        },
        "robot": robot.describe(),
        "scale": {s: t.scale for s, t in targets.arms.items()},
        "methods": solver_.method,
        "gaze": solver_.gaze_on,
        "summary": table.summary(dt, source),
    }
    files: list[Path] = []
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        with staged_outputs(out) as staging:
            write_trajectory(traj, staging)
            write_text(staging / "keys.xml", keyframes_xml(traj))
            write_text(staging / "metrics.csv", table.csv_text())
            write_json(staging / "metrics.json", doc)
            if plot:
                title = f"{clip_path.stem} on {model_label(model)} ({solver})"
                plot_retarget(table, title, staging / "metrics.png")
        files = [out / n for n in published(out)]
    return RetargetResult(doc, files, traj, table)


def _run(r: Retargeter, robot: RobotSide, targets: Targets, dt: float):
    """The frame loop: solve, measure, record."""
    sides = list(r.arms)
    table = FrameTable(sides, r.gaze_on)
    qpos = np.zeros((targets.frames, robot.model.nq))
    samples: dict[str, list[tuple]] = {n: [] for n in [*sides, "head"]}
    w0, c0 = time.perf_counter(), time.process_time()
    r.start()  # the first frame's start and the swivel plans: counted in frame 0's time
    setup = (time.perf_counter() - w0, time.process_time() - c0)
    data = robot.robot.data
    prev: dict[str, np.ndarray] = {}
    for f in range(targets.frames):
        fs = r.solve(f)
        row: dict[str, Any] = {"frame": f, "time_s": f * dt}
        margin, ratio = math.inf, 0.0
        for side, arm in r.arms.items():
            c, t = arm.chain, targets.arms[side]
            c.set_q(r.q[side])
            p, R = c.position.copy(), c.rotation.copy()
            ep = float(np.linalg.norm(p - t.position[f]))
            er = _angle(R, t.rotation(f)) if arm.pose else math.nan
            ok = float(np.linalg.norm(t.position[f] - arm.shoulder)) <= arm.length
            ang, bend = elbow_angle(arm, t.elbow[f])
            elbow = math.degrees(ang) if min(bend, float(t.bend[f])) >= BENT else math.nan
            row |= {
                f"{side}_position_error_m": ep,
                f"{side}_orientation_error_deg": er,
                f"{side}_elbow_error_deg": elbow,
                f"{side}_reachable": ok,
                f"{side}_solver": fs.solver.get(side, ""),
            }
            lm_ = c.limit_margin(r.q[side])
            margin = min(margin, lm_)
            res = fs.results[side]
            samples[side].append(
                (t.position[f], p, ep, er, ok, res.status.value, res.iterations, fs.seconds, lm_)
            )
        if r.gaze_on:
            assert robot.head is not None and targets.gaze is not None
            h = robot.head
            h.set_q(r.q["head"])
            g = gaze_error(h.position, h.rotation, robot.gaze_axis, targets.gaze[f])
            row["gaze_error_deg"] = math.degrees(g.angle)
            lm_ = h.limit_margin(r.q["head"])
            margin = min(margin, lm_)
            look = h.position + np.linalg.norm(targets.gaze[f] - h.position) * (
                h.rotation @ robot.gaze_axis
            )
            res = fs.results["head"]
            samples["head"].append(
                (
                    targets.gaze[f],
                    look,
                    g.miss,
                    g.angle,
                    True,
                    res.status.value,
                    res.iterations,
                    fs.seconds,
                    lm_,
                )
            )
        if f > 0:
            for name, q in r.q.items():
                lim = (robot.head_speed if name == "head" else robot.arms[name].speed) * dt
                ratio = max(ratio, float(np.max(np.abs(q - prev[name]) / lim)))
        prev = {n: q.copy() for n, q in r.q.items()}
        row |= {
            "limit_margin_rad": margin,
            "speed_ratio": ratio if f > 0 else math.nan,
            "speed_cut": any(fs.cut.values()),
            "collisions": fs.collisions,
            "qp_fallback": fs.fallback,
            "wall_ms": (fs.seconds + (setup[0] if f == 0 else 0.0)) * 1e3,
            "cpu_ms": (fs.cpu + (setup[1] if f == 0 else 0.0)) * 1e3,
        }
        table.add(row)
        qpos[f] = data.qpos
    for side in r.arms:
        achieved = np.array([s[1] for s in samples[side]])
        table.cols[f"{side}_jerk"] = jerk(achieved, dt).tolist()
    return table, qpos, samples


def _trajectory(
    clip_path: Path,
    settings: dict[str, Any],
    robot: RobotSide,
    r: Retargeter,
    targets: Targets,
    qpos: np.ndarray,
    samples: dict[str, list[tuple]],
    dt: float,
) -> Trajectory:
    m = robot.model
    n = targets.frames
    tracks = []
    for name in [*r.arms, *(["head"] if r.gaze_on else [])]:
        rows = samples[name]
        c = robot.head if name == "head" else robot.arms[name].chain
        assert c is not None
        look = name == "head"
        err = np.array([s[2] for s in rows])
        orient = np.array([s[3] for s in rows])
        quat = None
        if not look and robot.arms[name].pose:
            from humanoid_ik.core.rotations import mat_to_quat

            quat = np.array([mat_to_quat(targets.arms[name].rotation(f)) for f in range(n)])
            orient = np.radians(orient)
        on = err < ON_TARGET_DISTANCE
        if look:
            on = orient < ON_TARGET_ANGLE
        elif quat is not None:
            on = on & (orient < ON_TARGET_ANGLE)
        tracks.append(
            EffectorTrack(
                site=c.ee_name,
                target_name="gaze" if look else f"{name}_hand",
                task="look_at" if look else "reach",
                solver=r.method.get(name, ""),
                joints=tuple(c.joint_names),
                q=qpos[:, c.qpos_adr],
                target=np.array([s[0] for s in rows]),
                target_quat=quat,
                achieved=np.array([s[1] for s in rows]),
                position_error=err,
                on_target=on,
                reachable=np.array([s[4] for s in rows], dtype=bool),
                status=tuple(s[5] for s in rows),
                orientation_error=orient,
                iterations=np.array([s[6] for s in rows]),
                solve_time=np.array([s[7] for s in rows]),
                limit_margin=np.array([s[8] for s in rows]),
                kind=c.ee_kind,
            )
        )
    return Trajectory(
        time=np.arange(n, dtype=np.float64) * dt,
        qpos=qpos,
        qpos_names=tuple(qpos_names(m)),
        joint_names=tuple(joint_name(m, j) for j in range(m.njnt)),
        effectors=tuple(tracks),
        fps=1.0 / dt,
        scene=clip_path.stem,
        scene_file=str(clip_path),
        model_file=settings["model"],
        model_sha256=settings["model_sha256"],
    )


# ----------------------------------------------------------------------------- folders
SUMMARY_FIELDS = (
    "clip",
    "status",
    "frames",
    "left_median_mm",
    "left_p99_mm",
    "right_median_mm",
    "right_p99_mm",
    "elbow_median_deg",
    "gaze_median_deg",
    "frames_out_of_range",
    "frames_over_speed_limit",
    "collision_frames",
    "qp_fallback_frames",
    "frames_per_s_cpu",
    "error",
)
"""The columns of a folder's ``summary.csv``."""


def done(folder: Path, settings: dict[str, Any]) -> bool:
    """Whether ``folder`` holds a complete set of a clip's outputs made with ``settings``."""
    names = set(published(folder))
    if not {n for n in CLIP_FILES if n != "metrics.png"} <= names:
        return False
    try:
        doc = json.loads((folder / "metrics.json").read_text())
    except (OSError, ValueError):
        return False
    return bool(doc.get("settings") == settings) and all((folder / n).is_file() for n in names)


def _row(clip: str, status: str, doc: dict[str, Any] | None, error: str = "") -> dict[str, Any]:
    row: dict[str, Any] = {"clip": clip, "status": status, "error": error}
    if doc is None:
        return row
    s = doc["summary"]
    row["frames"] = s["frames"]
    elbows = []
    for side in ("left", "right"):
        if side in s:
            pe = s[side]["position_error_reachable_m"]
            row[f"{side}_median_mm"] = None if pe["median"] is None else pe["median"] * 1e3
            row[f"{side}_p99_mm"] = None if pe["p99"] is None else pe["p99"] * 1e3
            if s[side]["elbow_error_deg"]["median"] is not None:
                elbows.append(s[side]["elbow_error_deg"]["median"])
    row["elbow_median_deg"] = max(elbows) if elbows else None
    row["gaze_median_deg"] = s.get("gaze_error_deg", {}).get("median")
    for k in (
        "frames_out_of_range",
        "frames_over_speed_limit",
        "collision_frames",
        "qp_fallback_frames",
        "frames_per_s_cpu",
    ):
        row[k] = s[k]
    return row


def retarget_folder(
    folder: str | os.PathLike[str],
    model: str | os.PathLike[str] | None,
    out_dir: str | os.PathLike[str],
    *,
    progress: Any = None,
    **options: Any,
) -> tuple[list[dict[str, Any]], Path]:
    """Retarget every ``.bvh`` of ``folder`` (sorted by name) into ``out_dir/<stem>/``,
    one after the other (each clip is one process's work for a few seconds: a pool's
    start-up would cost more than it saves on a folder of short clips), skipping a clip
    whose outputs are complete and were made with the same settings; a clip that fails
    is a row with its one-line error, and the others run. Writes ``out_dir/summary.csv``.

    Args:
        progress: called as ``progress(clip, status)`` after each clip.
        options: :func:`retarget`'s keyword arguments.

    Returns:
        The summary rows and the summary file.

    Raises:
        RetargetError: ``folder`` holds no ``.bvh`` file.
    """
    src, out = Path(folder), Path(out_dir)
    clips = sorted(p for p in src.iterdir() if p.suffix.lower() == ".bvh" and p.is_file())
    if not clips:
        raise RetargetError(f"folder '{src}' holds no .bvh file")
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    keys = ("solver", "frames", "mapping", "limbs", "packages", "reach")
    for clip in clips:
        dest = out / clip.stem
        try:
            settings = _settings(
                clip,
                model,
                options.get("solver", "auto"),
                options.get("frames"),
                options.get("mapping"),
                options.get("limbs"),
                options.get("packages"),
            )
            if options.get("reach", REACH) != REACH:
                settings["reach"] = options["reach"]
            if done(dest, settings):
                doc = json.loads((dest / "metrics.json").read_text())
                rows.append(_row(clip.name, "skipped (done)", doc))
            else:
                given = {k: options[k] for k in keys if k in options}
                res = retarget(clip, model, dest, plot=options.get("plot", True), **given)
                rows.append(_row(clip.name, "ok", res.doc))
        except HumanoidIKError as exc:
            rows.append(_row(clip.name, "failed", None, str(exc)))
        if progress is not None:
            progress(clip.name, rows[-1]["status"])
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS, lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: "" if row.get(k) is None else row.get(k) for k in SUMMARY_FIELDS})
    path = write_text(out / "summary.csv", buf.getvalue())
    return rows, path
