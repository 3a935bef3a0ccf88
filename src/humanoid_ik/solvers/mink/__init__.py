"""The ``mink`` solver: differential IK as a quadratic program through mink and daqp.

Laid out like mink itself:

- :mod:`~humanoid_ik.solvers.mink.solver`: :class:`MinkSolver` (``"mink"``) and its
  options :class:`MinkOptions`;
- :mod:`~humanoid_ik.solvers.mink.upper_body`: :class:`UpperBodyIK`, both hands and the
  gaze solved jointly, one QP per step; its result :class:`UpperBodyResult`
  (:mod:`~humanoid_ik.solvers.mink.result`);
- :mod:`~humanoid_ik.solvers.mink.problem`: the QP of one set of active effectors and
  one step of it;
- :mod:`~humanoid_ik.solvers.mink.tasks`: :class:`PositionTask`, :class:`GazeTask` (one
  file each, on :class:`BufferedTask`);
- :mod:`~humanoid_ik.solvers.mink.limits`: :class:`JointRangeLimit`,
  :class:`JointVelocityLimit`, :class:`CollisionLimit` (one file each);
- :mod:`~humanoid_ik.solvers.mink.adapter`: the only module that uses mink names
  outside mink's public API (see its docstring).

``import humanoid_ik`` does not import mink (about 0.2 s with qpsolvers and SciPy): the
names of this package that need it (the tasks and limits) are loaded on first access,
and :class:`UpperBodyIK` imports mink when the first one is built.
"""

from __future__ import annotations

import importlib
from typing import Any

from humanoid_ik.solvers.mink.result import UpperBodyResult
from humanoid_ik.solvers.mink.solver import MinkOptions, MinkSolver
from humanoid_ik.solvers.mink.upper_body import (
    DEFAULT_COLLISION_PAIRS,
    DEFAULT_GAZE,
    DEFAULT_HANDS,
    UpperBodyIK,
)

__all__ = [
    "DEFAULT_COLLISION_PAIRS",
    "DEFAULT_GAZE",
    "DEFAULT_HANDS",
    "BufferedTask",
    "CollisionLimit",
    "GazeTask",
    "JointRangeLimit",
    "JointVelocityLimit",
    "MinkOptions",
    "MinkSolver",
    "PositionTask",
    "UpperBodyIK",
    "UpperBodyResult",
]

_LAZY = {
    "BufferedTask": "humanoid_ik.solvers.mink.tasks",
    "GazeTask": "humanoid_ik.solvers.mink.tasks",
    "PositionTask": "humanoid_ik.solvers.mink.tasks",
    "CollisionLimit": "humanoid_ik.solvers.mink.limits",
    "JointRangeLimit": "humanoid_ik.solvers.mink.limits",
    "JointVelocityLimit": "humanoid_ik.solvers.mink.limits",
}
"""Names whose modules import mink, loaded on first access."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
