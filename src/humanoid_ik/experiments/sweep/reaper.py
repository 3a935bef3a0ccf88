"""The reaper of a local Ray instance: run as a script (by its file path, so it imports
nothing of the package), it waits until its stdin closes, which happens when the sweep
that started it ends, however it ends, then kills every process whose environment
carries the sweep's tag (Ray's raylet, GCS, agents and workers inherit it), in passes
until a pass finds none. When the sweep ended without a word (killed), the passes go on
for at least :data:`MIN_WATCH_S` seconds: a process being started while a pass ran,
such as an agent the raylet launched late, is caught by a later one. A sweep that shut
Ray down itself writes ``done`` first, and one pass then suffices.

Usage: ``python reaper.py VARIABLE TAG``.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

MIN_WATCH_S = 10.0
"""How long the reaper keeps looking after the sweep ended [s]."""
MAX_WATCH_S = 60.0
"""When it gives up [s] (a process it cannot kill)."""
PAUSE_S = 0.2
"""The time between two passes [s]."""


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
    said = sys.stdin.buffer.read()  # returns at EOF: the sweep has ended
    watch = 0.0 if said.strip() == b"done" else MIN_WATCH_S
    start = time.monotonic()
    while time.monotonic() - start < MAX_WATCH_S:
        found = tagged(variable, tag)
        if not found and time.monotonic() - start >= watch:
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
