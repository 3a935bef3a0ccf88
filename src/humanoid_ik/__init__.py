"""humanoid_ik: inverse kinematics for humanoid arms on MuJoCo."""

from importlib.metadata import version

from humanoid_ik.config.scene import Scene, load_scene
from humanoid_ik.core.chain import DEFAULT_SITE, Chain
from humanoid_ik.core.models import bundled_model_path, load_model
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
from humanoid_ik.outputs.render import render_scene
from humanoid_ik.run.runner import SceneRunner, run_scene
from humanoid_ik.solvers import SOLVERS, make_solver, solve

__version__ = version("humanoid-ik")

__all__ = [
    "Chain",
    "ChainError",
    "DEFAULT_SITE",
    "HumanoidIKError",
    "IKResult",
    "ModelError",
    "NameNotFoundError",
    "RenderError",
    "SOLVERS",
    "Scene",
    "SceneError",
    "SceneRunner",
    "SolverError",
    "Status",
    "Target",
    "TargetError",
    "TrajectoryError",
    "UnsupportedJointError",
    "bundled_model_path",
    "load_model",
    "load_scene",
    "look_at",
    "make_solver",
    "render_scene",
    "run_scene",
    "solve",
]
