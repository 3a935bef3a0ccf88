"""The progress bar of every long command: tqdm on stderr, only when stderr is a terminal."""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["progress_bar"]


def progress_bar(total: int, unit: str, desc: str = "") -> Any:
    """A ``tqdm`` bar on stderr, or ``None`` when stderr is not a terminal or ``total < 1``
    (scripts and pipes get no bar)."""
    if not sys.stderr.isatty() or total < 1:
        return None
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, dynamic_ncols=True)
