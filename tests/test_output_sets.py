"""One rule for outputs (issue 14, item 4): a run's files replace the previous run's in
its folder as one set, or not at all; never a mix of two runs, never a temporary left
after the next run, whatever stops it (a failure, SIGINT, SIGTERM, SIGKILL, another run
writing into the same folder)."""

from __future__ import annotations

import json
import signal
import subprocess
import uuid
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from humanoid_ik.outputs.atomic import MANIFEST, publish, published, staged_outputs
from humanoid_ik.outputs.render.video import mp4_complete
from humanoid_ik.outputs.trajectory import load_trajectory
from tests.processes import (
    ended,
    handles,
    importing,
    none_left,
    run_cli,
    signal_when,
    start,
    tagged,
    temporaries,
)

SMALL = ["--width", "64", "--height", "48"]


def _check_one_set(folder: Path) -> list[str]:
    """The folder holds exactly one complete run: every file its manifest lists, none
    of another run's, consistent with each other; returns the listed names."""
    names = published(folder)
    ours = {p.name for p in folder.iterdir() if not p.name.startswith(".")} - {"notes.txt"}
    assert ours == set(names)
    frames = json.loads((folder / "metrics.json").read_text())["frames"]
    traj = load_trajectory(folder / "trajectory.npz")
    assert len(traj.time) == frames
    for name in names:
        if name.endswith(".mp4"):
            assert mp4_complete(folder / name)
    snaps = [n for n in names if n.startswith("frame_")]
    assert all(int(n[6:10]) < frames for n in snaps)
    return names


def test_publish_replaces_the_previous_set_and_keeps_the_users_files(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with staged_outputs(tmp_path) as stage:
        for name in ("a.png", "b.png", "metrics.json"):
            (stage / name).write_text("run 1")
    assert published(tmp_path) == ["a.png", "b.png", "metrics.json"]
    with staged_outputs(tmp_path) as stage:
        for name in ("b.png", "c.png", "metrics.json"):
            (stage / name).write_text("run 2")
    assert published(tmp_path) == ["b.png", "c.png", "metrics.json"]
    assert not (tmp_path / "a.png").exists()  # the earlier run's own file is gone
    assert (tmp_path / "b.png").read_text() == "run 2"
    assert (tmp_path / "notes.txt").read_text() == "mine"  # never listed, never touched
    assert temporaries(tmp_path) == []


def test_a_failed_run_leaves_the_previous_set_untouched(tmp_path):
    with staged_outputs(tmp_path) as stage:
        (stage / "metrics.json").write_text("run 1")
    with pytest.raises(RuntimeError), staged_outputs(tmp_path) as stage:
        (stage / "metrics.json").write_text("run 2, half")
        raise RuntimeError("the renderer failed")
    assert (tmp_path / "metrics.json").read_text() == "run 1"
    assert published(tmp_path) == ["metrics.json"] and temporaries(tmp_path) == []


def test_a_damaged_manifest_is_ignored_not_trusted(tmp_path):
    (tmp_path / "keep.txt").write_text("x")
    (tmp_path / MANIFEST).write_text('{"files": ["../escape", ".hidden", "keep.txt", 3]')
    assert published(tmp_path) == []  # not valid JSON
    (tmp_path / MANIFEST).write_text('{"files": ["../escape", ".hidden", 3]}')
    assert published(tmp_path) == []
    stage = tmp_path / "stage"
    stage.mkdir()
    (stage / "new.png").write_text("n")
    publish(stage, tmp_path)
    assert (tmp_path / "keep.txt").exists() and published(tmp_path) == ["new.png"]


@pytest.mark.slow
def test_rerender_removes_the_earlier_runs_frames_and_gif(tmp_path):
    out = tmp_path / "out"
    first = run_cli("render", "showcase", "--frames", "12", *SMALL, "--out", str(out))
    assert first.returncode == 0, first.stderr
    (out / "notes.txt").write_text("mine")
    first_names = set(published(out))
    second = run_cli("render", "circle", "--frames", "5", *SMALL, "--no-video", "--out", str(out))
    assert second.returncode == 0, second.stderr
    names = _check_one_set(out)
    assert "showcase.mp4" in first_names and not (out / "showcase.mp4").exists()
    assert not any(n.startswith("showcase") for n in names)
    assert (out / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_render_failing_at_the_video_keeps_the_previous_complete_set(tmp_path):
    out = tmp_path / "out"
    first = run_cli("render", "circle", "--frames", "12", *SMALL, "--out", str(out))
    assert first.returncode == 0, first.stderr
    before = {n: (out / n).read_bytes() for n in published(out)}
    size = (out / "circle.mp4").stat().st_size
    args = ["render", "circle", "--frames", "12", *SMALL, "--out", str(out)]
    failed = run_cli(*args, limit=size - 100)
    assert failed.returncode == 2 and "did not finish the file" in failed.stderr
    assert {n: (out / n).read_bytes() for n in published(out)} == before
    assert temporaries(out) == []


@pytest.mark.slow
def test_two_renders_into_one_folder_leave_one_whole_set(tmp_path):
    out = tmp_path / "out"
    procs = [
        start(["render", "showcase", "--frames", "10", *SMALL, "--out", str(out)]),
        start(["render", "circle", "--frames", "7", *SMALL, "--out", str(out)]),
    ]
    for p in procs:
        _o, err = p.communicate(timeout=300)
        assert p.returncode == 0, err.decode()
    names = _check_one_set(out)
    scenes = {n.split(".")[0] for n in names if n.endswith(".mp4")}
    assert len(scenes) == 1  # one run's video, not both
    assert temporaries(out) == []


@pytest.mark.slow
def test_ctrl_c_during_a_render_publishes_the_frames_done(tmp_path):
    out = tmp_path / "out"
    tag = uuid.uuid4().hex
    proc = start(["render", "showcase", "--frames", "1500", *SMALL, "--out", str(out)], tag)
    recording = {**_render_moment("recording", out, proc, tag), "after": 2.0}
    assert signal_when(proc, signal.SIGTERM, **recording)  # some frames are done
    _o, err = ended(proc, tag, 120)
    assert proc.returncode == 143, err.decode()
    names = _check_one_set(out)
    traj = load_trajectory(out / "trajectory.npz")
    assert traj.interrupted and 0 < len(traj.time) < 1500
    assert "showcase.mp4" in names
    assert np.all(np.diff(traj.time) > 0)


def _stage(out: Path, pid: int) -> Path | None:
    """The staging folder of process ``pid`` writing into ``out``, if there is one (not
    one that a killed run left)."""
    return next(out.glob(f".run.{pid}.*.tmpdir"), None) if out.exists() else None


def _ffmpeg_runs(tag: str) -> bool:
    """Whether an ``ffmpeg`` of the run tagged ``tag`` runs: the render loop has begun."""
    return any(b"ffmpeg" in Path(f"/proc/{pid}/cmdline").read_bytes() for pid in tagged(tag))


RENDER_KILLS = [
    ("start-up", signal.SIGINT),
    ("imports", signal.SIGTERM),
    ("staged", signal.SIGTERM),
    ("recording", signal.SIGKILL),
    ("rendering", signal.SIGINT),
    ("finishing", signal.SIGTERM),
    ("finishing", signal.SIGKILL),
]
"""(phase of the render, signal), in this order into one folder: importing MuJoCo; the
command importing on (SIGTERM's handler installed); the staging folder made;
ffmpeg started; frames being rendered (a second later); the video done, the metrics
being written."""


def _render_moment(phase: str, out: Path, proc: subprocess.Popen, tag: str) -> dict[str, Any]:
    """When to signal render ``proc`` (tagged ``tag``) in ``phase``: the ``ready``,
    ``after`` and ``poll`` of :func:`~tests.processes.signal_when`."""
    if phase == "start-up":
        return {"ready": lambda: importing(proc), "poll": 0.001}
    if phase == "imports":
        return {"ready": lambda: handles(proc, signal.SIGTERM), "poll": 0.0005}
    if phase in ("recording", "rendering"):  # a look at every process: not too often
        return {
            "ready": lambda: _ffmpeg_runs(tag),
            "after": 1.0 if phase == "rendering" else 0.0,
            "poll": 0.02,
        }

    def ready() -> bool:
        stage = _stage(out, proc.pid)
        return stage is not None and (phase == "staged" or (stage / "metrics.json").exists())

    return {"ready": ready}


@pytest.mark.slow
def test_kills_in_each_phase_of_renders_leave_one_whole_set_or_the_previous(tmp_path):
    """Renders into one folder, each stopped by a signal in one phase of its run (start-up,
    imports, staged, ffmpeg started, rendering, finishing; each signal in two or more):
    the folder always holds one complete set (the last finished or published one), no
    process of the run (ffmpeg included) outlives it, and the next run leaves no
    temporary behind."""
    out = tmp_path / "out"
    first = run_cli("render", "circle", "--frames", "6", *SMALL, "--out", str(out))
    assert first.returncode == 0, first.stderr
    for phase, sig in RENDER_KILLS:
        tag = uuid.uuid4().hex
        proc = start(["render", "showcase", "--frames", "20", *SMALL, "--out", str(out)], tag)
        assert signal_when(proc, sig, **_render_moment(phase, out, proc, tag)), (phase, sig)
        _o, err = ended(proc, tag, 120)
        status = {signal.SIGINT: 130, signal.SIGTERM: 143}.get(sig)
        assert proc.returncode in (0, -sig, status), (phase, sig, err.decode()[-800:])
        assert "Traceback" not in err.decode(), err.decode()[-1500:]
        assert none_left(tag) == [], (phase, sig)  # ffmpeg included
        _check_one_set(out)
    last = run_cli("render", "circle", "--frames", "4", *SMALL, "--no-video", "--out", str(out))
    assert last.returncode == 0, last.stderr
    _check_one_set(out)
    assert temporaries(out) == []
