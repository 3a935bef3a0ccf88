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


@pytest.fixture(scope="module")
def whole(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The MP4 of a render with no limit (read, never changed, by the tests)."""
    out = tmp_path_factory.mktemp("whole")
    res = _render(out)
    assert res.returncode == 0, res.stderr
    return out / "circle.mp4"


@pytest.mark.slow
def test_mp4_whose_trailer_cannot_be_written_is_not_left_under_its_name(tmp_path, whole):
    assert mp4_complete(whole)
    size = whole.stat().st_size
    # the frames fit, the index ffmpeg writes last does not: as a disk filling up then
    res = _render(tmp_path / "short", limit=size - 100)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "did not finish the file" in lines[0] and "circle.mp4" in lines[0]
    assert not (tmp_path / "short" / "circle.mp4").exists()
    assert [p.name for p in (tmp_path / "short").glob(".*")] == []  # no temporary left


@pytest.mark.slow
def test_mp4_complete_tells_a_whole_file_from_a_cut_one(tmp_path, whole):
    assert mp4_complete(whole)
    data = whole.read_bytes()
    for cut in (len(data) - 1, len(data) // 2, 7):
        part = tmp_path / f"cut{cut}.mp4"
        part.write_bytes(data[:cut])
        assert not mp4_complete(part)
    shutil.copy(whole, tmp_path / "copy.mp4")
    assert mp4_complete(tmp_path / "copy.mp4")
    assert not mp4_complete(tmp_path / "missing.mp4")
