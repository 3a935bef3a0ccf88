"""The ``humanoid-ik`` command line: one module per command, :mod:`.app` ties them up.

:func:`main` imports the commands (and MuJoCo) only when called, so Ctrl-C during the
start-up ends with the usual one line and status 130, not an import traceback.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from humanoid_ik.cli.interrupts import interrupted

__all__ = ["main"]


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
