"""Sweeps: a sweep file's grid of jobs (scenes or target sets x solver configurations x
seeds) run as independent jobs on a local process pool or on a Ray cluster, resumably,
then summarised.

Modules: ``jobs`` (running one job into its result), ``executors`` (local pool, Ray),
``ray_head`` (the process that drives a local Ray instance in a process group of its
own, run as a script), ``summary`` (summary rows, CSV/JSON, plot) and ``resume``
(:func:`run_sweep`: the job results on disk and what is left to run). The sweep file
itself (:class:`Job`, :class:`Sweep`, :func:`load_sweep`, :func:`parse_sweep`) is read
by :mod:`humanoid_ik.config.sweep_file` and re-exported here. ``read_records`` and
``damaged_records`` are the former names of :func:`read_results` and
:func:`damaged_results`, kept as deprecated aliases for one release.
"""

from humanoid_ik.config.sweep_file import Job, Sweep, load_sweep, parse_sweep
from humanoid_ik.errors import renamed
from humanoid_ik.experiments.sweep.executors import import_ray
from humanoid_ik.experiments.sweep.jobs import COLUMNS, TIMING_COLUMNS, run_job
from humanoid_ik.experiments.sweep.resume import (
    SweepResult,
    check_out,
    damaged_results,
    read_results,
    run_sweep,
)
from humanoid_ik.experiments.sweep.summary import plot_summary, summary_rows, write_summary

__all__ = [
    "COLUMNS",
    "TIMING_COLUMNS",
    "Job",
    "Sweep",
    "SweepResult",
    "check_out",
    "damaged_results",
    "import_ray",
    "load_sweep",
    "parse_sweep",
    "plot_summary",
    "read_results",
    "run_job",
    "run_sweep",
    "summary_rows",
    "write_summary",
]

_RENAMED = {"damaged_records": "damaged_results", "read_records": "read_results"}
"""Former names (a job's result was its "record"): old -> new, for one release."""

__getattr__ = renamed(__name__, _RENAMED, globals())
