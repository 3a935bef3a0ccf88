"""Where a sweep's jobs run: a local process pool (the default) or a Ray cluster.

Both take the jobs to run and an ``on_done(job, record)`` callback that the calling
process runs as each record comes back (in completion order), so results are written by
one process and a Ray cluster needs no shared file system. A worker that dies gives a
``failed`` record (:func:`~humanoid_ik.experiments.sweep.jobs.failed_record`) instead of
stopping the others.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from humanoid_ik.config.sweep_file import Job
from humanoid_ik.errors import SweepError
from humanoid_ik.experiments.sweep.jobs import failed_record, run_job

__all__ = ["PRELOAD", "OnDone", "import_ray", "run_local", "run_ray"]

OnDone = Callable[[Job, dict[str, Any]], None]
"""``on_done(job, record)``, called in the calling process as each job finishes."""
PRELOAD = (
    "humanoid_ik.experiments.sweep.jobs",
    "humanoid_ik.run.runner",
    "humanoid_ik.experiments.bench",
)
"""Modules the local pool's forkserver imports once, before it forks the workers: what
:func:`~humanoid_ik.experiments.sweep.jobs.run_job` needs."""


def run_local(jobs: Sequence[Job], workers: int, on_done: OnDone) -> None:
    """Run ``jobs`` on ``workers`` local processes (forkserver, see :data:`PRELOAD`).

    Ctrl-C cancels the jobs not yet started and is raised again.
    """
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        pending = {pool.submit(run_job, job): job for job in jobs}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    job = pending.pop(fut)
                    try:
                        rec = fut.result()
                    except Exception as exc:  # noqa: BLE001 - a dead worker
                        rec = failed_record(job, exc)
                    on_done(job, rec)
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise


def import_ray():
    """The ``ray`` module.

    Raises:
        SweepError: Ray is not installed (the message says how to install it).
    """
    try:
        import ray
    except ImportError:
        raise SweepError(
            None, "", "Ray is not installed; install it with pip install 'humanoid-ik[ray]'"
        ) from None
    return ray


def run_ray(jobs: Sequence[Job], workers: int | None, address: str, on_done: OnDone) -> None:
    """Run ``jobs`` as Ray tasks (1 CPU each, no retries).

    Args:
        jobs: the jobs.
        workers: CPUs of a local Ray instance (default ``os.cpu_count()``).
        address: ``"local"`` starts a private instance, anything else is passed to
            ``ray.init(address=...)``. A Ray already initialised in this process is used
            as it is (and left running); one started here is shut down at the end.
        on_done: called as each record comes back.

    Raises:
        SweepError: Ray is not installed.
    """
    ray = import_ray()
    started = False
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "configure_logging": False,
        }
        if address == "local":
            ray.init(num_cpus=workers or os.cpu_count(), **kwargs)
        else:
            ray.init(address=address, **kwargs)
        started = True
    try:
        task = ray.remote(num_cpus=1, max_retries=0)(run_job)
        pending = {task.remote(job): job for job in jobs}
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                job = pending.pop(ref)
                try:
                    rec = ray.get(ref)
                except Exception as exc:  # noqa: BLE001 - a dead worker or node
                    rec = failed_record(job, exc)
                on_done(job, rec)
    finally:
        if started:
            ray.shutdown()
