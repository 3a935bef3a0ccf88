"""A retarget run: read the clip, find both sides, solve every frame, write the outputs as
one set; and a folder of clips, resumable, with a summary table.

Files of one clip (``staged_outputs``: they replace the previous run's as one set):
``trajectory.npz``/``trajectory.csv`` (the robot's motion, as any run's: one effector
per hand, ``reach``, and the gaze, ``look_at``), ``keys.xml`` (MuJoCo keyframes, one per
frame), ``robot.bvh`` (the robot's motion for animation tools, where BVH can hold it;
``metrics.json``'s ``bvh`` says), ``metrics.csv`` (per frame, :mod:`.metrics`),
``metrics.json`` (what was mapped, the settings and the summary) and ``metrics.png``;
with a film, ``film.mp4``, the ``frame_NNNN.png`` snapshots and ``contact_sheet.png``
(the robot and the human skeleton beside it, ``outputs/render/skeleton.py``).

A clip's name (the trajectory's scene, a folder run's output folder) is the file's stem
made a :data:`~humanoid_ik.core.names.NAME` (:func:`clip_name`).
"""

from __future__ import annotations

import math
import os
import re
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.measures import ON_TARGET_ANGLE, ON_TARGET_DISTANCE, gaze_error
from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.models import load_model, model_file
from humanoid_ik.core.names import MAX_NAME, name_ok
from humanoid_ik.core.robot import joint_name
from humanoid_ik.errors import RetargetError, TrajectoryFileError
from humanoid_ik.experiments.retarget.elbow import elbow_error
from humanoid_ik.experiments.retarget.human import HumanSide, Mapping, find_human
from humanoid_ik.experiments.retarget.metrics import FrameTable, jerk, plot_retarget
from humanoid_ik.experiments.retarget.robot import RobotSide, model_label
from humanoid_ik.experiments.retarget.solve import Retargeter
from humanoid_ik.experiments.retarget.targets import BENT, REACH, Targets, scaled_targets
from humanoid_ik.motion.bvh import BVHClip, read_bvh
from humanoid_ik.outputs.atomic import published, staged_outputs, write_json, write_text
from humanoid_ik.outputs.bvh import bvh_text
from humanoid_ik.outputs.keyframes import keyframes_xml
from humanoid_ik.outputs.trajectory import write_trajectory
from humanoid_ik.run.trajectory import EffectorTrack, Trajectory, qpos_names

__all__ = [
    "CLIP_FILES",
    "FILM",
    "FILM_FILES",
    "RetargetResult",
    "clip_name",
    "retarget",
    "clip_settings",
]

CLIP_FILES = (
    "keys.xml",
    "metrics.csv",
    "metrics.json",
    "metrics.png",
    "trajectory.csv",
    "trajectory.npz",
)
"""The files one clip's retarget writes (``metrics.png`` only with the plot)."""
FILM_FILES = ("contact_sheet.png", "film.mp4")
"""... and with a film (besides its ``frame_NNNN.png`` snapshots)."""
FILM = RenderSpec(width=480, height=360)
"""The film's defaults (``--film``): small, the front camera, trails, four snapshots."""


def clip_name(path: str | os.PathLike[str]) -> str:
    """The name of the clip at ``path``: its stem with every character a
    :data:`~humanoid_ik.core.names.NAME` may not hold replaced by ``_``, the ends trimmed
    of ``_``, ``.`` and ``-``, at most :data:`~humanoid_ik.core.names.MAX_NAME` characters
    (``Walk 01.bvh`` -> ``Walk_01``; ``clip`` when nothing is left)."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(path).stem)[:MAX_NAME].strip("_.-")
    return name if name_ok(name) else "clip"


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


def clip_settings(
    clip_path: Path,
    model: str | os.PathLike[str] | None,
    solver: str,
    frames: int | None,
    mapping: str | os.PathLike[str] | None,
    limbs: str | os.PathLike[str] | None,
    packages: dict[str, Path] | None,
    reach: float = REACH,
    film: RenderSpec | None = None,
) -> dict[str, Any]:
    """What a clip's outputs were made with (``metrics.json``; a folder run skips a clip
    whose outputs were made with the same)."""
    mpath = model_file(model)
    import hashlib

    out: dict[str, Any] = {
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
    if reach != REACH:
        out["reach"] = reach
    if film is not None:
        out["film"] = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(film).items()}
    return out


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
    film: RenderSpec | None = None,
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
        film: film the robot with the human skeleton beside it (``film.mp4``, snapshots,
            contact sheet: :data:`FILM` is a small one); ``None``: no film.

    Raises:
        BVHError: a bad BVH file, or a skeleton without arms.
        RetargetError: a bad mapping file or solver, a robot without arms.
        ModelError: a bad model file.
        RenderError: no OpenGL backend works, or the film's size or camera does not fit
            the model (nothing is written then).
    """
    clip_path = Path(clip_path)
    settings = clip_settings(
        clip_path, model, solver, frames, mapping, limbs, packages, reach, film
    )
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
            doc["bvh"] = _robot_bvh(traj, robot.model, staging)
            write_text(staging / "metrics.csv", table.csv_text())
            if plot:
                title = f"{traj.scene} on {model_label(model)} ({solver})"
                plot_retarget(table, title, staging / "metrics.png")
            if film is not None:
                arms = list(solver_.arms)
                doc["film"] = _film(clip, human, robot, arms, traj, film, staging, packages)
            write_json(staging / "metrics.json", doc)
        files = [out / n for n in published(out)]
    return RetargetResult(doc, files, traj, table)


def _robot_bvh(traj: Trajectory, model: Any, folder: Path) -> str:
    """Write the robot's motion as ``robot.bvh`` into ``folder`` (``export-bvh``'s
    writer) and say so; a robot BVH cannot hold (a slide joint that moves, hinges of
    one body about different points) is said instead, the keyframes holding it."""
    try:
        write_text(folder / "robot.bvh", bvh_text(traj, model))
    except TrajectoryFileError as exc:
        return f"not written: {exc}"
    return "robot.bvh"


def _film(
    clip: BVHClip,
    human: HumanSide,
    robot: RobotSide,
    arms: list[str],
    traj: Trajectory,
    render: RenderSpec,
    folder: Path,
    packages: dict[str, Path] | None,
) -> dict[str, Any]:
    """Film ``traj`` with the human skeleton beside the robot into ``folder`` (the
    staging folder); what ``metrics.json`` says of it. The skeleton is scaled by the
    mean arm lengths of the mapped arms, about the midpoint of their shoulders (one
    shoulder for a one-armed mapping), put at the robot's (``human_skeleton``).

    Raises:
        KeyboardInterrupt: Ctrl-C stopped the film (the set is then not published).
    """
    from humanoid_ik.outputs.render.skeleton import (
        beside_robot,
        film_with_skeleton,
        human_skeleton,
    )

    m = robot.model
    forward = robot.heading[:, 0]
    X = human_skeleton(
        clip.positions[: traj.n_frames],
        shoulders=tuple(human.arms[s].shoulder for s in arms),
        human_arm=float(np.mean([human.arms[s].length for s in arms])),
        robot_shoulders=[robot.arms[s].shoulder for s in arms],
        robot_arm=float(np.mean([robot.arms[s].length for s in arms])),
        forward=forward,
        heading_pair=human.heading_pair,
    )
    X = beside_robot(X, m, traj.qpos, forward)
    out = film_with_skeleton(
        traj, m, X, clip.skeleton.parents, folder, render=render, name="film",
        packages=packages,
    )  # fmt: skip
    if out.interrupted:
        raise KeyboardInterrupt
    return {
        "frames": out.frames,
        "size": [render.width, render.height],
        "camera": render.camera,
        "files": sorted(p.name for p in out.files()),
        "notes": list(out.notes),
    }


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
            plan = r.plan.get(side)
            in_ranges = None if plan is None else bool(plan.in_ranges[f])
            need = None if plan is None else float(plan.speed_need[f])
            feasible = ok and (plan is None or bool(plan.in_ranges[f]))
            ang, bend = elbow_error(c, t.elbow[f])
            elbow = math.degrees(ang) if min(bend, float(t.bend[f])) >= BENT else math.nan
            row |= {
                f"{side}_position_error_m": ep,
                f"{side}_orientation_error_deg": er,
                f"{side}_elbow_error_deg": elbow,
                f"{side}_reachable": ok,
                f"{side}_in_ranges": in_ranges,
                f"{side}_speed_need": need,
                f"{side}_feasible": feasible,
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
        scene=clip_name(clip_path),
        scene_file=str(clip_path),
        model_file=settings["model"],
        model_sha256=settings["model_sha256"],
    )
