"""Shared fixtures. Rendering tests use Mesa's EGL off-screen unless a backend is set.

The suite runs on every CPU with pytest-xdist (``-n auto``, ``--dist loadfile``): all the
tests of one file run on one worker, so a fixture of a module (``scope="module"``) is
built once, and files run side by side; so no test may rely on a fixed port, folder or
file outside its ``tmp_path`` that a test of another file could use at the same time."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from humanoid_ik import Chain  # noqa: E402


@pytest.fixture(scope="session", autouse=True)
def _model_cache(tmp_path_factory: pytest.TempPathFactory):
    """The converted meshes and compiled models of this run in a folder of its own, shared
    by the run's workers and the subprocesses they start (``HUMANOID_IK_CACHE``), never
    the user's cache; left as it was when the caller set one."""
    if "HUMANOID_IK_CACHE" in os.environ:
        yield
        return
    root = tmp_path_factory.getbasetemp()
    shared = root.parent if os.environ.get("PYTEST_XDIST_WORKER") else root
    os.environ["HUMANOID_IK_CACHE"] = str(shared / "humanoid_ik-cache")
    yield
    del os.environ["HUMANOID_IK_CACHE"]


@pytest.fixture()
def right_arm() -> Chain:
    """The bundled humanoid's right arm, palm site, at home."""
    return Chain()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
