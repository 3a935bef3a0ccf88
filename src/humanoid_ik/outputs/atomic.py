"""Atomic file writing: every output is written under a temporary name beside its final
name and renamed into place only when complete, so a final name never holds half a file."""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

__all__ = ["atomic_path", "write_json", "write_text"]


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
    ext = final.suffix if suffix is None else suffix
    tmp = final.with_name(f".{final.stem}.{os.getpid()}.{threading.get_ident()}.tmp{ext}")
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json(path: str | os.PathLike, doc: Any, indent: int = 1) -> Path:
    """Write ``doc`` as JSON (and a final newline) to ``path`` atomically; returns the path."""
    return write_text(path, json.dumps(doc, indent=indent) + "\n")
