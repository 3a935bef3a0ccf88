"""Atomic file writing: every output is written under a temporary name beside its final
name and renamed into place only when complete, so a final name never holds half a file.

A temporary name carries the writer's process id (``.NAME.PID.TID.tmp.EXT``); a run
killed with SIGKILL cannot remove its temporaries, so every later write of the same
final name removes those whose process is gone (:func:`remove_stale`).

A run's outputs (``render``, ``run``, ``replay``) are one set: :func:`staged_outputs`
has the run write every file into a fresh staging folder inside the output folder, then
:func:`publish` replaces the previous run's files (listed in the folder's manifest,
:data:`MANIFEST`) with the new ones, with SIGINT and SIGTERM held back and a lock
against another run publishing into the same folder. A run that fails or is stopped
while writing leaves the previous set untouched; the folder never holds a mix of two
runs' files. Files the manifest does not list (the user's own) are never touched: a
run whose set would replace one is refused (:func:`publish`).

Portable: the folder's lock is ``fcntl.flock`` where ``fcntl`` exists (POSIX) and an
``O_EXCL`` lock file holding the writer's process id elsewhere (:func:`_folder_lock`);
``/proc`` is read only to tell a zombie from a live process, where it exists.
"""

from __future__ import annotations

import errno
import json
import math
import os
import re
import shutil
import signal
import sys
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = [
    "MANIFEST",
    "atomic_dir",
    "atomic_path",
    "check_not_theirs",
    "json_text",
    "output_file",
    "pid_alive",
    "publish",
    "published",
    "remove_stale",
    "signals_held",
    "staged_outputs",
    "write_json",
    "write_text",
]

MANIFEST = ".humanoid-ik-outputs.json"
"""The file in an output folder that lists the files of the last run published there."""
_LOCK = ".humanoid-ik-outputs.lock"
_STAGING = "run"  # the staging folder is ``.run.PID.TID.tmpdir`` inside the output folder

_TEMP = re.compile(r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.(?P<tid>\d+)\.tmp(?:dir|\..*)?$")


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` runs (a zombie waiting for its parent counts as dead
    where ``/proc`` tells; elsewhere as alive until reaped)."""
    if sys.platform == "win32":  # os.kill(pid, 0) would end the process there
        return _pid_alive_windows(pid)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):  # no /proc (macOS, BSD), or the process just ended
        return True


def _pid_alive_windows(pid: int) -> bool:
    if sys.platform != "win32":  # for type checkers: the body is Windows only
        raise OSError("Windows only")
    import ctypes

    kernel = ctypes.WinDLL("kernel32", use_last_error=True)
    handle = kernel.OpenProcess(0x00100000 | 0x1000, False, pid)  # SYNCHRONIZE | QUERY
    if not handle:
        return ctypes.get_last_error() == 5  # access denied: it exists
    try:
        return bool(kernel.WaitForSingleObject(handle, 0) == 0x102)  # WAIT_TIMEOUT: running
    finally:
        kernel.CloseHandle(handle)


def _temporary(final: Path, ext: str) -> Path:
    return final.with_name(f".{final.stem}.{os.getpid()}.{threading.get_ident()}.tmp{ext}")


def remove_stale(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries of ``path`` (files or folders) left by processes that no
    longer run; returns what was removed. Temporaries of live writers are kept."""
    final = Path(path)
    removed: list[Path] = []
    try:
        entries = list(final.parent.iterdir())
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP.match(entry.name)
        if m is None or m["stem"] != final.stem or pid_alive(int(m["pid"])):
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed


def output_file(path: str | os.PathLike) -> Path:
    """The file that writing ``path`` replaces: ``path`` itself, or the file a symbolic
    link there points to (written through, the link kept).

    Raises:
        OSError: ``path`` is a device, a FIFO or a socket (``--out /dev/null`` must not
            replace the system's device with a regular file).
    """
    final = Path(path)
    if final.is_symlink():
        final = final.resolve()
    if final.exists() and not final.is_file() and not final.is_dir():
        raise OSError(
            errno.EINVAL,
            "not a regular file (a device, FIFO or socket); give a file path",
            str(path),
        )
    return final


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` when the block succeeds,
    removed when it fails, so ``path`` is never half written (:func:`output_file`: a
    symbolic link is written through; a device, FIFO or socket is refused).

    Args:
        path: the final file.
        suffix: the temporary file's extension (default: that of ``path``; some
            writers choose the format from it).
    """
    final = output_file(path)
    remove_stale(final)
    tmp = _temporary(final, final.suffix if suffix is None else suffix)
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextmanager
def atomic_dir(path: str | os.PathLike) -> Iterator[Path]:
    """A fresh temporary folder beside ``path`` for the block's scratch files, removed
    when the block ends, however it ends (and by the next run if a SIGKILL stops it)."""
    final = Path(path)
    remove_stale(final)
    tmp = _temporary(final, "dir")
    try:  # made inside the try: a Ctrl-C just after mkdir still removes it
        tmp.mkdir()
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def json_text(doc: Any, indent: int | None = 1) -> str:
    """``doc`` as strict JSON: a NaN or an infinity (an unlimited joint's range margin,
    a model's NaN) becomes ``null``, as JSON has no such numbers (``json.dumps`` would
    write ``NaN``/``Infinity``, which strict parsers refuse)."""
    return json.dumps(_finite(doc), indent=indent, allow_nan=False)


def _finite(doc: Any) -> Any:
    if isinstance(doc, float):  # numpy's float64 too
        return doc if math.isfinite(doc) else None
    if isinstance(doc, dict):
        return {k: _finite(v) for k, v in doc.items()}
    if isinstance(doc, (list, tuple)):
        return [_finite(v) for v in doc]
    return doc


def write_json(path: str | os.PathLike, doc: Any, indent: int = 1) -> Path:
    """Write ``doc`` as strict JSON (:func:`json_text`) and a final newline to ``path``
    atomically; returns the path."""
    return write_text(path, json_text(doc, indent) + "\n")


def published(folder: str | os.PathLike) -> list[str]:
    """The names of the files the last run published in ``folder`` (its manifest)."""
    try:
        doc = json.loads((Path(folder) / MANIFEST).read_text())
        names = doc["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    if not isinstance(names, list):
        return []
    return [n for n in names if isinstance(n, str) and n == Path(n).name and n[:1] != "."]


@contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held back for the block and raised when it ends (publishing a
    set, opening the viewer's window); a no-op outside the main thread, where Python
    runs no signal handler anyway.

    Two layers, as a process has threads of its own (OpenBLAS's, a viewer's): the main
    thread blocks both signals (``pthread_sigmask`` where it exists, not on Windows), so
    no system call of the block is cut short and a thread started in it inherits the
    mask; and both Python handlers are replaced for the block by one that only notes the
    signal, because the kernel hands a signal the main thread blocks to another thread,
    whose C handler still has Python run the handler in the middle of the block. At its
    end the handlers and the mask are put back, then each signal noted is raised.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = (signal.SIGINT, signal.SIGTERM)
    noted: list[int] = []
    before = (
        signal.pthread_sigmask(signal.SIG_BLOCK, held)
        if hasattr(signal, "pthread_sigmask")
        else None
    )
    handlers: dict[signal.Signals, Any] = {}
    late: BaseException | None = None
    try:
        for sig in held:
            if signal.getsignal(sig) is not None:  # None: set outside Python, kept
                handlers[sig] = signal.getsignal(sig)
                signal.signal(sig, lambda signum, frame: noted.append(signum))
        yield
    finally:
        for sig, handler in handlers.items():
            while True:  # ``signal.signal`` first runs the handlers of signals just come
                try:
                    signal.signal(sig, handler)
                    break
                except BaseException as exc:  # a handler put back raised: keep it for last
                    late = late or exc
        if before is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, before)
        for signum in dict.fromkeys(noted):
            signal.raise_signal(signum)
        if late is not None:
            raise late


def check_not_theirs(folder: str | os.PathLike, names: Iterable[str]) -> None:
    """Refuse to write ``names`` into ``folder`` where one of them is there but no earlier
    run published it (the user's own file). :func:`publish` checks the whole set; a run
    checks the names it knows beforehand too, so that it fails before its work.

    Raises:
        FileExistsError: naming the first such file.
    """
    dst = Path(folder)
    ours = set(published(dst))
    for name in names:
        if name not in ours and os.path.lexists(dst / name):
            raise FileExistsError(
                errno.EEXIST,
                "not written over a file that no earlier run wrote here (remove it or "
                "choose another output folder)",
                str(dst / name),
            )


def publish(staging: str | os.PathLike, folder: str | os.PathLike) -> list[Path]:
    """Move every file of ``staging`` into ``folder``, in place of the files the previous
    run published there, and record them in the folder's :data:`MANIFEST`; returns the
    final paths. Runs with SIGINT and SIGTERM held back and with the folder's lock held,
    so neither a Ctrl-C nor a concurrent run can leave two runs' files mixed.

    Raises:
        FileExistsError: a file of the new set is in ``folder`` already but no earlier
            run published it (the user's own): nothing is replaced.
    """
    src, dst = Path(staging), Path(folder)
    names = sorted(p.name for p in src.iterdir() if p.is_file() and not p.name.startswith("."))
    with signals_held(), _folder_lock(dst / _LOCK):
        ours = set(published(dst))
        check_not_theirs(dst, names)
        for old in ours - set(names):
            (dst / old).unlink(missing_ok=True)
        for name in names:
            os.replace(src / name, dst / name)
        write_json(dst / MANIFEST, {"files": names})
    return [dst / n for n in names]


LOCK_POLL_S = 0.05
"""How often a run waiting for another's lock file tries again (no ``fcntl``) [s]."""


@contextmanager
def _folder_lock(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` for the block, against other processes and threads.

    ``fcntl.flock`` where ``fcntl`` exists: the system drops it when its holder ends,
    however it ends. Elsewhere a lock file ``PATH.held`` created with ``O_EXCL`` and
    holding the writer's process id: it is removed when the block ends, and a waiter
    removes one whose process no longer runs (a writer killed while publishing).
    """
    try:
        import fcntl
    except ImportError:
        fcntl = None  # type: ignore[assignment]
    if fcntl is not None:
        with open(path, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            yield
        return
    held = path.with_name(path.name + ".held")
    mine = f"{os.getpid()}\n".encode()
    while True:
        try:
            fd = os.open(held, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            _remove_dead_lock(held)
            time.sleep(LOCK_POLL_S)
            continue
        try:
            os.write(fd, mine)
        finally:
            os.close(fd)
        break
    try:
        yield
    finally:
        held.unlink(missing_ok=True)


def _remove_dead_lock(held: Path) -> None:
    """Remove lock file ``held`` if the process it names no longer runs: it is moved
    aside under a name of this thread's own first, and put back if what was moved is
    not the dead one's (another waiter took the lock in between)."""
    try:
        owner = int(held.read_text() or "0")
    except (OSError, ValueError):
        return  # gone, or being written: try again later
    if owner <= 0 or pid_alive(owner):
        return
    aside = held.with_name(f"{held.name}.{os.getpid()}.{threading.get_ident()}")
    try:
        os.replace(held, aside)
    except OSError:
        return
    try:
        moved = int(aside.read_text() or "0")
    except (OSError, ValueError):
        moved = owner
    if moved == owner:
        aside.unlink(missing_ok=True)
    else:
        try:
            os.link(aside, held)  # back to its holder, unless a third run took it meanwhile
        except OSError:
            pass
        aside.unlink(missing_ok=True)


@contextmanager
def staged_outputs(folder: str | os.PathLike) -> Iterator[Path]:
    """A fresh staging folder for one run's files inside the output ``folder`` (which
    must exist); when the block succeeds its files are published (:func:`publish`),
    and whatever happens the staging folder is removed (a SIGKILLed run's one by the
    next run in the same folder)."""
    with atomic_dir(Path(folder) / _STAGING) as staging:
        yield staging
        publish(staging, folder)
