"""Atomic file writing: every output is written under a temporary name beside its final
name and renamed into place only when complete, so a final name never holds half a file.

A temporary name carries the writer's process id (``.NAME.PID.TID.tmp.EXT``); a run
killed with SIGKILL cannot remove its temporaries, so every later write of the same
final name removes those whose process is gone (:func:`remove_stale`).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = ["atomic_dir", "atomic_path", "pid_alive", "remove_stale", "write_json", "write_text"]

_TEMP = re.compile(r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.(?P<tid>\d+)\.tmp(?:dir|\..*)?$")


def pid_alive(pid: int) -> bool:
    """True while process ``pid`` runs (a zombie waiting for its parent counts as dead)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def _temporary(final: Path, ext: str) -> Path:
    return final.with_name(f".{final.stem}.{os.getpid()}.{threading.get_ident()}.tmp{ext}")


def remove_stale(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries of ``path`` (files or folders) left by processes that no
    longer run; returns what was removed. Temporaries of live writers are kept."""
    final = Path(path)
    removed = []
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


@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """A temporary path beside ``path``; renamed onto ``path`` when the block succeeds,
    removed when it fails, so ``path`` is never half written.

    Args:
        path: the final file.
        suffix: the temporary file's extension (default: that of ``path``; some
            writers choose the format from it).
    """
    final = Path(path)
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
    tmp.mkdir()
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json(path: str | os.PathLike, doc: Any, indent: int = 1) -> Path:
    """Write ``doc`` as JSON (and a final newline) to ``path`` atomically; returns the path."""
    return write_text(path, json.dumps(doc, indent=indent) + "\n")
