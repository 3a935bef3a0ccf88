"""Real subprocesses of the command line for the signal, output-set and disk-full tests:
start one (tagged in its environment, so every process it starts can be found), signal
it at a chosen moment of its run, run one under a file-size limit, find what is still
alive, list temporaries."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

TAG = "HUMANOID_IK_TEST_TAG"
STATUS = {signal.SIGINT: 130, signal.SIGTERM: 143}
MESSAGE = {signal.SIGINT: "humanoid-ik: interrupted", signal.SIGTERM: "humanoid-ik: terminated"}


def _env(tag: str) -> dict[str, str]:
    return {**os.environ, TAG: tag, "MUJOCO_GL": "egl"}


def start(args: list[str], tag: str = "") -> subprocess.Popen:
    """``python -m humanoid_ik ARGS`` with pipes, its environment carrying ``tag``."""
    return subprocess.Popen(
        [sys.executable, "-m", "humanoid_ik", *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=_env(tag),
    )


def signal_when(
    proc: subprocess.Popen,
    sig: int,
    ready: Callable[[], bool] | float,
    after: float = 0.0,
    within: float = 120.0,
    poll: float = 0.002,
) -> bool:
    """Send ``sig`` to ``proc`` at a moment of its run: ``after`` seconds after ``ready()``
    holds (checked every ``poll`` seconds: a file the run writes at that moment exists),
    or ``ready`` seconds after now when it is a number. Returns whether ``proc`` was
    still running then (False: it ended first, the signal was not sent).

    Raises:
        AssertionError: ``ready()`` did not hold within ``within`` seconds.
    """
    if not callable(ready):
        time.sleep(ready)
    else:
        deadline = time.monotonic() + within
        while not _holds(ready):
            if proc.poll() is not None:
                return False
            assert time.monotonic() < deadline, f"the moment never came within {within} s"
            time.sleep(poll)
        time.sleep(after)
    if proc.poll() is not None:
        return False
    proc.send_signal(sig)
    return True


def importing(proc: subprocess.Popen) -> bool:
    """Whether ``proc``'s interpreter is past its own start and into the command line's
    imports: numpy's compiled core is loaded (``/proc/PID/maps``), which only the
    commands import. A Ctrl-C before that meets the interpreter's start-up, not the
    program (on a busy machine, a fixed delay after the start may still be there)."""
    return b"_multiarray_umath" in Path(f"/proc/{proc.pid}/maps").read_bytes()


def handles(proc: subprocess.Popen, sig: int) -> bool:
    """Whether ``proc`` has installed a handler for ``sig`` yet (``SigCgt`` of
    ``/proc/PID/status``): the command line is up, still importing what it runs."""
    for line in Path(f"/proc/{proc.pid}/status").read_text().splitlines():
        if line.startswith("SigCgt:"):
            return bool(int(line.split()[1], 16) >> (sig - 1) & 1)
    return False


def _holds(ready: Callable[[], bool]) -> bool:
    try:
        return ready()
    except OSError:  # a file went away while being looked at
        return False


def run_cli(*args: str, limit: int | None = None) -> subprocess.CompletedProcess:
    """Run the command line to its end; with ``limit``, no file it (or ffmpeg, which
    inherits the limit) writes may grow past ``limit`` bytes: a write beyond it fails
    as on a full disk (``RLIMIT_FSIZE``, with ``SIGXFSZ`` ignored)."""
    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        f"limit = {limit!r}\n"
        "if limit: resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))\n"
        "from humanoid_ik.cli import main\n"
        f"sys.exit(main({list(args)!r}))\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=_env(""), timeout=300
    )


def tagged(tag: str) -> list[int]:
    """Processes alive whose environment carries ``tag`` (a run and all it started)."""
    needle = f"{TAG}={tag}".encode()
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if needle in (entry / "environ").read_bytes().split(b"\0"):
                state = (entry / "stat").read_bytes().rsplit(b")", 1)[1].split()[0]
                if state != b"Z":
                    pids.append(int(entry.name))
        except OSError:
            continue
    return pids


def none_left(tag: str, within: float = 10.0) -> list[int]:
    """Wait up to ``within`` seconds for every process with ``tag`` to end; returns those
    still alive then (and kills them, so that they do not disturb the next test)."""
    deadline = time.monotonic() + within
    while (alive := tagged(tag)) and time.monotonic() < deadline:
        time.sleep(0.1)
    for pid in alive:
        os.kill(pid, signal.SIGKILL)
    return alive


def ended(proc: subprocess.Popen, tag: str, within: float) -> tuple[bytes, bytes]:
    """``proc.communicate()`` (stdout, stderr) once the run has ended, at most ``within``
    seconds from now; a run still going then is killed, with every process of its
    non-empty ``tag``, so that a hang fails its test and leaves nothing behind.

    Raises:
        AssertionError: the run did not end within ``within`` seconds.
    """
    try:
        return proc.communicate(timeout=within)
    except subprocess.TimeoutExpired:
        left = none_left(tag, within=0.0) if tag else []
        proc.kill()
        proc.communicate()
        command = " ".join(map(str, list(proc.args)[3:]))
        raise AssertionError(
            f"{command!r} still ran {within} s later ({len(left)} process(es) killed)"
        ) from None


def temporaries(folder: Path) -> list[str]:
    """The temporaries (``.NAME.PID.TID.tmp...``) anywhere under ``folder``."""
    return sorted(p.name for p in folder.rglob(".*") if ".tmp" in p.name)


@contextmanager
def virtual_display() -> Iterator[str]:
    """A virtual X server of the caller's own, as ``":N"`` for ``DISPLAY``: ``Xvfb
    -displayfd`` takes the first free display under the X server's own lock and writes
    its number once it serves, so two test workers starting one at the same moment get
    two displays (``xvfb-run -a`` probes for a free number first and does not wait for
    the server it stops, so a test started at once after another could connect to a
    display going away). Stopped at the end and checked gone with every process that
    carries its tag."""
    import select
    import shutil
    import uuid

    exe = shutil.which("Xvfb")
    assert exe is not None, "Xvfb is not installed (Debian: apt-get install xvfb)"
    tag = uuid.uuid4().hex
    r, w = os.pipe()
    server = subprocess.Popen(
        [exe, "-displayfd", str(w), "-nolisten", "tcp", "-noreset", "-screen", "0", "800x600x24"],
        pass_fds=(w,),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, TAG: tag},
    )
    os.close(w)
    try:
        ready, _, _ = select.select([r], [], [], 30)
        number = os.read(r, 16).decode().strip() if ready else ""
        assert number.isdigit(), f"Xvfb gave no display within 30 s ({number!r})"
        yield f":{number}"
    finally:
        os.close(r)
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
    assert none_left(tag) == [], "Xvfb still runs"
