"""The ``mink`` solver: differential IK as a quadratic program through mink and daqp.

Laid out like mink itself:

- :mod:`~humanoid_ik.solvers.mink.solver`: :class:`MinkSolver` (``"mink"``);
- :mod:`~humanoid_ik.solvers.mink.options`: its options :class:`MinkOptions`, the one
  place the mink defaults and bounds are written;
- :mod:`~humanoid_ik.solvers.mink.upper_body`: :class:`UpperBodyIK`, hands and a gaze
  solved jointly, one QP per step, on any model (the caller names the effectors and the
  collision pairs); its result :class:`UpperBodyResult`
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

Deprecated: ``DEFAULT_HANDS``, ``DEFAULT_GAZE`` and ``DEFAULT_COLLISION_PAIRS`` (the
bundled humanoid's effector and geom names, once the defaults of :class:`UpperBodyIK`)
still resolve, with a ``DeprecationWarning`` (:mod:`~humanoid_ik.solvers.mink.deprecated`);
nothing in the package uses them. Pass the names instead (the bundled scenes name their
collision pairs in the scene file).
"""

from __future__ import annotations

import importlib
from typing import Any

from humanoid_ik.solvers.mink.options import MinkOptions
from humanoid_ik.solvers.mink.result import UpperBodyResult
from humanoid_ik.solvers.mink.solver import MinkSolver
from humanoid_ik.solvers.mink.upper_body import UpperBodyIK

__all__ = [
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
        from humanoid_ik.solvers.mink.deprecated import lookup

        return lookup(__name__, name)
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
