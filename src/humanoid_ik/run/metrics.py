"""What a scene run measured: one sample per effector and frame, and the run's summary.

The runner fills a :class:`Metrics` frame by frame (it is one of the runner's frame
sinks); the outputs layer writes it to files.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.scene import Scene

__all__ = ["CSV_FIELDS", "EffectorSample", "FrameRecord", "Metrics"]


@dataclass(frozen=True)
class EffectorSample:
    """What one effector did in one frame (measured on the scene's ``MjData``).

    Attributes:
        effector: the site name.
        target_name: the target it tracks.
        task: ``reach`` or ``look_at``.
        target: target position ``(3,)`` [m].
        achieved: the site position ``(3,)`` [m]; for ``look_at`` the gaze point (on the
            site's x axis, as far from the site as the target).
        position_error: distance from the site to the target [m]; for ``look_at`` the
            distance from the target to the gaze ray.
        orientation_error: angle between achieved and target orientation [rad] (pose
            targets), the gaze's angle off the target (``look_at``), else ``None``.
        iterations: the solver's iterations.
        solve_time: the solver's wall time [s] (a solver that moves several effectors
            at once splits its time equally).
        limit_margin: smallest distance of a chain joint to its range end [rad].
        reachable: the target lies within the chain's reach (``look_at``: the gaze can
            turn onto it within the joint ranges).
        on_target: within :data:`ON_TARGET_DISTANCE` (and :data:`ON_TARGET_ANGLE`).
        status: the solver's status.
    """

    effector: str
    target_name: str
    task: str
    target: NDArray[np.float64]
    achieved: NDArray[np.float64]
    position_error: float
    orientation_error: float | None
    iterations: int
    solve_time: float
    limit_margin: float
    reachable: bool
    on_target: bool
    status: str


@dataclass(frozen=True)
class FrameRecord:
    """One frame: its index, time [s] and one sample per effector (scene order)."""

    index: int
    time: float
    samples: tuple[EffectorSample, ...]

    @property
    def solve_time(self) -> float:
        """Total solver time of the frame [s]."""
        return float(sum(s.solve_time for s in self.samples))


CSV_FIELDS = [
    "frame",
    "time_s",
    "effector",
    "target_name",
    "task",
    "target_x",
    "target_y",
    "target_z",
    "achieved_x",
    "achieved_y",
    "achieved_z",
    "position_error_m",
    "orientation_error_rad",
    "iterations",
    "solve_time_s",
    "limit_margin_rad",
    "reachable",
    "on_target",
    "status",
]


class Metrics:
    """Every frame's record of a run, with CSV/JSON export and a summary.

    Args:
        scene: the scene that ran.
        solvers: the solver label of each effector (scene order).

    Attributes:
        frames: every frame's record, in order.
        frame_times: wall time of each frame in the runner's loop [s] (solve,
            ``mj_forward``, measuring and every output taking the frame); not exported.
        interrupted: Ctrl-C stopped the run early.
    """

    def __init__(self, scene: Scene, solvers: Sequence[str]):
        self.scene = scene
        self.solvers = list(solvers)
        self.frames: list[FrameRecord] = []
        self.frame_times: list[float] = []
        self.interrupted = False

    def __len__(self) -> int:
        return len(self.frames)

    def append(self, frame: FrameRecord) -> None:
        """Add a frame's record."""
        self.frames.append(frame)

    def add_frame(self, record: FrameRecord, data: mujoco.MjData) -> None:
        """Add a frame's record (as a sink of the runner's loop; ``data`` is not needed)."""
        self.frames.append(record)

    def series(self, effector: int, attribute: str) -> NDArray[np.float64]:
        """One attribute of one effector over the frames ``(frames,)`` (``None`` -> NaN)."""
        vals = [getattr(f.samples[effector], attribute) for f in self.frames]
        return np.array([math.nan if v is None else v for v in vals], dtype=np.float64)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per frame and effector, keyed like the CSV columns."""
        out = []
        for f in self.frames:
            for s in f.samples:
                out.append(
                    {
                        "frame": f.index,
                        "time_s": f.time,
                        "effector": s.effector,
                        "target_name": s.target_name,
                        "task": s.task,
                        "target_x": float(s.target[0]),
                        "target_y": float(s.target[1]),
                        "target_z": float(s.target[2]),
                        "achieved_x": float(s.achieved[0]),
                        "achieved_y": float(s.achieved[1]),
                        "achieved_z": float(s.achieved[2]),
                        "position_error_m": s.position_error,
                        "orientation_error_rad": s.orientation_error,
                        "iterations": s.iterations,
                        "solve_time_s": s.solve_time,
                        "limit_margin_rad": s.limit_margin,
                        "reachable": s.reachable,
                        "on_target": s.on_target,
                        "status": s.status,
                    }
                )
        return out

    def summary(self) -> list[dict[str, Any]]:
        """Per effector: frames, reachable frames, share on target while reachable, worst
        and median position error while reachable [m], median and worst solve time [s]."""
        out = []
        for k, eff in enumerate(self.scene.effectors):
            err = self.series(k, "position_error")
            reach = self.series(k, "reachable").astype(bool)
            on = self.series(k, "on_target").astype(bool)
            st = self.series(k, "solve_time")
            er = err[reach]
            out.append(
                {
                    "effector": eff.name,
                    "target": eff.target,
                    "task": eff.task,
                    "solver": self.solvers[k],
                    "frames": len(self.frames),
                    "reachable_frames": int(reach.sum()),
                    "on_target_when_reachable": float(on[reach].mean()) if er.size else None,
                    "max_position_error_reachable_m": float(er.max()) if er.size else None,
                    "median_position_error_reachable_m": float(np.median(er)) if er.size else None,
                    "median_solve_time_s": float(np.median(st)) if st.size else None,
                    "max_solve_time_s": float(st.max()) if st.size else None,
                    "max_iterations": int(self.series(k, "iterations").max()) if self.frames else 0,
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the scene, the summary and every sample."""
        sc = self.scene
        return {
            "scene": sc.name,
            "source": sc.source,
            "fps": sc.fps,
            "frames": len(self.frames),
            "interrupted": self.interrupted,
            "effectors": [
                {e.kind: e.name, "target": e.target, "task": e.task, "solver": s}
                for e, s in zip(sc.effectors, self.solvers, strict=True)
            ],
            "summary": self.summary(),
            "samples": self.rows(),
        }

    def csv_text(self) -> str:
        """The samples as CSV text (one row per frame and effector)."""
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
        w.writeheader()
        for row in self.rows():
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()
