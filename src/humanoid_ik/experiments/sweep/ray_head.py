"""The driver of a sweep's local Ray instance (``--ray local``), in a process of its own.

:func:`~humanoid_ik.experiments.sweep.executors.run_ray` runs this file as a script, in
a new session, so a new process group, that the sweep owns. It reads the CPUs and the
jobs (one pickle) from its stdin, starts Ray (``ray.init``: Ray's GCS, raylet and agents
join this process's group), runs the jobs as Ray tasks and writes each job's result back (one
pickle each: ``("result", index, result)``, then ``("end",)``; ``("error", WHY)`` when
Ray does not start). When the sweep ends, however it ends, its end of the stdin pipe
closes: after ``("end",)`` Ray is shut down gracefully, otherwise (the sweep was killed
or interrupted) at once; either way this process then kills its whole process group,
itself included. Whatever Ray started in the group goes with it, and Ray's workers (in
groups of their own) end by themselves within seconds of their raylet.

No tag in anyone's environment, no look at other processes. POSIX only: where process
groups are missing the sweep starts Ray in its own process instead.

Usage: ``python ray_head.py`` (stdin and stdout as above).
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
import threading
from typing import IO, Any


def _private_streams() -> tuple[IO[bytes], IO[bytes]]:
    """This process's stdin and stdout, moved to descriptors that no child inherits; the
    processes Ray starts get ``/dev/null`` in their place, so the sweep's pipes close
    with this process and no Ray process reads or writes them."""
    stdin, stdout = os.dup(0), os.dup(1)  # os.dup: not inheritable
    null = os.open(os.devnull, os.O_RDWR)
    os.dup2(null, 0)
    os.dup2(null, 1)
    os.close(null)
    return os.fdopen(stdin, "rb"), os.fdopen(stdout, "wb")


def _end_group() -> None:
    os.killpg(os.getpgrp(), signal.SIGKILL)


def _one_line(exc: BaseException) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return lines[0] if lines else type(exc).__name__


def main() -> int:
    inp, out = _private_streams()
    ended = threading.Event()

    def send(*message: Any) -> None:
        pickle.dump(message, out)
        out.flush()

    def watch() -> None:
        inp.read()  # returns at EOF: the sweep has ended, or was stopped or killed
        if not ended.is_set():
            _end_group()

    try:
        cpus, jobs, *how = pickle.load(inp)  # how: another run and failed than a sweep's
        threading.Thread(target=watch, name="sweep-watch", daemon=True).start()
        import ray

        from humanoid_ik.experiments.sweep.executors import ray_dispatch

        try:
            ray.init(
                num_cpus=cpus, include_dashboard=False, log_to_driver=False, configure_logging=False
            )
        except Exception as exc:  # noqa: BLE001 - any failure to start, in one line
            send("error", _one_line(exc))
            return 1
        ray_dispatch(ray, jobs, lambda i, result: send("result", i, result), *how)
        ended.set()
        send("end")
        ray.shutdown()
        return 0
    finally:
        _end_group()


if __name__ == "__main__":
    if sys.path and os.path.abspath(sys.path[0]) == os.path.dirname(os.path.abspath(__file__)):
        del sys.path[0]  # not this folder's modules (jobs, summary, ...) as top-level ones
    sys.exit(main())
