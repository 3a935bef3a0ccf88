"""Whether an exception is a Ctrl-C (or SIGTERM) in disguise: one rule for the start-up
(:func:`humanoid_ik.cli.main`) and the commands (:mod:`humanoid_ik.cli.app`)."""

from __future__ import annotations

__all__ = ["interrupted"]


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
