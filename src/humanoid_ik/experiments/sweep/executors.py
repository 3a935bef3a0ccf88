"""Where a sweep's jobs run: a local process pool (the default) or a Ray cluster.

A job is a sweep's :class:`~humanoid_ik.config.sweep_file.Job` run by
:func:`~humanoid_ik.experiments.sweep.jobs.run_job` unless the caller names another
``run`` (a picklable module-level function of one picklable job, returning its result)
with its ``failed(job, exc)`` (the result of a job whose worker died) and the modules
its workers should import once (``preload``): ``retarget FOLDER --workers N`` runs its
clips so, on the same pool with the same guarantees.

Both take the jobs to run and an ``on_done(job, result)`` callback that the calling
process runs as each result comes back (in completion order), so results are written by
one process and a Ray cluster needs no shared file system. A worker that dies gives a
``failed`` result (:func:`~humanoid_ik.experiments.sweep.jobs.failed_result`) instead of
stopping the others.

Both make the processes they start end with the calling process, however it ends, with
no tag in anyone's environment and no look at processes of others: the local pool's
workers watch a pipe that only the caller holds open (:func:`die_with`), and a local Ray
instance is driven by a process in a process group of its own that is killed as a whole
(:func:`_run_ray_local`).

Joining a Ray cluster gives up after about :data:`RAY_CONNECT_TIMEOUT_S` seconds (Ray's
own defaults wait minutes for an address where nothing answers): while Ray is imported
and while it connects, the environment variables of :data:`RAY_CONNECT_ENV` are set
where the caller has not set them, then restored (Ray reads some of them once, when it
is imported; a Ray imported before keeps its own timeouts).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from multiprocessing.connection import Connection
from typing import IO, Any

from humanoid_ik.errors import SweepError
from humanoid_ik.experiments.sweep.jobs import failed_result, run_job

__all__ = [
    "MAX_WORKERS",
    "PRELOAD",
    "RAY_CONNECT_ENV",
    "RAY_CONNECT_TIMEOUT_S",
    "RAY_SHUTDOWN_TIMEOUT_S",
    "OnDone",
    "die_with",
    "import_ray",
    "ray_dispatch",
    "run_local",
    "run_ray",
]

OnDone = Callable[[Any, dict[str, Any]], None]
"""``on_done(job, result)``, called in the calling process as each job finishes."""
Run = Callable[[Any], dict[str, Any]]
"""``run(job) -> result``: what a worker does with one job (picklable: module level)."""
Failed = Callable[[Any, BaseException], dict[str, Any]]
"""``failed(job, exc) -> result``: the result of a job whose worker died."""
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


def die_with(owner: Connection) -> None:
    """Make this process (a pool worker) end when the sweep that started it ends, however
    it ends, SIGKILL included. ``owner`` is the read end of a pipe whose only write end
    the sweep holds: the operating system closes it when the sweep ends, and a daemon
    thread waiting on it then stops the forkserver that forked this worker (while that
    is still this worker's parent) and exits, so nothing outlives the sweep or keeps
    the caller's stdout and stderr open. Portable: no ``/proc``, no ``prctl``."""
    forkserver = os.getppid()

    def watch() -> None:
        try:
            while True:
                owner.recv_bytes()  # nothing is ever sent: returns at EOF only
        except (EOFError, OSError):
            pass
        if os.getppid() == forkserver and forkserver != 1:
            try:
                os.kill(forkserver, signal.SIGKILL)
            except (OSError, AttributeError):  # gone already; no SIGKILL on Windows
                pass
        os._exit(1)

    threading.Thread(target=watch, name="die-with-sweep", daemon=True).start()


def run_local(
    jobs: Sequence[Any],
    workers: int,
    on_done: OnDone,
    log: str | os.PathLike | None = None,
    *,
    run: Run = run_job,
    failed: Failed = failed_result,
    preload: Sequence[str] = PRELOAD,
) -> None:
    """Run ``jobs`` on ``workers`` local processes (forkserver, see :data:`PRELOAD`).

    The workers end with this process whatever ends it (:func:`die_with`: the read end
    of a pipe goes to each worker, the write end stays here). Ctrl-C
    ends the workers, so no job runs on, and is raised again.

    Args:
        jobs, workers, on_done: what to run, on how many processes, and the callback.
        log: a file that receives what the forkserver and its workers print (a worker
            being forked while the sweep is interrupted prints a traceback there, not
            on the caller's terminal); ``None`` leaves them the caller's stderr. Only a
            forkserver started by this call is redirected.
        run, failed, preload: what a worker runs on a job, the result of a job whose
            worker died, the modules the forkserver imports (default: a sweep's).
    """
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(list(preload))
    if log is not None:
        with open(log, "ab") as f, _stderr_into(f.fileno()):
            from multiprocessing import forkserver, resource_tracker

            resource_tracker.ensure_running()
            forkserver.ensure_running()
    watched, alive = ctx.Pipe(duplex=False)  # alive: not inheritable, held here only
    try:
        with ProcessPoolExecutor(
            max_workers=workers, mp_context=ctx, initializer=die_with, initargs=(watched,)
        ) as pool:
            pending: dict[Future[dict[str, Any]], Any] = {}
            try:
                for job in jobs:
                    pending[pool.submit(run, job)] = job
                while pending:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        job = pending.pop(fut)
                        try:
                            result = fut.result()
                        except Exception as exc:  # noqa: BLE001 - a dead worker
                            result = failed(job, exc)
                        on_done(job, result)
            except BaseException:  # Ctrl-C, even while the jobs are being submitted
                # the workers end now, so the pool breaks and fails every pending job
                # itself (cancelling them here raced with that: Python 3.11's pool then
                # printed an InvalidStateError traceback); nothing more is recorded
                alive.close()
                raise
    finally:  # after the pool's shutdown: its workers have exited
        alive.close()
        watched.close()


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
def _stderr_into(fd: int) -> Iterator[None]:
    """File descriptor 2 sent to ``fd`` for the block (processes started in it keep it)."""
    sys.stderr.flush()
    saved = os.dup(2)
    os.dup2(fd, 2)
    try:
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)


@contextmanager
def _stderr_held() -> Iterator[list[str]]:
    """File descriptor 2 sent to a temporary file for the block (what Ray's C++ side
    prints while it connects); the text held is appended to the yielded list."""
    held: list[str] = []
    with tempfile.TemporaryFile() as tmp:
        try:
            with _stderr_into(tmp.fileno()):
                yield held
        finally:
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


RAY_SHUTDOWN_TIMEOUT_S = 60.0
"""How long the process of a local Ray instance may take to shut Ray down after the
last result before the sweep kills its process group [s]."""
_HEAD = os.path.join(os.path.dirname(__file__), "ray_head.py")


def _can_own_a_group() -> bool:
    """True where a process group can be started and killed as a whole (POSIX)."""
    return hasattr(os, "killpg") and hasattr(os, "setsid")


def _run_ray_local(
    jobs: Sequence[Any], workers: int | None, on_done: OnDone, how: tuple[Run, Failed]
) -> None:
    """Run ``jobs`` on a local Ray instance of ``workers`` CPUs (default all) that a
    process of its own drives (``ray_head.py``), in a new session and so a process
    group that this process owns; results come back through a pipe.

    When this process ends, however it ends (SIGKILL included: the operating system
    closes the pipe), that process kills its whole group: Ray's GCS, raylet and agents
    go at once, and Ray's workers (in groups of their own) end by themselves within
    seconds of their raylet (Ray's own fate-sharing). A terminal's Ctrl-C does not
    reach the instance (another session): the sweep handles it and the pipe closes.

    Raises:
        SweepError: Ray does not start (its one-line reason), or its process ended
            before the last result.
    """
    jobs = list(jobs)
    with tempfile.TemporaryFile() as said:  # what it prints (Ray's notes, a traceback)
        head = subprocess.Popen(
            [sys.executable, _HEAD],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=said,
            start_new_session=True,
        )
        _drive(head, jobs, workers, on_done, said, how)


def _drive(
    head: subprocess.Popen,
    jobs: list[Any],
    workers: int | None,
    on_done: OnDone,
    said: IO[bytes],
    how: tuple[Run, Failed],
) -> None:
    """Send ``jobs`` to the process ``head`` (``ray_head.py``), hand each result it
    sends back to ``on_done``, and end it (see :func:`_run_ray_local`)."""
    assert head.stdin is not None and head.stdout is not None
    try:
        try:
            sent: tuple[Any, ...] = (workers or os.cpu_count() or 1, jobs)
            if how != (run_job, failed_result):  # ray_head.py runs a sweep's by default
                sent = (*sent, *how)
            pickle.dump(sent, head.stdin)
            head.stdin.flush()
        except BrokenPipeError:
            pass  # it ended already: reading says so
        while True:
            try:
                message = pickle.load(head.stdout)
            except EOFError:
                said.seek(0)
                lines = [ln.strip() for ln in said.read().decode(errors="replace").splitlines()]
                why = next((ln for ln in reversed(lines) if ln), "no reason given")
                raise SweepError(
                    None, "", f"the local Ray instance ended before the sweep's last job: {why}"
                ) from None
            if message[0] == "result":
                on_done(jobs[message[1]], message[2])
            elif message[0] == "error":
                raise SweepError(None, "", f"cannot start a local Ray instance: {message[1]}")
            else:  # ("end",)
                break
    finally:
        try:
            head.stdin.close()  # the process reads EOF: it shuts Ray down and ends
        except OSError:
            pass
        try:
            head.wait(RAY_SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)  # not reaped yet: the group is still ours
            head.wait()
        head.stdout.close()


def run_ray(
    jobs: Sequence[Any],
    workers: int | None,
    address: str,
    on_done: OnDone,
    *,
    run: Run = run_job,
    failed: Failed = failed_result,
) -> None:
    """Run ``jobs`` as Ray tasks (1 CPU each, no retries).

    Args:
        jobs: the jobs.
        workers: CPUs of a local Ray instance (default ``os.cpu_count()``).
        address: ``"local"`` starts a private instance, anything else is passed to
            ``ray.init(address=...)``. A Ray already initialised in this process is used
            as it is (and left running); one started here is shut down at the end, and
            its processes die with this one if it is killed (:func:`_run_ray_local`; where
            process groups are missing, Windows, Ray is started in this process and
            Ray's own fate-sharing applies).
        on_done: called as each result comes back.
        run, failed: as :func:`run_local`'s.

    Raises:
        SweepError: Ray is not installed, cannot start, or cannot join the cluster at
            ``address``.
    """
    ray = import_ray(address)
    if address == "local" and not ray.is_initialized() and _can_own_a_group():
        _run_ray_local(jobs, workers, on_done, (run, failed))
    else:
        _run_ray(ray, jobs, workers, address, on_done, (run, failed))


def ray_dispatch(
    ray: Any,
    jobs: Sequence[Any],
    on_done: Callable[[int, Any], None],
    run: Run = run_job,
    failed: Failed = failed_result,
) -> None:
    """Every job as a Ray task (one CPU, no retries) of ``run``, ``on_done(index,
    result)`` as each ends; a task that fails (a dead worker or node) gets ``failed``'s
    result. Used in the sweep's process and in a local Ray's own (``ray_head.py``)."""
    task = ray.remote(num_cpus=1, max_retries=0)(run)
    pending = {task.remote(job): i for i, job in enumerate(jobs)}
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            i = pending.pop(ref)
            try:
                result = ray.get(ref)
            except Exception as exc:  # noqa: BLE001 - a dead worker or node
                result = failed(jobs[i], exc)
            on_done(i, result)


def _run_ray(
    ray: Any,
    jobs: Sequence[Any],
    workers: int | None,
    address: str,
    on_done: OnDone,
    how: tuple[Run, Failed],
) -> None:
    started = False
    if not ray.is_initialized():
        _init_ray(ray, workers, address)
        started = True
    try:
        ray_dispatch(ray, jobs, lambda i, result: on_done(jobs[i], result), *how)
    finally:
        if started:
            ray.shutdown()
