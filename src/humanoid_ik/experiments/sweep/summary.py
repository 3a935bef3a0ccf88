"""A sweep's summary: one row per job, sorted so the order never depends on the executor,
written as ``summary.csv`` and ``summary.json``, and a plot comparing the solver
configurations (``summary.png``)."""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from humanoid_ik.config.sweep_file import Sweep
from humanoid_ik.experiments.sweep.jobs import COLUMNS, TIMING_COLUMNS
from humanoid_ik.outputs.atomic import atomic_path, write_json, write_text

__all__ = ["percent", "plot_summary", "status_counts", "summary_rows", "write_summary"]


def percent(share: float | None, spec: str = ".1f") -> str:
    """A share in [0, 1] as a percentage, rounded down at the last shown digit, so a
    share below 1 never reads 100 (``0.9975`` -> ``99.7``; ``1.0`` -> ``100.0``);
    ``-`` for ``None``.

    Args:
        share: the share, e.g. a success rate.
        spec: the format of the percentage, e.g. ``"11.1f"`` (fixed point: ``f``).
    """
    if share is None:
        width = spec.split(".")[0].lstrip(">")
        return format("-", f">{width}") if width else "-"
    decimals = int(spec.rsplit(".", 1)[1].rstrip("f")) if "." in spec else 0
    scale = 10**decimals
    # floor with a tolerance for binary fractions (0.29 * 1000 = 289.99999999999997)
    shown = math.floor(share * 100 * scale + 1e-6) / scale
    if share < 1.0:
        shown = min(shown, 100.0 - 1.0 / scale)
    return format(shown, spec)


def summary_rows(results: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The job results as summary rows (keys :data:`COLUMNS`), sorted by kind, name,
    configuration and seed, so the order never depends on the executor."""
    rows = [{k: r.get(k) for k in COLUMNS} for r in results]
    rows.sort(
        key=lambda r: (
            r["kind"],
            r["name"],
            r["config"],
            -1 if r["seed"] is None else r["seed"],
            r["id"],
        )
    )
    return rows


def status_counts(results: Sequence[Mapping[str, Any]]) -> dict[str, int]:
    """How many job results have each status, in order of first appearance."""
    counts: dict[str, int] = {}
    for r in results:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
    return counts


def _cell(value: Any) -> Any:
    """A job result's value as a CSV cell: ``None`` empty, a dict as JSON, a float exactly."""
    if value is None:
        return ""
    if isinstance(value, dict):
        return json.dumps(value, sort_keys=True)
    if isinstance(value, float):
        return repr(value)
    return value


def write_summary(
    sweep: Sweep, results: Sequence[Mapping[str, Any]], out: str | os.PathLike
) -> list[Path]:
    """Write ``summary.csv`` (one row per job) and ``summary.json`` (the sweep, counts
    by status and the same rows) into ``out`` atomically; returns both paths."""

    out = Path(out)
    rows = summary_rows(results)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _cell(v) for k, v in row.items()})
    write_text(out / "summary.csv", buf.getvalue())
    counts = status_counts(rows)
    doc = {
        "sweep": sweep.name,
        "description": sweep.description,
        "source": sweep.source,
        "jobs": len(rows),
        "counts": counts,
        "timing_columns": list(TIMING_COLUMNS),
        "rows": rows,
    }
    write_json(out / "summary.json", doc)
    return [out / "summary.csv", out / "summary.json"]


def plot_summary(
    results: Sequence[Mapping[str, Any]], path: str | os.PathLike, title: str = ""
) -> Path:
    """Three panels comparing solver configurations on every scene and target set:
    success rate, median time per solve [ms] and worst error [m] (means over seeds;
    failed and skipped jobs are left out). Written atomically as PNG; returns the path."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is left alone

    rows = [r for r in summary_rows(results) if r["status"] == "ok"]
    sets = sorted({(r["kind"], r["name"]) for r in rows})
    configs = sorted({r["config"] for r in rows})
    panels = (
        ("success_rate", "success rate", False),
        ("median_solve_ms", "median time per solve [ms]", True),
        ("max_error_m", "worst error [m]", True),
    )
    fig = Figure(figsize=(max(7.0, 1.2 + 0.9 * len(sets) * max(1, len(configs)) / 2), 9.5))
    axes = fig.subplots(3, 1, sharex=True)
    width = 0.8 / max(1, len(configs))
    xs = np.arange(len(sets))
    for ax, (col, label, log) in zip(axes, panels, strict=True):
        for k, cfg in enumerate(configs):
            vals = []
            for s in sets:
                v = [
                    r[col]
                    for r in rows
                    if (r["kind"], r["name"]) == s and r["config"] == cfg and r[col] is not None
                ]
                vals.append(float(np.mean(v)) if v else math.nan)
            arr = np.asarray(vals)
            if log:  # an exact zero would vanish from a log axis
                arr = np.where(np.isfinite(arr) & (arr <= 0), 1e-16, arr)
            ax.bar(xs - 0.4 + (k + 0.5) * width, arr, width, label=cfg)
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
        else:
            ax.set_ylim(0, 1.05)
        ax.grid(axis="y", alpha=0.3)
    axes[-1].set_xticks(xs, [f"{k}: {n}" for k, n in sets], rotation=20, ha="right")
    fig.legend(
        *axes[0].get_legend_handles_labels(),
        fontsize=8,
        ncols=min(3, max(1, len(configs))),
        loc="upper center",
    )
    if title:
        fig.suptitle(title, y=0.995, fontsize=10, x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=100)
    return path
