"""The ``humanoid-ik`` command line: one module per command, :mod:`.app` ties them up.

:func:`main` imports the commands (and MuJoCo) only when called, so Ctrl-C during the
start-up ends with the usual one line and status 130, not an import traceback.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

__all__ = ["interrupted", "main"]


def interrupted(exc: BaseException | None) -> bool:
    """True when ``exc`` is, or was caused by, a Ctrl-C or SIGTERM. Compiled code hides
    some: MuJoCo's extension turns one during its import into ``ImportError`` (caused
    by it), and ctypes one during an argument's conversion (PyOpenGL's calls while
    MuJoCo loads EGL) into ``ctypes.ArgumentError: argument 1: KeyboardInterrupt``,
    which keeps only the name."""
    seen = 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return True
        if type(exc).__name__ == "ArgumentError" and type(exc).__module__ == "ctypes":
            return any(f": {name}:" in f" {exc}" for name in ("KeyboardInterrupt", "Terminated"))
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see :mod:`humanoid_ik.cli.app`)."""
    try:
        from humanoid_ik.cli.app import main as run
    except BaseException as exc:
        if not interrupted(exc):
            raise
        print("humanoid-ik: interrupted", file=sys.stderr)
        return 130
    return run(argv)
