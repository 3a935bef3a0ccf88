"""The public API: every name in __all__ imports, solve() leaves the caller's data alone."""

from __future__ import annotations

import importlib
import pkgutil

import mujoco
import numpy as np
import pytest

import humanoid_ik
from humanoid_ik import Chain, HumanoidIKError, solve


def test_every_public_name_imports():
    """Every name in __all__ of the package and of each module exists."""
    modules = [humanoid_ik] + [
        importlib.import_module(f"humanoid_ik.{m.name}")
        for m in pkgutil.walk_packages(humanoid_ik.__path__)
        if m.name != "__main__"
    ]
    for mod in modules:
        for name in getattr(mod, "__all__", []):
            assert hasattr(mod, name), f"{mod.__name__}.{name}"


def test_every_error_derives_from_the_root():
    """All package exceptions share HumanoidIKError as root."""
    from humanoid_ik import errors

    for name in dir(errors):
        obj = getattr(errors, name)
        if (
            isinstance(obj, type)
            and issubclass(obj, Exception)
            and obj.__module__ == errors.__name__
        ):
            assert issubclass(obj, HumanoidIKError)


def test_solve_leaves_caller_data_unchanged():
    """solve(data=...) reads the caller's MjData and does not write it unless asked."""
    chain = Chain()
    d = mujoco.MjData(chain.model)
    mujoco.mj_resetDataKeyframe(chain.model, d, chain.model.key("home").id)
    d.qpos[0] = 0.3  # neck yaw: not in the chain
    mujoco.mj_forward(chain.model, d)
    before = d.qpos.copy()
    res = solve(chain, [0.3, -0.3, 1.1], data=d)
    assert res.converged
    np.testing.assert_array_equal(d.qpos, before)
    assert chain.data.qpos[0] == 0.3  # the scratch copy kept the caller's other joints


def test_solve_apply_writes_the_result():
    """apply=True writes the converged pose into the caller's data and runs forward."""
    chain = Chain()
    d = mujoco.MjData(chain.model)
    res = solve(chain, [0.3, -0.3, 1.1], "two_link", data=d, apply=True)
    np.testing.assert_allclose(d.qpos[chain.qpos_adr], res.q)
    np.testing.assert_allclose(d.site("right_palm_site").xpos, [0.3, -0.3, 1.1], atol=1e-9)


def test_failed_solve_leaves_caller_data_unchanged():
    """A bad target or an unconverged solve with apply=True leaves the data as it was."""
    chain = Chain()
    d = mujoco.MjData(chain.model)
    d.qpos[:] = 0.05
    before = d.qpos.copy()
    with pytest.raises(HumanoidIKError):
        solve(chain, [np.nan, 0, 0], data=d, apply=True)
    res = solve(chain, [3.0, 0.0, 1.4], "two_link", data=d, apply=True)
    assert res.status == "unreachable"
    np.testing.assert_array_equal(d.qpos, before)
