"""Shared fixtures. Rendering tests use Mesa's EGL off-screen unless a backend is set."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from humanoid_ik import Chain  # noqa: E402


@pytest.fixture()
def right_arm() -> Chain:
    """The bundled humanoid's right arm, palm site, at home."""
    return Chain()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
