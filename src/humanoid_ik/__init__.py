"""humanoid_ik: inverse kinematics for humanoid arms on MuJoCo.

The public names below are imported on first use (``humanoid_ik.Chain`` loads the chain
and MuJoCo then), so ``import humanoid_ik`` and the command line start at once and
Ctrl-C during start-up is the command line's to handle. ``_EXPORTS`` is the list;
the ``TYPE_CHECKING`` imports repeat it for type checkers (a test keeps them equal).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "Scene": "humanoid_ik.config.scene",
    "load_scene": "humanoid_ik.config.scene",
    "Chain": "humanoid_ik.core.chain",
    "DEFAULT_SITE": "humanoid_ik.core.chain",
    "bundled_model_path": "humanoid_ik.core.models",
    "load_model": "humanoid_ik.core.models",
    "staged_model": "humanoid_ik.core.models",
    "look_at": "humanoid_ik.core.rotations",
    "IKResult": "humanoid_ik.core.types",
    "Status": "humanoid_ik.core.types",
    "Target": "humanoid_ik.core.types",
    "ChainError": "humanoid_ik.errors",
    "HumanoidIKError": "humanoid_ik.errors",
    "ModelError": "humanoid_ik.errors",
    "NameNotFoundError": "humanoid_ik.errors",
    "RenderError": "humanoid_ik.errors",
    "SceneError": "humanoid_ik.errors",
    "SolverError": "humanoid_ik.errors",
    "TargetError": "humanoid_ik.errors",
    "TrajectoryError": "humanoid_ik.errors",
    "UnsupportedJointError": "humanoid_ik.errors",
    "Inspection": "humanoid_ik.experiments.inspection",
    "inspect_model": "humanoid_ik.experiments.inspection",
    "render_scene": "humanoid_ik.outputs.render",
    "SceneRunner": "humanoid_ik.run.runner",
    "run_scene": "humanoid_ik.run.runner",
    "SOLVERS": "humanoid_ik.solvers",
    "make_solver": "humanoid_ik.solvers",
    "solve": "humanoid_ik.solvers",
}
"""Public name -> the module that defines it."""

__all__ = sorted([*_EXPORTS, "__version__"])


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import version

        value: Any = version("humanoid-ik")
    elif name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
    else:
        raise AttributeError(f"module 'humanoid_ik' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})


if TYPE_CHECKING:
    from humanoid_ik.config.scene import Scene, load_scene
    from humanoid_ik.core.chain import DEFAULT_SITE, Chain
    from humanoid_ik.core.models import bundled_model_path, load_model, staged_model
    from humanoid_ik.core.rotations import look_at
    from humanoid_ik.core.types import IKResult, Status, Target
    from humanoid_ik.errors import (
        ChainError,
        HumanoidIKError,
        ModelError,
        NameNotFoundError,
        RenderError,
        SceneError,
        SolverError,
        TargetError,
        TrajectoryError,
        UnsupportedJointError,
    )
    from humanoid_ik.experiments.inspection import Inspection, inspect_model
    from humanoid_ik.outputs.render import render_scene
    from humanoid_ik.run.runner import SceneRunner, run_scene
    from humanoid_ik.solvers import SOLVERS, make_solver, solve

    __version__: str
