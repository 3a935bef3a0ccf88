"""Where a sweep's jobs run: a local process pool (the default) or a Ray cluster.

Both take the jobs to run and an ``on_done(job, record)`` callback that the calling
process runs as each record comes back (in completion order), so results are written by
one process and a Ray cluster needs no shared file system. A worker that dies gives a
``failed`` record (:func:`~humanoid_ik.experiments.sweep.jobs.failed_record`) instead of
stopping the others.

Joining a Ray cluster gives up after about :data:`RAY_CONNECT_TIMEOUT_S` seconds (Ray's
own defaults wait minutes for an address where nothing answers): while Ray is imported
and while it connects, the environment variables of :data:`RAY_CONNECT_ENV` are set
where the caller has not set them, then restored (Ray reads some of them once, when it
is imported; a Ray imported before keeps its own timeouts).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any

from humanoid_ik.config.sweep_file import Job
from humanoid_ik.errors import SweepError
from humanoid_ik.experiments.sweep.jobs import failed_record, run_job

__all__ = [
    "MAX_WORKERS",
    "PRELOAD",
    "RAY_CONNECT_ENV",
    "RAY_CONNECT_TIMEOUT_S",
    "OnDone",
    "import_ray",
    "run_local",
    "run_ray",
]

OnDone = Callable[[Job, dict[str, Any]], None]
"""``on_done(job, record)``, called in the calling process as each job finishes."""
PRELOAD = (
    "humanoid_ik.experiments.sweep.jobs",
    "humanoid_ik.run.runner",
    "humanoid_ik.experiments.bench",
)
"""Modules the local pool's forkserver imports once, before it forks the workers: what
:func:`~humanoid_ik.experiments.sweep.jobs.run_job` needs."""
MAX_WORKERS = 256
"""Most local processes (or CPUs of a local Ray instance) a sweep may ask for; each
worker imports MuJoCo and holds a model (about 100 MB)."""
RAY_CONNECT_TIMEOUT_S = 10
"""How long Ray waits for a cluster's GCS to answer when joining it [s]."""
RAY_CONNECT_ENV = {
    "RAY_py_gcs_connect_timeout_s": str(RAY_CONNECT_TIMEOUT_S),
    "RAY_gcs_server_port_wait_time_s": "1",
}
"""Ray's settings for joining a cluster (an address other than ``local``): one attempt
of :data:`RAY_CONNECT_TIMEOUT_S` seconds (plus Ray's fixed 5 s connection checks)."""


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


@contextmanager
def _environment(values: Mapping[str, str]) -> Iterator[None]:
    """``values`` in ``os.environ`` for the block where the caller has not set them."""
    added = [k for k in values if k not in os.environ]
    os.environ.update({k: values[k] for k in added})
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)


@contextmanager
def _stderr_held() -> Iterator[list[str]]:
    """File descriptor 2 sent to a temporary file for the block (what Ray's C++ side
    prints while it connects); the text held is appended to the yielded list."""
    sys.stderr.flush()
    saved = os.dup(2)
    held: list[str] = []
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield held
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            held.append(tmp.read().decode(errors="replace"))


def import_ray(address: str | None = None):
    """The ``ray`` module, imported with :data:`RAY_CONNECT_ENV` when ``address`` names a
    cluster to join (not ``None`` or ``local``).

    Raises:
        SweepError: Ray is not installed (the message says how to install it).
    """
    env = RAY_CONNECT_ENV if address not in (None, "local") else {}
    try:
        with _environment(env):
            import ray
    except ImportError:
        raise SweepError(
            None, "", "Ray is not installed; install it with pip install 'humanoid-ik[ray]'"
        ) from None
    return ray


def _init_ray(ray: Any, workers: int | None, address: str) -> None:
    """Start a private Ray instance (``local``) or join the cluster at ``address``.

    Raises:
        SweepError: Ray cannot start or join it (after :data:`RAY_CONNECT_TIMEOUT_S`).
    """
    kwargs: dict[str, Any] = {
        "include_dashboard": False,
        "log_to_driver": False,
        "configure_logging": False,
    }
    if address == "local":
        ray.init(num_cpus=workers or os.cpu_count(), **kwargs)
        return
    try:
        with _environment(RAY_CONNECT_ENV), _stderr_held() as held:
            ray.init(address=address, **kwargs)
    except Exception as exc:  # noqa: BLE001 - Ray raises ValueError, ConnectionError, ...
        lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
        why = lines[0] if lines else type(exc).__name__
        raise SweepError(
            None,
            "",
            f"cannot connect to Ray at {address!r}: {why} (expected 'local', "
            "'auto' or the address of a running cluster, e.g. HOST:6379 or ray://HOST:10001)",
        ) from None
    sys.stderr.write("".join(held))


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
        SweepError: Ray is not installed, or cannot join the cluster at ``address``.
    """
    ray = import_ray(address)
    started = False
    if not ray.is_initialized():
        _init_ray(ray, workers, address)
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
