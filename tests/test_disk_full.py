"""A disk that fills while ffmpeg finishes the MP4 (issue 14, item 1): simulated for real
with a file-size limit (``RLIMIT_FSIZE``) that ffmpeg inherits, so its trailer write
fails as on a full disk; no broken MP4 may be left under the final name."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from humanoid_ik.outputs.render.video import mp4_complete
from tests.processes import run_cli

ARGS = ["render", "circle", "--frames", "12", "--width", "96", "--height", "72"]


def _render(out: Path, limit: int | None = None) -> subprocess.CompletedProcess:
    return run_cli(*ARGS, "--out", str(out), limit=limit)


@pytest.mark.slow
def test_mp4_whose_trailer_cannot_be_written_is_not_left_under_its_name(tmp_path):
    full = _render(tmp_path / "full")
    assert full.returncode == 0, full.stderr
    mp4 = tmp_path / "full" / "circle.mp4"
    assert mp4_complete(mp4)
    size = mp4.stat().st_size
    # the frames fit, the index ffmpeg writes last does not: as a disk filling up then
    res = _render(tmp_path / "short", limit=size - 100)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "did not finish the file" in lines[0] and "circle.mp4" in lines[0]
    assert not (tmp_path / "short" / "circle.mp4").exists()
    assert [p.name for p in (tmp_path / "short").glob(".*")] == []  # no temporary left


@pytest.mark.slow
def test_mp4_complete_tells_a_whole_file_from_a_cut_one(tmp_path):
    res = _render(tmp_path / "r")
    assert res.returncode == 0, res.stderr
    whole = tmp_path / "r" / "circle.mp4"
    assert mp4_complete(whole)
    data = whole.read_bytes()
    for cut in (len(data) - 1, len(data) // 2, 7):
        part = tmp_path / f"cut{cut}.mp4"
        part.write_bytes(data[:cut])
        assert not mp4_complete(part)
    shutil.copy(whole, tmp_path / "copy.mp4")
    assert mp4_complete(tmp_path / "copy.mp4")
    assert not mp4_complete(tmp_path / "missing.mp4")
