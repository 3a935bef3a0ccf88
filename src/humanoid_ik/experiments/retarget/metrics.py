"""Per-frame metrics of a retarget, their summary and the plot.

Columns of ``metrics.csv`` (one row per frame; ``<side>`` is ``left`` or ``right``):

- ``<side>_position_error_m``: the hand's distance to its scaled target;
  ``<side>_reachable``: the target lies within the arm's reach (its distance from the
  arm's first joint at most the sampled reach, as a scene run says it);
- ``<side>_in_ranges``: some swivel reaches the pose exactly inside the joint ranges
  (``closed_form`` arms, from the swivel plan's grid at the nearest planned frame; empty
  for other arms: not known); ``<side>_speed_need``: the plan's largest joint speed over
  its limit around this frame (above 1: the grid's swivels, 7.5 degrees apart, do not
  follow the clip within the speed limits; the frame loop, solving inside the speed
  box, may); ``<side>_feasible``: reachable, and for a planned arm in the ranges: the
  frames the hand's ``feasible`` errors are over;
- ``<side>_orientation_error_deg``: the hand frame's angle to its target orientation;
- ``<side>_elbow_error_deg``: the angle between the robot's and the human's elbow
  directions about the shoulder-wrist line (empty where either elbow is nearer its
  shoulder-wrist line than :data:`~.targets.BENT` of the upper arm: a nearly straight
  arm, whose elbow direction is not defined or not pulled in full);
- ``<side>_solver``: what solved it (``closed_form``, ``lm``, ``mink``; ``+lm(position)``:
  a pose out of reach solved for the position);
- ``gaze_error_deg``: the gaze axis's angle to the human head's direction (empty without
  a moving head);
- ``limit_margin_rad``: the smallest distance of any arm or head joint to its range end
  (negative: out of range);
- ``speed_ratio``: the largest joint speed over its limit (1: at the limit);
  ``speed_cut``: a joint was held to its limit this frame;
- ``collisions``: derived pairs in contact (``mj_geomDistance`` < 0); ``qp_fallback``:
  the frame was solved again by the QP;
- ``<side>_jerk``: the hand's jerk [m/s^3] (third difference of its positions; empty on
  the first three frames);
- ``wall_ms``, ``cpu_ms``: the frame's solve, limits and collision check.

The summary (``metrics.json``): for each error its median, 99th percentile and maximum
(hand positions over reachable frames, and over feasible ones: within the joint ranges
as far as the swivel plan knows), the counts of frames out of
range, over a speed limit, cut to a limit, in collision and solved by the QP fallback,
the hands' RMS jerk next to the scaled human source's, and frames per second (wall and
CPU).
"""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.outputs.atomic import atomic_path

__all__ = ["FrameTable", "plot_retarget", "stats"]


def stats(values: NDArray[np.float64] | list[float]) -> dict[str, float | None]:
    """Median, 99th percentile and maximum of the finite ``values`` (``None`` if none)."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not v.size:
        return {"median": None, "p99": None, "max": None}
    return {
        "median": float(np.median(v)),
        "p99": float(np.percentile(v, 99)),
        "max": float(v.max()),
    }


def jerk(x: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """``(F,)`` the jerk's magnitude of positions ``x (F, 3)`` [m/s^3] (NaN on the first
    three frames)."""
    out = np.full(len(x), math.nan)
    if len(x) > 3:
        out[3:] = np.linalg.norm(np.diff(x, n=3, axis=0), axis=1) / dt**3
    return out


class FrameTable:
    """The columns of every frame, filled as the frames are solved."""

    def __init__(self, sides: list[str], gaze: bool):
        self.sides, self.gaze = sides, gaze
        self.cols: dict[str, list[Any]] = {}

    def add(self, row: dict[str, Any]) -> None:
        for k, v in row.items():
            self.cols.setdefault(k, []).append(v)

    def array(self, key: str) -> NDArray[np.float64]:
        return np.array(
            [math.nan if v is None else float(v) for v in self.cols.get(key, [])], dtype=np.float64
        )

    def __len__(self) -> int:
        return len(self.cols.get("frame", []))

    def csv_text(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        keys = list(self.cols)
        w.writerow(keys)
        for i in range(len(self)):
            row: list[Any] = []
            for k in keys:
                v = self.cols[k][i]
                if v is None or (isinstance(v, float) and not math.isfinite(v)):
                    row.append("")
                elif isinstance(v, bool):
                    row.append(int(v))
                else:
                    row.append(v)
            w.writerow(row)
        return buf.getvalue()

    def summary(self, dt: float, source: dict[str, NDArray[np.float64]]) -> dict[str, Any]:
        """The summary (see the module); ``source`` the scaled human hand positions per
        side ``(F, 3)``, for the jerk comparison."""
        out: dict[str, Any] = {"frames": len(self)}
        for s in self.sides:
            reach = self.array(f"{s}_reachable").astype(bool)
            err = self.array(f"{s}_position_error_m")
            feasible = self.array(f"{s}_feasible").astype(bool)
            hand = {
                "reachable_frames": int(reach.sum()),
                "position_error_reachable_m": stats(err[reach]),
                "feasible_frames": int(feasible.sum()),
                "position_error_feasible_m": stats(err[feasible]),
                "position_error_m": stats(err),
                "orientation_error_deg": stats(self.array(f"{s}_orientation_error_deg")),
                "elbow_error_deg": stats(self.array(f"{s}_elbow_error_deg")),
                "elbow_frames": int(np.isfinite(self.array(f"{s}_elbow_error_deg")).sum()),
            }
            j = self.array(f"{s}_jerk")
            js = jerk(source[s], dt)
            hand["jerk_rms_m_s3"] = _rms(j)
            hand["source_jerk_rms_m_s3"] = _rms(js)
            solvers = self.cols.get(f"{s}_solver", [])
            hand["solvers"] = {n: solvers.count(n) for n in sorted(set(solvers))}
            out[s] = hand
        if self.gaze:
            out["gaze_error_deg"] = stats(self.array("gaze_error_deg"))
        margin = self.array("limit_margin_rad")
        ratio = self.array("speed_ratio")
        out["min_limit_margin_rad"] = float(margin.min()) if margin.size else None
        out["frames_out_of_range"] = int((margin < -1e-9).sum())
        out["max_speed_ratio"] = float(np.nanmax(ratio)) if np.isfinite(ratio).any() else None
        out["frames_over_speed_limit"] = int((ratio > 1.0 + 1e-6).sum())
        out["frames_speed_cut"] = int(self.array("speed_cut").sum())
        out["collision_frames"] = int((self.array("collisions") > 0).sum())
        out["qp_fallback_frames"] = int(self.array("qp_fallback").sum())
        wall, cpu = self.array("wall_ms"), self.array("cpu_ms")
        out["wall_ms"] = stats(wall)
        out["frames_per_s_wall"] = float(len(wall) / (wall.sum() / 1e3)) if wall.sum() else None
        out["frames_per_s_cpu"] = float(len(cpu) / (cpu.sum() / 1e3)) if cpu.sum() else None
        return out


def _rms(v: NDArray[np.float64]) -> float | None:
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v * v))) if v.size else None


def plot_retarget(table: FrameTable, title: str, path: str | os.PathLike[str]) -> Path:
    """Hand position error [mm] (log), elbow and gaze error [deg] and the largest joint
    speed over its limit, over time; written atomically as PNG (800 x 700 px)."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    fig = Figure(figsize=(8, 7), dpi=100)
    ax_p, ax_e, ax_s = fig.subplots(3, 1, sharex=True)
    t = table.array("time_s")
    colors = {"left": "tab:blue", "right": "tab:orange"}
    for s in table.sides:
        err = np.maximum(table.array(f"{s}_position_error_m") * 1e3, 1e-6)
        ax_p.plot(t, err, color=colors[s], lw=1.2, label=f"{s} hand")
        ax_e.plot(
            t, table.array(f"{s}_elbow_error_deg"), color=colors[s], lw=1.2, label=f"{s} elbow"
        )
    if table.gaze:
        ax_e.plot(t, table.array("gaze_error_deg"), color="tab:green", lw=1.2, label="gaze")
    ax_p.axhline(1.0, color="gray", ls="--", lw=0.8)
    ax_p.set_yscale("log")
    ax_p.set_ylabel("hand error [mm]")
    ax_p.set_title(title)
    ax_p.legend(fontsize=7, loc="upper right")
    ax_e.set_ylabel("direction error [deg]")
    ax_e.legend(fontsize=7, loc="upper right")
    ax_s.plot(t, table.array("speed_ratio"), color="tab:red", lw=1.0, label="joint speed / limit")
    coll = table.array("collisions") > 0
    if coll.any():
        ax_s.plot(t[coll], np.ones(coll.sum()), "kx", ms=4, label="self-collision")
    ax_s.axhline(1.0, color="gray", ls="--", lw=0.8)
    ax_s.set_ylabel("speed / limit")
    ax_s.set_xlabel("time [s]")
    ax_s.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return Path(path)
