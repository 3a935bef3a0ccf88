"""The metrics plot of a run: position error and solve time over time, per effector."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from humanoid_ik.outputs.atomic import atomic_path
from humanoid_ik.outputs.render.drawing import TRAIL_COLORS
from humanoid_ik.run.recording import Recording

__all__ = ["plot_metrics"]


def plot_metrics(metrics: Recording, path: str | os.PathLike) -> Path:
    """Plot position error [mm] (log scale) and solve time [ms] over time, per effector,
    with the frames where a target is out of reach shaded; written atomically as PNG.

    Args:
        metrics: a run's metrics (at least one frame).
        path: the PNG to write (800 x 500 px).

    Returns:
        ``path``.
    """
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    fig = Figure(figsize=(8, 5), dpi=100)
    ax_e, ax_t = fig.subplots(2, 1, sharex=True)
    times = np.array([f.time for f in metrics.frames])
    for k, eff in enumerate(metrics.scene.effectors):
        label = f"{eff.name} ({metrics.solvers[k]})"
        rgb = TRAIL_COLORS[k % len(TRAIL_COLORS)]
        err = np.maximum(metrics.series(k, "position_error") * 1e3, 1e-6)
        ax_e.plot(times, err, color=rgb, label=label, lw=1.4)
        ax_t.plot(times, metrics.series(k, "solve_time") * 1e3, color=rgb, label=label, lw=1.2)
        out = ~metrics.series(k, "reachable").astype(bool)
        if out.any() and times.size > 1:
            dt = float(times[1] - times[0])
            for i in np.flatnonzero(out):
                ax_e.axvspan(times[i] - dt / 2, times[i] + dt / 2, color="red", alpha=0.08, lw=0)
    ax_e.axhline(1.0, color="gray", ls="--", lw=0.8)
    ax_e.set_yscale("log")
    ax_e.set_ylabel("position error [mm]")
    ax_e.set_title(f"{metrics.scene.name}: error and solve time (red: target out of reach)")
    ax_e.legend(fontsize=7, loc="upper right")
    ax_t.set_ylabel("solve time [ms]")
    ax_t.set_xlabel("time [s]")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return Path(path)
