"""MuJoCo's own warnings as Python warnings.

Without a callback of its own, MuJoCo prints a warning (``XML contains a 'NaN'``, a
visual geom buffer full) and appends it to a ``MUJOCO_LOG.TXT`` in the current folder:
a file in the user's folder that nothing asked for. The package's MuJoCo calls that may
warn (compiling a model: ``core/models.py``) run inside :func:`mujoco_warnings`, which
turns each into a :class:`MuJoCoWarning` and puts the previous callback back after; the
command line runs every command inside it and prints each as one note line.
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

import mujoco

from humanoid_ik.core.robot_files import ModelWarning

__all__ = ["MuJoCoWarning", "mujoco_warnings"]


class MuJoCoWarning(ModelWarning):
    """A warning MuJoCo gave while the package compiled or used a model, its text after
    ``MuJoCo: ``. A :class:`ModelWarning`: the command line prints it as one
    ``humanoid-ik: note: MuJoCo: ...`` line."""


_lock = threading.Lock()
_depth = 0
_previous: object = None
_raised: list[BaseException] = []
"""What ``warnings.warn`` raised in the callback (``-W error``, a Ctrl-C there): an
exception must not pass through MuJoCo's C code (it aborts the process), so it is
raised when the outermost :func:`mujoco_warnings` ends."""


def _warn(message: str) -> None:
    """MuJoCo's warning callback: the message as a :class:`MuJoCoWarning`, attributed to
    the package's line that called MuJoCo (the frame below this callback)."""
    try:
        warnings.warn(f"MuJoCo: {' '.join(message.split())}", MuJoCoWarning, 2)
    except BaseException as exc:  # noqa: BLE001 (kept, raised after MuJoCo returns)
        _raised.append(exc)


@contextmanager
def mujoco_warnings() -> Iterator[None]:
    """MuJoCo's warnings are :class:`MuJoCoWarning` inside: no ``MUJOCO_LOG.TXT``, no
    print. Nested and threaded uses share one callback (the outermost puts the previous
    one back); an exception the warning raised is raised at the end.

    Raises:
        Warning: a :class:`MuJoCoWarning` that the warning filters turn into an error.
    """
    global _depth, _previous
    with _lock:
        if _depth == 0:
            _previous = mujoco.get_mju_user_warning()
            mujoco.set_mju_user_warning(_warn)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            pending = None
            if _depth == 0:
                mujoco.set_mju_user_warning(_previous)
                _previous = None
                pending = _raised[0] if _raised else None
                _raised.clear()
        if pending is not None:
            raise pending
