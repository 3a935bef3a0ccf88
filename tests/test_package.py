"""The public API: every name in __all__ imports, solve() leaves the caller's data alone."""

from __future__ import annotations

import importlib
import os
import pkgutil
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

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


# ----------------------------------------------------------------------------- packaging
REPO = Path(__file__).resolve().parents[1]


def test_bundled_folders_of_a_checkout():
    """In the checkout (an editable install) the bundled folders are the repository's own;
    reports name the model the same way as an installed wheel does."""
    from humanoid_ik.core.models import BUNDLED_KINDS, bundled_dir, display_model

    for kind in BUNDLED_KINDS:
        assert bundled_dir(kind).resolve() == (REPO / kind).resolve()
    assert display_model(None) == "models/humanoid/scene.xml"
    with pytest.raises(humanoid_ik.ModelError, match="folders: models, scenes, sweeps, motions"):
        bundled_dir("renders")


def _clean_copy(dest: Path) -> Path:
    """The files a build reads, copied without the checkout's build leftovers."""
    keep = ["pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "src", *BUNDLED]
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "*.pyc", "*.so")
    dest.mkdir(parents=True)
    for name in keep:
        src = REPO / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=ignore)
        else:
            shutil.copy2(src, dest / name)
    return dest


BUNDLED = ("models", "scenes", "sweeps", "motions")


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The sdist and the wheel that ``python -m build`` makes from a clean copy of the
    project (the wheel from the sdist, as .ci/wheel-smoke builds them): built once for
    the tests that read them."""
    pytest.importorskip("build", reason="python -m build: the dev extra installs it")
    tmp = tmp_path_factory.mktemp("built")
    src = _clean_copy(tmp / "src")
    dist = tmp / "dist"
    subprocess.run(
        [sys.executable, "-m", "build", "-o", str(dist), str(src)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    (sdist,) = dist.glob("humanoid_ik-*.tar.gz")
    (wheel,) = dist.glob("humanoid_ik-*.whl")
    return sdist, wheel


@pytest.mark.slow
def test_wheel_carries_and_finds_its_bundled_files(tmp_path, built):
    """The wheel holds models/, scenes/, sweeps/, motions/ under humanoid_ik/_bundled/; unpacked
    outside the checkout, the package reads them through importlib.resources: scenes
    lists the bundled scenes and solve uses the humanoid."""
    _sdist, wheel = built
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        z.extractall(tmp_path / "site")
    for f in (
        "models/humanoid/scene.xml",
        "models/humanoid/humanoid.xml",
        "scenes/circle.toml",
        "sweeps/compare_solvers.toml",
        "motions/reach_cmu.bvh",
    ):
        assert f"humanoid_ik/_bundled/{f}" in names
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "site")}
    for key in (
        "HUMANOID_IK_MODELS",
        "HUMANOID_IK_SCENES",
        "HUMANOID_IK_SWEEPS",
        "HUMANOID_IK_MOTIONS",
    ):
        env.pop(key, None)

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [sys.executable, *args],
            cwd=elsewhere,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )

    probe = run(
        "-c",
        "import humanoid_ik; from humanoid_ik.core.models import bundled_dir, display_model;"
        "print(humanoid_ik.__file__); print(bundled_dir('scenes')); print(display_model(None))",
    )
    pkg, scenes, shown = probe.stdout.split("\n")[:3]
    site = str((tmp_path / "site").resolve())
    assert pkg.startswith(site) and scenes == f"{site}/humanoid_ik/_bundled/scenes"
    assert shown == "models/humanoid/scene.xml"
    res = run("-m", "humanoid_ik", "scenes")
    assert res.returncode == 0 and res.stdout.splitlines()[1].startswith("circle ")
    res = run("-m", "humanoid_ik", "solve", "--target", "0.35,-0.30,1.15", "--solver", "dls")
    assert res.returncode == 0 and "converged" in res.stdout, res.stderr
    # lm's kernel is compiled into the wheel (a platform wheel) and loaded from there
    kernel = "humanoid_ik/solvers/jacobian/_lm_kernel"
    assert sorted(n for n in names if "_lm_" in n) == [
        f"{kernel}{sysconfig.get_config_var('EXT_SUFFIX')}",
        f"{kernel}.pyi",
    ]
    assert not wheel.name.endswith("-none-any.whl"), wheel.name
    res = run(
        "-c", "from humanoid_ik.solvers.jacobian import _lm_kernel; print(_lm_kernel.__file__)"
    )
    assert res.stdout.startswith(f"{site}/{kernel}"), res.stdout + res.stderr
    res = run("-m", "humanoid_ik", "solve", "--target", "0.35,-0.30,1.15", "--solver", "lm")
    assert res.returncode == 0 and "converged" in res.stdout, res.stderr


NO_COMPILER = (
    "humanoid_ik: building the lm kernel needs a C compiler and Python's headers "
    "(on Debian/Ubuntu: apt-get install gcc libc6-dev python3-dev; see docs/lm.md)"
)
"""The line setup.py stops with when the compiler does not work."""


@pytest.mark.slow
def test_without_a_c_compiler_the_build_fails_with_one_line(tmp_path):
    """lm's kernel is required: with a compiler that fails (CC=/bin/false) the wheel
    build fails, and the output has the one line saying what to install (no traceback
    in it), and no wheel is made."""
    src = _clean_copy(tmp_path / "src")
    dist = tmp_path / "dist"
    env = {**os.environ, "CC": "/bin/false", "LDSHARED": "/bin/false -shared"}
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist), str(src)],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out
    (line,) = [x.strip() for x in out.splitlines() if NO_COMPILER in x]
    assert line.startswith(NO_COMPILER) and "Traceback" not in line, line
    assert not list(dist.glob("*.whl"))


@pytest.mark.slow
def test_sdist_carries_the_bundled_folders_and_builds_the_wheel(built):
    """The sdist has the top-level folders (MANIFEST.in) and the wheel built from it maps
    them into the package (what .ci/wheel-smoke installs)."""
    sdist, wheel = built
    with tarfile.open(sdist) as t:
        names = {n.split("/", 1)[1] for n in t.getnames() if "/" in n}
    assert {"models/humanoid/scene.xml", "scenes/circle.toml", "setup.py"} <= names
    assert "src/humanoid_ik/solvers/jacobian/_lm_kernel.c" in names
    assert "src/humanoid_ik/solvers/jacobian/_lm_kernel.pyi" in names
    with zipfile.ZipFile(wheel) as z:
        assert "humanoid_ik/_bundled/scenes/circle.toml" in z.namelist()
