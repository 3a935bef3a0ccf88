"""humanoid_ik: inverse kinematics for humanoid arms on MuJoCo.

The front door is the IK library: the robot state and its chains, targets and results,
``solve``, the solvers and their options, and the errors. The application built on it
(scene files, the runner, rendering, sweeps, datasets, trajectory files, the command
line) lives in its own modules (``humanoid_ik.config``, ``run``, ``outputs``,
``experiments``, ``cli``), which ``import humanoid_ik`` does not load.

The public names below are imported on first use (``humanoid_ik.Chain`` loads the chain
and MuJoCo then), so ``import humanoid_ik`` and the command line start at once and
Ctrl-C during start-up is the command line's to handle. ``_EXPORTS`` is the list;
the ``TYPE_CHECKING`` imports repeat it for type checkers (a test keeps them equal).

Deprecated: the application names the front door used to export (``load_scene``,
``SceneRunner``, ``render_scene``, ...; :data:`_DEPRECATED`) still resolve for one
release, each with a ``DeprecationWarning`` that names its module, and so does
``TrajectoryError``, now ``MotionError`` (:data:`_RENAMED`; CHANGELOG.md).
"""

from __future__ import annotations

import importlib
import warnings
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "Chain": "humanoid_ik.core.chain",
    "DEFAULT_SITE": "humanoid_ik.core.chain",
    "bundled_model_path": "humanoid_ik.core.models",
    "load_model": "humanoid_ik.core.models",
    "Robot": "humanoid_ik.core.robot",
    "look_at": "humanoid_ik.core.rotations",
    "BatchResults": "humanoid_ik.core.types",
    "IKResult": "humanoid_ik.core.types",
    "Status": "humanoid_ik.core.types",
    "Target": "humanoid_ik.core.types",
    "ChainError": "humanoid_ik.errors",
    "HumanoidIKError": "humanoid_ik.errors",
    "ModelError": "humanoid_ik.errors",
    "MotionError": "humanoid_ik.errors",
    "NameNotFoundError": "humanoid_ik.errors",
    "RenderError": "humanoid_ik.errors",
    "SceneError": "humanoid_ik.errors",
    "SolverError": "humanoid_ik.errors",
    "TargetError": "humanoid_ik.errors",
    "UnsupportedJointError": "humanoid_ik.errors",
    "SOLVERS": "humanoid_ik.solvers",
    "Solver": "humanoid_ik.solvers",
    "make_solver": "humanoid_ik.solvers",
    "solve": "humanoid_ik.solvers",
    "solve_batch": "humanoid_ik.solvers",
    "ClosedForm": "humanoid_ik.solvers.analytic.closed_form",
    "ClosedFormOptions": "humanoid_ik.solvers.analytic.closed_form",
    "TwoLink": "humanoid_ik.solvers.analytic.two_link",
    "TwoLinkOptions": "humanoid_ik.solvers.analytic.two_link",
    "Auto": "humanoid_ik.solvers.auto",
    "CCD": "humanoid_ik.solvers.ccd",
    "CCDOptions": "humanoid_ik.solvers.ccd",
    "DLS": "humanoid_ik.solvers.jacobian.dls",
    "DLSOptions": "humanoid_ik.solvers.jacobian.dls",
    "LM": "humanoid_ik.solvers.jacobian.lm",
    "LMOptions": "humanoid_ik.solvers.jacobian.lm",
    "JacobianOptions": "humanoid_ik.solvers.jacobian.loop",
    "PseudoInverse": "humanoid_ik.solvers.jacobian.pseudoinverse",
    "PseudoInverseOptions": "humanoid_ik.solvers.jacobian.pseudoinverse",
    "JacobianTranspose": "humanoid_ik.solvers.jacobian.transpose",
    "TransposeOptions": "humanoid_ik.solvers.jacobian.transpose",
    "LookAt": "humanoid_ik.solvers.look_at",
    "LookAtOptions": "humanoid_ik.solvers.look_at",
    "MinkOptions": "humanoid_ik.solvers.mink",
    "MinkSolver": "humanoid_ik.solvers.mink",
    "SolverOptions": "humanoid_ik.solvers.options",
}
"""Public name -> the module that defines it."""

_DEPRECATED = {
    "Scene": "humanoid_ik.config.scene",
    "load_scene": "humanoid_ik.config.scene",
    "staged_model": "humanoid_ik.outputs.stage",
    "Inspection": "humanoid_ik.experiments.inspection",
    "inspect_model": "humanoid_ik.experiments.inspection",
    "render_scene": "humanoid_ik.outputs.render",
    "SceneRunner": "humanoid_ik.run.runner",
    "run_scene": "humanoid_ik.run.runner",
}
"""Application names the front door exported before: name -> the module to import it
from. They resolve for one release, each access with a ``DeprecationWarning``."""

_RENAMED = {"TrajectoryError": "MotionError"}
"""Library names renamed: old name -> new name (both in ``humanoid_ik.errors``). The
old ones resolve for one release, each access with a ``DeprecationWarning``."""

__all__ = sorted([*_EXPORTS, "__version__"])


def __getattr__(name: str) -> Any:
    if name in _DEPRECATED:
        module = _DEPRECATED[name]
        warnings.warn(
            f"humanoid_ik.{name} is deprecated and will be removed in the next release: "
            f"it is part of the application, not the IK library; use "
            f"'from {module} import {name}' ({module}.{name})",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(module), name)  # not kept: each use warns
    if name in _RENAMED:
        new = _RENAMED[name]
        warnings.warn(
            f"humanoid_ik.{name} is deprecated and will be removed in the next release: "
            f"it is now humanoid_ik.{new}",
            DeprecationWarning,
            stacklevel=2,
        )
        return __getattr__(new)
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
    from humanoid_ik.core.chain import DEFAULT_SITE, Chain
    from humanoid_ik.core.models import bundled_model_path, load_model
    from humanoid_ik.core.robot import Robot
    from humanoid_ik.core.rotations import look_at
    from humanoid_ik.core.types import BatchResults, IKResult, Status, Target
    from humanoid_ik.errors import (
        ChainError,
        HumanoidIKError,
        ModelError,
        MotionError,
        NameNotFoundError,
        RenderError,
        SceneError,
        SolverError,
        TargetError,
        UnsupportedJointError,
    )
    from humanoid_ik.solvers import SOLVERS, Solver, make_solver, solve, solve_batch
    from humanoid_ik.solvers.analytic.closed_form import ClosedForm, ClosedFormOptions
    from humanoid_ik.solvers.analytic.two_link import TwoLink, TwoLinkOptions
    from humanoid_ik.solvers.auto import Auto
    from humanoid_ik.solvers.ccd import CCD, CCDOptions
    from humanoid_ik.solvers.jacobian.dls import DLS, DLSOptions
    from humanoid_ik.solvers.jacobian.lm import LM, LMOptions
    from humanoid_ik.solvers.jacobian.loop import JacobianOptions
    from humanoid_ik.solvers.jacobian.pseudoinverse import PseudoInverse, PseudoInverseOptions
    from humanoid_ik.solvers.jacobian.transpose import JacobianTranspose, TransposeOptions
    from humanoid_ik.solvers.look_at import LookAt, LookAtOptions
    from humanoid_ik.solvers.mink import MinkOptions, MinkSolver
    from humanoid_ik.solvers.options import SolverOptions

    __version__: str
