"""Deprecated (one release): this module is now :mod:`humanoid_ik.outputs.run_files`,
and its ``record_scene`` is :func:`~humanoid_ik.outputs.run_files.write_run`. Each name
imported from here warns (``DeprecationWarning``) and gives the new module's object."""

from __future__ import annotations

import warnings
from typing import Any

_RENAMED = {"record_scene": "write_run"}
"""Old name -> new name in :mod:`humanoid_ik.outputs.run_files`; every other name of
that module's ``__all__`` kept its name (and resolves here too, with the warning)."""


def __getattr__(name: str) -> Any:
    from humanoid_ik.outputs import run_files

    new = _RENAMED.get(name, name)
    if new not in run_files.__all__ or name in _RENAMED.values():  # old names only
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"humanoid_ik.outputs.record.{name} is deprecated; use humanoid_ik.outputs.run_files.{new}",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(run_files, new)
