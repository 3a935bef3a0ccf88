"""humanoid_ik: inverse kinematics for humanoid arms on MuJoCo."""

from humanoid_ik.api import solve
from humanoid_ik.chain import DEFAULT_SITE, Chain, bundled_model_path, load_model
from humanoid_ik.errors import (
    ChainError,
    HumanoidIKError,
    ModelError,
    NameNotFoundError,
    SolverError,
    TargetError,
    UnsupportedJointError,
)
from humanoid_ik.rotations import look_at
from humanoid_ik.solvers import SOLVERS, make_solver
from humanoid_ik.types import IKResult, Target

__version__ = "0.1.0"

__all__ = [
    "Chain",
    "ChainError",
    "DEFAULT_SITE",
    "HumanoidIKError",
    "IKResult",
    "ModelError",
    "NameNotFoundError",
    "SOLVERS",
    "SolverError",
    "Target",
    "TargetError",
    "UnsupportedJointError",
    "bundled_model_path",
    "load_model",
    "look_at",
    "make_solver",
    "solve",
]
