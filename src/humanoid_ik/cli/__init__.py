"""The ``humanoid-ik`` command line: one module per command, :mod:`.app` ties them up.

:func:`main` imports the commands (and MuJoCo) only when called, so Ctrl-C during the
start-up ends with the usual one line and status 130, not an import traceback.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

__all__ = ["main"]


def _interrupted(exc: BaseException | None) -> bool:
    """True when ``exc`` is, or was caused by, a Ctrl-C (a compiled module, MuJoCo's
    among them, turns one during its import into ``ImportError``)."""
    seen = 0
    while exc is not None and seen < 20:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (see :mod:`humanoid_ik.cli.app`)."""
    try:
        from humanoid_ik.cli.app import main as run
    except BaseException as exc:
        if not _interrupted(exc):
            raise
        print("humanoid-ik: interrupted", file=sys.stderr)
        return 130
    return run(argv)
