"""The IK library apart from the application, and portable (issue 19, item 6):
``import humanoid_ik``, ``solve`` and ``humanoid-ik --help`` work where ``fcntl``,
``prctl`` and ``/proc`` are missing, ``import humanoid_ik`` loads none of the
application layer, and the application names the front door used to export still
resolve, with a ``DeprecationWarning`` naming their new module."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
import warnings
from pathlib import Path

import pytest

import humanoid_ik
from humanoid_ik.outputs import atomic

TARGET = [0.35, -0.30, 1.15]
APPLICATION = (
    "humanoid_ik.run",
    "humanoid_ik.outputs",
    "humanoid_ik.experiments",
    "humanoid_ik.config",
    "humanoid_ik.cli",
)
"""The application layer's packages, which ``import humanoid_ik`` must not load."""

NOT_POSIX = '''\
"""Installed by the portability test (tests/test_portable.py): this interpreter behaves
as on a platform without fcntl, without prctl and without /proc."""
import builtins, ctypes, io, os, sys


class _NoFcntl:
    def find_spec(self, name, path=None, target=None):
        if name == "fcntl":
            raise ModuleNotFoundError("No module named 'fcntl' (blocked by the test)")
        return None


sys.meta_path.insert(0, _NoFcntl())
sys.modules.pop("fcntl", None)

_symbol = ctypes.CDLL.__getattr__


def _no_prctl(self, name):
    if name == "prctl":
        raise AttributeError("prctl (blocked by the test)")
    return _symbol(self, name)


ctypes.CDLL.__getattr__ = _no_prctl


def _no_proc(fn):
    def call(path, *args, **kwargs):
        p = os.fsdecode(path) if isinstance(path, (str, bytes, os.PathLike)) else ""
        if p == "/proc" or p.startswith("/proc/"):
            raise FileNotFoundError(2, "No such file or directory (blocked by the test)", p)
        return fn(path, *args, **kwargs)

    return call


builtins.open = io.open = _no_proc(io.open)
for _name in ("open", "stat", "lstat", "scandir", "listdir"):
    setattr(os, _name, _no_proc(getattr(os, _name)))
'''


@pytest.fixture(scope="module")
def not_posix(tmp_path_factory) -> dict[str, str]:
    """The environment of a Python whose ``sitecustomize`` blocks ``fcntl``, ctypes'
    ``prctl`` and ``/proc`` before anything else is imported."""
    site = tmp_path_factory.mktemp("not_posix")
    (site / "sitecustomize.py").write_text(NOT_POSIX)
    path = os.pathsep.join([str(site), *filter(None, [os.environ.get("PYTHONPATH")])])
    return {**os.environ, "PYTHONPATH": path}


def _python(env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, env=env, timeout=300
    )


def test_the_blocks_hold(not_posix):
    """The blocked interpreter really has no fcntl, prctl or /proc."""
    code = textwrap.dedent(
        """
        import ctypes, os
        for attempt in (lambda: __import__("fcntl"), lambda: ctypes.CDLL(None).prctl,
                        lambda: open("/proc/self/stat"), lambda: os.listdir("/proc")):
            try:
                attempt()
            except (ImportError, AttributeError, OSError):
                continue
            raise SystemExit("not blocked")
        print("blocked")
        """
    )
    res = _python(not_posix, "-c", code)
    assert res.returncode == 0 and res.stdout.strip() == "blocked", res.stderr


def test_import_and_solve_without_fcntl_prctl_or_proc(not_posix):
    code = textwrap.dedent(
        f"""
        import sys
        import numpy as np
        import humanoid_ik

        chain = humanoid_ik.Chain()
        res = humanoid_ik.solve(chain, {TARGET!r})
        position, _ = chain.fk(res.q)
        assert np.linalg.norm(position - np.array({TARGET!r})) < 1e-4, (position, res)
        loaded = sorted(m for m in sys.modules
                        if m == "fcntl" or m.startswith({APPLICATION!r}))
        print(res.status.name, loaded)
        """
    )
    res = _python(not_posix, "-c", code)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split(maxsplit=1)[1].strip() == "[]", res.stdout


def test_command_line_without_fcntl_prctl_or_proc(not_posix):
    helped = _python(not_posix, "-m", "humanoid_ik", "--help")
    assert helped.returncode == 0, helped.stderr
    assert "usage" in helped.stdout and "solve" in helped.stdout
    solved = _python(not_posix, "-m", "humanoid_ik", "solve", "--target", "0.35,-0.30,1.15")
    assert solved.returncode == 0, solved.stderr
    assert "right_shoulder_flexion_joint" in solved.stdout, solved.stdout
    assert "right_wrist_deviation_joint" in solved.stdout, solved.stdout


def test_import_humanoid_ik_loads_no_application_module():
    """In a fresh interpreter: the front door and a solve load only the IK library, and
    not the process pools that only solve_batch's workers need."""
    code = textwrap.dedent(
        f"""
        import sys
        import humanoid_ik

        humanoid_ik.solve(humanoid_ik.Chain(), {TARGET!r})
        pools = ("multiprocessing", "concurrent.futures")
        print(sorted(m for m in sys.modules if m.startswith({APPLICATION!r} + pools)))
        """
    )
    res = subprocess.run(
        [sys.executable, "-W", "error::DeprecationWarning", "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == "[]"


def test_front_door_lists_no_application_name():
    for name, module in humanoid_ik._EXPORTS.items():
        assert not module.startswith(APPLICATION), (name, module)
    assert not set(humanoid_ik._DEPRECATED) & set(humanoid_ik.__all__)


@pytest.mark.parametrize("name", sorted(humanoid_ik._DEPRECATED))
def test_deprecated_application_names_warn_and_still_work(name):
    module = humanoid_ik._DEPRECATED[name]
    with pytest.warns(DeprecationWarning, match=rf"from {module} import {name}"):
        value = getattr(humanoid_ik, name)
    assert value is getattr(__import__(module, fromlist=[name]), name)
    with pytest.warns(DeprecationWarning):  # each use warns, not only the first
        getattr(humanoid_ik, name)


def test_deprecated_from_import_warns_and_works():
    with pytest.warns(DeprecationWarning, match="humanoid_ik.config.scene"):
        from humanoid_ik import load_scene
    assert load_scene("circle").name == "circle"


def test_library_names_do_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in humanoid_ik.__all__:
            assert getattr(humanoid_ik, name) is not None


def test_folder_lock_without_fcntl_excludes_and_removes_a_dead_holders_lock(tmp_path, monkeypatch):
    """Without fcntl, publishing holds an O_EXCL lock file: one holder at a time, and a
    lock file left by a process that no longer runs does not block the next run."""
    monkeypatch.setitem(sys.modules, "fcntl", None)  # import fcntl raises ImportError
    lock = tmp_path / ".lock"
    inside: list[int] = []
    overlaps: list[int] = []

    def work(i: int) -> None:
        for _ in range(25):
            with atomic._folder_lock(lock):
                inside.append(i)
                overlaps.append(len(inside))
                inside.remove(i)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert max(overlaps) == 1 and len(overlaps) == 100
    dead = subprocess.Popen(["true"])
    dead.wait()
    Path(f"{lock}.held").write_text(f"{dead.pid}\n")
    with atomic._folder_lock(lock):
        assert Path(f"{lock}.held").read_text() == f"{os.getpid()}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_publish_without_fcntl(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "fcntl", None)
    with atomic.staged_outputs(tmp_path) as staging:
        (staging / "a.txt").write_text("1")
    assert atomic.published(tmp_path) == ["a.txt"]
    assert (tmp_path / "a.txt").read_text() == "1"
    assert sorted(p.name for p in tmp_path.iterdir()) == [".humanoid-ik-outputs.json", "a.txt"]


def test_renamed_error_warns_and_is_the_new_one():
    """``humanoid_ik.TrajectoryError`` is now ``MotionError``; the old name still works."""
    assert "TrajectoryError" not in humanoid_ik.__all__
    with pytest.warns(DeprecationWarning, match=r"humanoid_ik\.MotionError"):
        old = humanoid_ik.TrajectoryError
    assert old is humanoid_ik.MotionError
