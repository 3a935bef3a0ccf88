"""Runs stopped by real signals (issue 14, items 2 and 6): sweeps, datasets and renders
killed with SIGINT, SIGTERM or SIGKILL leave no process alive and no temporary file after
the next run, and end with the conventional status and one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik.config.sweep_file import load_sweep
from humanoid_ik.core.models import bundled_dir
from humanoid_ik.experiments.dataset import read_dataset
from humanoid_ik.outputs.atomic import atomic_dir, atomic_path, remove_stale
from tests.processes import (
    MESSAGE,
    STATUS,
    ended,
    handles,
    importing,
    none_left,
    signal_when,
    start,
    tagged,
    temporaries,
)

SWEEP = bundled_dir("sweeps") / "compare_solvers.toml"


def _command(pid: int) -> str:
    """A process's command line (for a failure message)."""
    try:
        return (Path("/proc") / str(pid) / "cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return "?"


def _wait_mid_run(folder: Path, written: int = 4_000_000, within: float = 120.0) -> None:
    """Wait until a dataset run has written ``written`` bytes of raw chunks into its
    temporary folder under ``folder``: well inside a run of a million pairs (about
    110 MB), whatever the machine's speed."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            size = sum(p.stat().st_size for p in folder.rglob("*.raw"))
        except FileNotFoundError:  # a file went away while being listed
            size = 0
        if size >= written:
            return
        time.sleep(0.02)
    raise AssertionError(f"the dataset under {folder} never wrote {written} bytes")


def _wait_for(path: Path, within: float = 60.0) -> None:
    deadline = time.monotonic() + within
    while not path.exists():
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.05)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_killed_sweep_leaves_no_worker_and_frees_the_callers_pipes(tmp_path, sig):
    tag = uuid.uuid4().hex
    proc = start(["sweep", str(SWEEP), "--workers", "2", "--out", str(tmp_path)], tag)
    _wait_for(tmp_path / "workers.log")
    time.sleep(1.0)  # the pool's workers are running jobs
    assert len(tagged(tag)) >= 3  # the sweep, its forkserver and workers
    proc.send_signal(sig)
    # communicate returns only when every holder of the pipes is gone
    _out, err = ended(proc, tag, 30)
    assert none_left(tag) == []
    if sig == signal.SIGKILL:
        assert proc.returncode == -signal.SIGKILL
    else:
        assert proc.returncode == STATUS[sig]
        lines = err.decode().strip().splitlines()
        assert lines[-1] == MESSAGE[sig] and "Traceback" not in err.decode()


@pytest.mark.slow
def test_dataset_killed_leaves_temporaries_that_the_next_run_removes(tmp_path):
    out = tmp_path / "pairs.npz"
    tag = uuid.uuid4().hex
    proc = start(["dataset", "--n", "1000000", "--chunk", "4096", "--out", str(out)], tag)
    _wait_mid_run(tmp_path)
    proc.kill()
    ended(proc, tag, 30)
    assert not out.exists() and temporaries(tmp_path)  # what SIGKILL leaves behind
    done = subprocess.run(
        [sys.executable, "-m", "humanoid_ik", "dataset", "--n", "100", "--out", str(out)],
        capture_output=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert temporaries(tmp_path) == []
    assert read_dataset(out).positions.shape == (100, 3)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_dataset_stopped_by_a_signal_removes_itstemporaries(tmp_path, sig):
    out = tmp_path / "pairs.npz"
    tag = uuid.uuid4().hex
    proc = start(["dataset", "--n", "1000000", "--chunk", "4096", "--out", str(out)], tag)
    _wait_mid_run(tmp_path)
    proc.send_signal(sig)
    _out, err = ended(proc, tag, 30)
    assert proc.returncode == STATUS[sig]
    assert err.decode().strip().splitlines()[-1] == MESSAGE[sig]
    assert temporaries(tmp_path) == [] and not out.exists()


def _dead_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_remove_stale_removes_only_temporaries_of_dead_writers(tmp_path):
    final = tmp_path / "showcase.mp4"
    dead = _dead_pid()
    stale_file = tmp_path / f".showcase.{dead}.140000.tmp.mp4"
    stale_dir = tmp_path / f".showcase.{dead}.140000.tmpdir"
    live_file = tmp_path / f".showcase.{os.getpid()}.1.tmp.mp4"
    other = tmp_path / f".other.{dead}.1.tmp.mp4"
    stale_file.write_bytes(b"x")
    stale_dir.mkdir()
    (stale_dir / "chunk").write_bytes(b"y")
    live_file.write_bytes(b"z")
    other.write_bytes(b"w")
    assert sorted(remove_stale(final)) == sorted([stale_file, stale_dir])
    assert live_file.exists() and other.exists() and not stale_dir.exists()
    with atomic_path(tmp_path / "other.mp4") as tmp:  # every atomic write cleans first
        tmp.write_bytes(b"v")
    assert not other.exists() and (tmp_path / "other.mp4").read_bytes() == b"v"


def test_atomic_dir_is_removed_when_its_block_fails(tmp_path):
    with pytest.raises(RuntimeError), atomic_dir(tmp_path / "data.npz") as scratch:
        (scratch / "part").write_bytes(b"1")
        raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []


SMALL_SWEEP = """
name = "small"
seeds = [0, 1]
solvers = ["dls", "closed_form"]

[[scenes]]
scene = "circle"
frames = 60

[[targets]]
name = "right_pose"
task = "pose"
n = 50
"""
DATASET_PAIRS = 100_000
"""Pairs of a killed dataset run: packing them (11 MB) takes 10 ms or more, caught by
looking every half millisecond."""


MOMENT_ATTEMPTS = 3
"""Runs started before a moment is given up: the packing phase lasts about 10 ms, which
a loaded machine can spend elsewhere."""


def _packing(out: Path) -> bool:
    return any(p.name.endswith(".tmp.npz") for p in out.iterdir())


Moment = float | Callable[[subprocess.Popen, Path], bool]
PHASES: dict[str, Moment] = {
    # the moment of a sweep's run (out: its output folder) or a dataset's (out: the folder
    # of d.npz) at which the signal is sent: a delay, or what the run has done by then
    "start-up": lambda proc, out: importing(proc),  # MuJoCo, before the command's handlers
    "imports": lambda proc, out: handles(proc, signal.SIGTERM),  # the command importing
    "pool": lambda proc, out: (out / "workers.log").exists(),  # forkserver, workers start
    "jobs": lambda proc, out: any((out / "jobs").glob("*.json")),  # records coming back
    "summary": lambda proc, out: (out / "summary.csv").exists(),  # plotting summary.png
    "packing": lambda proc, out: _packing(out),  # raw chunks into the .npz's temporary
    "published": lambda proc, out: (out / "d.npz").exists(),  # scratch removed, exiting
}
KILLS = [
    ("sweep", "start-up", signal.SIGINT),
    ("sweep", "imports", signal.SIGTERM),
    ("sweep", "pool", signal.SIGINT),
    ("sweep", "pool", signal.SIGTERM),
    ("sweep", "pool", signal.SIGKILL),
    ("sweep", "jobs", signal.SIGINT),
    ("sweep", "jobs", signal.SIGKILL),
    ("sweep", "summary", signal.SIGTERM),
    ("sweep", "summary", signal.SIGKILL),
    ("dataset", "start-up", signal.SIGTERM),
    ("dataset", "imports", signal.SIGTERM),
    ("dataset", "packing", signal.SIGINT),
    ("dataset", "packing", signal.SIGTERM),
    ("dataset", "packing", signal.SIGKILL),
    ("dataset", "published", signal.SIGKILL),
]
"""(run, phase of the run, signal): every phase of each run, each signal in several."""


@pytest.mark.slow
@pytest.mark.parametrize(
    ("kind", "phase", "sig"), KILLS, ids=[f"{k}-{p}-{s.name}" for k, p, s in KILLS]
)
def test_kill_in_each_phase_of_sweeps_and_datasets_leaves_complete_or_nothing(
    tmp_path, kind, phase, sig
):
    """A sweep or a dataset stopped by a signal at one moment of its run (start-up,
    imports, pool, jobs and summary of a sweep; start-up, imports, packing and publishing
    of a dataset): nothing of it runs afterwards, what is on disk is complete or absent,
    and the next run finishes with no temporary left."""
    out = tmp_path / kind
    out.mkdir()
    sweep = None
    if kind == "sweep":
        sweep = tmp_path / "small.toml"
        sweep.write_text(SMALL_SWEEP)
        args = ["sweep", str(sweep), "--workers", "2", "--out", str(out)]
    else:
        args = ["dataset", "--n", str(DATASET_PAIRS), "--out", str(out / "d.npz")]
    tag = uuid.uuid4().hex
    moment = PHASES[phase]
    for _attempt in range(MOMENT_ATTEMPTS):  # a busy machine may miss a short moment
        proc = start(args, tag)
        ready = moment if isinstance(moment, float) else partial(moment, proc, out)
        if signal_when(proc, sig, ready, poll=0.0005 if phase == "packing" else 0.002):
            break
        ended(proc, tag, 60)  # it finished first: run it again
    else:
        pytest.fail(f"the {phase} moment came and went unseen {MOMENT_ATTEMPTS} times")
    _o, err = ended(proc, tag, 60)
    # ended by the signal itself (before the handlers are installed, or SIGKILL), by its
    # handler (130, 143), or finished first (0)
    statuses = (-sig, 0) if sig == signal.SIGKILL else (STATUS[sig], -sig, 0)
    assert proc.returncode in statuses, (kind, phase, sig, err.decode()[-500:])
    assert "Traceback" not in err.decode(), err.decode()[-1500:]
    assert none_left(tag) == [], (kind, phase, sig)
    _check_complete_or_absent(kind, out, sweep)
    _check_rerun(kind, out, args)


def _check_complete_or_absent(kind: str, out: Path, sweep: Path | None) -> None:
    """What a stopped run left under its final names is whole."""
    if kind == "dataset":
        if (out / "d.npz").exists():
            assert read_dataset(out / "d.npz").positions.shape == (DATASET_PAIRS, 3)
        return
    assert sweep is not None
    # the records under their final names (a SIGKILL may leave a hidden temporary beside
    # them, ``.ID.PID.TID.tmp.json``: the next run removes it, see _check_rerun)
    for record in (out / "jobs").glob("[!.]*.json"):
        assert json.loads(record.read_text())["status"] in ("ok", "failed", "skipped")
    if (out / "summary.csv").exists():
        rows = (out / "summary.csv").read_text().splitlines()
        assert len(rows) == len(load_sweep(sweep).jobs) + 1


def _check_rerun(kind: str, out: Path, args: list[str]) -> None:
    if kind == "dataset":
        small = [*args[:2], "200", *args[3:]]
        done = subprocess.run(
            [sys.executable, "-m", "humanoid_ik", *small], capture_output=True, timeout=120
        )
        assert done.returncode == 0, done.stderr
        d = read_dataset(out / "d.npz")
        assert d.positions.shape == (200, 3) and np.all(np.isfinite(d.q))
    else:  # a resumed sweep finishes and its job records are whole
        done = subprocess.run(
            [sys.executable, "-m", "humanoid_ik", *args], capture_output=True, timeout=300
        )
        assert done.returncode == 0, done.stderr
        assert (out / "summary.csv").exists()
    assert temporaries(out) == [], temporaries(out)


@pytest.mark.slow
def test_killed_sweep_on_local_ray_takes_its_ray_processes_along(tmp_path):
    pytest.importorskip("ray")  # the ray extra; CI installs it
    tag = uuid.uuid4().hex
    args = ["sweep", str(SWEEP), "--ray", "local", "--workers", "2", "--out", str(tmp_path)]
    proc = start(args, tag)
    deadline = time.monotonic() + 120
    while not list((tmp_path / "jobs").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.2)  # Ray is up and its workers are running jobs
    assert len(tagged(tag)) >= 4  # the sweep, its Ray process, Ray's raylet, GCS, workers
    proc.kill()
    ended(proc, tag, 60)
    left = {pid: _command(pid) for pid in tagged(tag)}
    # the Ray process's group (GCS, raylet, agents) goes at once, Ray's workers (in
    # groups of their own) within seconds of their raylet (docs/sweeps.md)
    assert none_left(tag, within=30) == [], left


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.0, 0.1, 0.2, 0.35])
def test_ctrl_c_during_start_up_is_one_line_and_130(tmp_path, delay):
    """SIGINT while the command line is still importing MuJoCo and the commands (``delay``
    seconds after their imports began)."""
    tag = uuid.uuid4().hex
    proc = start(["scenes"], tag)
    signal_when(proc, signal.SIGINT, lambda: importing(proc), after=delay, poll=0.001)
    out, err = ended(proc, tag, 60)
    text = err.decode()
    assert "Traceback" not in text, text
    # 130 with the one line; 0 when the listing finished first; or ended by SIGINT's
    # default action, when it landed while the interpreter was exiting (Python's own
    # handler already gone), after the listing or after the one line
    assert proc.returncode in (0, 130, -signal.SIGINT), text
    assert text.strip() in ("", "humanoid-ik: interrupted"), text
    if proc.returncode == 130:
        assert text.strip() == "humanoid-ik: interrupted"
    if proc.returncode == 0:
        assert text == "" and b"showcase" in out


def test_ctrl_c_that_a_compiled_import_turned_into_import_error_counts_as_ctrl_c():
    """MuJoCo's extension reports a Ctrl-C during its initialisation as
    ``ImportError: initialization failed`` caused by the ``KeyboardInterrupt``."""
    from humanoid_ik.cli.interrupts import interrupted

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise ImportError("initialization failed") from exc
    except ImportError as exc:
        assert interrupted(exc)
    assert not interrupted(ImportError("No module named 'mujoco'"))


def test_ctrl_c_that_ctypes_wrapped_counts_as_ctrl_c():
    """A Ctrl-C while ctypes converts a call's argument (PyOpenGL's calls as MuJoCo
    loads EGL) comes out as ``ctypes.ArgumentError: argument 1: KeyboardInterrupt``;
    other argument errors stay errors."""
    import ctypes

    from humanoid_ik.cli.interrupts import interrupted

    class Interrupts:
        @property
        def _as_parameter_(self):
            raise KeyboardInterrupt

    libc = ctypes.CDLL(None)
    with pytest.raises(ctypes.ArgumentError) as caught:
        libc.abs(Interrupts())
    assert interrupted(caught.value)
    with pytest.raises(ctypes.ArgumentError) as wrong:
        libc.abs(object())
    assert not interrupted(wrong.value)


FINALISER_SIGNAL = """
import os, signal, sys, time
from humanoid_ik.cli import app

class Finaliser:
    def __del__(self):  # the signal's handler runs in here, where Python cannot raise
        os.kill(os.getpid(), {sig})
        for _ in range(200_000):
            pass

def build_parser():
    Finaliser()  # dropped at once: its finaliser runs now
    time.sleep(5)  # the signal delivered again lands here
    raise SystemExit("the signal was lost")

app.build_parser = build_parser
sys.exit(app.main(["scenes"]))
"""


@pytest.mark.parametrize(
    ("sig", "status", "word"),
    [("signal.SIGTERM", 143, "terminated"), ("signal.SIGINT", 130, "interrupted")],
)
def test_a_signal_that_lands_in_a_finaliser_still_stops_the_command(sig, status, word):
    """A SIGTERM or Ctrl-C whose exception Python cannot raise (a finaliser; the import
    system's module-lock callback) is neither printed as ``Exception ignored`` nor lost:
    the command stops with the one line and its status."""
    done = subprocess.run(
        [sys.executable, "-c", FINALISER_SIGNAL.format(sig=sig)],
        capture_output=True,
        timeout=60,
    )
    err = done.stderr.decode()
    assert done.returncode == status, err
    assert err.strip() == f"humanoid-ik: {word}", err
