"""Exceptions of humanoid_ik: one root class, narrow subclasses.

Every message names the bad value and, where there is a finite set, the valid choices.
"""

from __future__ import annotations

from collections.abc import Iterable


class HumanoidIKError(Exception):
    """Root of every error raised by humanoid_ik."""


class ModelError(HumanoidIKError):
    """A model path that does not exist or XML that MuJoCo cannot compile."""


class NameNotFoundError(HumanoidIKError, KeyError):
    """A site, body or joint name that is not in the model."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]):
        self.kind = kind
        self.name = name
        self.valid = sorted(valid)
        shown = ", ".join(self.valid) if self.valid else "(none)"
        super().__init__(f"{kind} '{name}' not in model; {kind}s: {shown}")

    def __str__(self) -> str:  # KeyError would quote the message.
        return str(self.args[0])


class UnsupportedJointError(HumanoidIKError):
    """A joint type the chain cannot drive (ball, slide, free) on the chain's path."""


class ChainError(HumanoidIKError):
    """A chain that cannot be built: no joints, joints not on the end effector's path."""


class TargetError(HumanoidIKError, ValueError):
    """A target with NaN/inf, a wrong shape, or a zero quaternion."""


class SolverError(HumanoidIKError, ValueError):
    """An unknown solver name, a bad solver option, or a solver that does not fit the chain."""


def choices(valid: Iterable[str]) -> str:
    """Comma-separated list of valid choices for an error message."""
    return ", ".join(sorted(valid))
