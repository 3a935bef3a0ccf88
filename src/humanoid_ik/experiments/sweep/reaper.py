"""The reaper of a local Ray instance: run as a script (by its file path, so it imports
nothing of the package), it waits until its stdin closes, which happens when the sweep
that started it ends, however it ends, then kills every process whose environment
carries the sweep's tag (Ray's raylet, GCS, agents and workers inherit it), again and
again until none is left (a process being started while the first pass ran is caught
by a later one).

Usage: ``python reaper.py VARIABLE TAG``.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

PASSES = 50
"""Most passes; a pass every :data:`PAUSE_S` seconds until one finds nothing."""
PAUSE_S = 0.2


def tagged(variable: str, tag: str) -> list[int]:
    """Processes other than this one whose environment has ``VARIABLE=TAG``."""
    needle = f"{variable}={tag}".encode()
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            if needle in (entry / "environ").read_bytes().split(b"\0"):
                found.append(int(entry.name))
        except OSError:
            continue
    return found


def main(argv: list[str]) -> int:
    variable, tag = argv
    sys.stdin.buffer.read()  # returns at EOF: the sweep has ended
    for _ in range(PASSES):
        found = tagged(variable, tag)
        if not found:
            return 0
        for pid in found:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        time.sleep(PAUSE_S)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
