"""The ``humanoid-ik`` command line: one module per command, :mod:`.app` ties them up.

:func:`main` imports the commands (and MuJoCo) only when called, so Ctrl-C during the
start-up ends with the usual one line and status 130, not an import traceback.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Sequence
from types import FrameType

from humanoid_ik.cli.interrupts import interrupted

__all__ = ["main"]


def _import_mujoco() -> None:
    """Import MuJoCo even when ``MUJOCO_GL`` holds a value it does not know: MuJoCo
    raises at import then, which would stop every command, ``solve`` too. It is then
    imported with rendering off and the user's value put back, so only the commands
    that render refuse it, in one line (``outputs/render/backend.py``)."""
    try:
        import mujoco  # noqa: F401
    except RuntimeError as exc:
        value = os.environ.get("MUJOCO_GL")
        if value is None or "MUJOCO_GL" not in str(exc):
            raise
        os.environ["MUJOCO_GL"] = "disable"
        try:
            import mujoco  # noqa: F401, F811
        finally:
            os.environ["MUJOCO_GL"] = value


class _StartUpSigint:
    """Python's Ctrl-C handler that also remembers it ran: an extension's import can turn
    the ``KeyboardInterrupt`` into its own error without chaining it (numpy's
    "Importing the numpy C-extensions failed"), so the start-up asks this instead."""

    def __init__(self) -> None:
        self.seen = False

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        self.seen = True
        signal.default_int_handler(signum, frame)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see :mod:`humanoid_ik.cli.app`)."""
    sigint = _StartUpSigint()
    previous = None
    in_main_thread = threading.current_thread() is threading.main_thread()
    if in_main_thread and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        previous = signal.signal(signal.SIGINT, sigint)
    try:
        _import_mujoco()
        from humanoid_ik.cli.app import main as run
    except BaseException as exc:
        if not (sigint.seen or interrupted(exc)):
            raise
        print("humanoid-ik: interrupted", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return run(argv)
