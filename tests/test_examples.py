"""The scripts of examples/ run as a user runs them (a subprocess, from another folder)
and what they print and write is right, checked against MuJoCo independently."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from humanoid_ik import Chain
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.rotations import quat_to_mat

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
URDF = EXAMPLES / "urdf_arm" / "arm7.urdf"


def run_example(
    name: str, *args: str | Path, cwd: Path, timeout: float = 120
) -> subprocess.CompletedProcess[str]:
    """Run ``examples/<name>`` with this interpreter from ``cwd``."""
    env = dict(os.environ, MUJOCO_GL="egl", MPLBACKEND="Agg")
    return subprocess.run(
        [sys.executable, str(EXAMPLES / name), *map(str, args)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def number(pattern: str, text: str) -> float:
    """The first number after ``pattern`` in ``text``."""
    m = re.search(pattern + r"\s*([-+0-9.e]+)", text)
    assert m, f"{pattern!r} not in output:\n{text}"
    return float(m.group(1))


def test_every_example_is_tested() -> None:
    """Each script in examples/ has a test here (a new one cannot go untested)."""
    scripts = sorted(p.name for p in EXAMPLES.glob("*.py"))
    assert scripts == [
        "export_dataset.py",
        "own_robot_urdf.py",
        "scene_from_python.py",
        "solve_and_plot.py",
    ]


def test_own_robot_urdf(tmp_path: Path) -> None:
    """The URDF arm's pose is solved: the stored joints put the tool link on the target
    (MuJoCo FK of a fresh chain), inside the ranges, with the errors it printed."""
    out = tmp_path / "out"
    proc = run_example("own_robot_urdf.py", out, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    sol = json.loads((out / "solution.json").read_text())
    assert sol["status"] == "converged"
    arm = Chain(URDF, body="tool_link")
    q = np.array([sol["joints"][name] for name in arm.joint_names])
    assert len(q) == 7 and arm.within_limits(q)
    p, R = arm.fk(q)
    target_p = np.array(sol["target_position_m"])
    assert np.linalg.norm(p - target_p) < 1e-4
    R_target = quat_to_mat(sol["target_quat_wxyz"])
    angle = np.arccos(np.clip((np.trace(R_target.T @ R) - 1) / 2, -1, 1))
    assert angle < 1e-3
    assert number("position error", proc.stdout) == pytest.approx(
        sol["position_error_m"], rel=1e-3, abs=1e-15
    )
    # the solve started from home, far from the target: not a pose handed back unchanged
    assert np.linalg.norm(target_p - arm.fk(arm.q_home)[0]) > 0.05


def test_default_output_is_a_temporary_folder(tmp_path: Path) -> None:
    """Without an output folder an example writes into a new temp folder, never into
    the folder it runs from."""
    proc = run_example("own_robot_urdf.py", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    written = Path(re.search(r"wrote (\S+)", proc.stdout).group(1))  # type: ignore[union-attr]
    assert written.is_file() and not written.is_relative_to(tmp_path)
    assert not written.is_relative_to(ROOT)
    assert list(tmp_path.iterdir()) == []


def test_solve_and_plot(tmp_path: Path) -> None:
    """Every point of the circle is solved to within 0.1 mm, the elbow moves inside its
    range, and the plot is a real image with content."""
    proc = run_example("solve_and_plot.py", tmp_path, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert number("max position error", proc.stdout) < 1e-4
    m = re.search(r"right elbow from ([-0-9.]+) to ([-0-9.]+) deg", proc.stdout)
    assert m, proc.stdout
    low, high = np.radians([float(m.group(1)), float(m.group(2))])
    arm = Chain()
    k = arm.joint_names.index("right_elbow_joint")
    assert arm.lower[k] <= low < high <= arm.upper[k]
    assert high - low > np.radians(10)  # the hand's circle bends and stretches the elbow
    image = matplotlib.image.imread(tmp_path / "joint_angles.png")
    assert image.shape[:2] == (360, 480)  # 6 x 4.5 in at 80 dpi
    assert image[..., :3].std() > 0.05  # not a blank canvas


@pytest.mark.slow
def test_scene_from_python(tmp_path: Path) -> None:
    """The scene written from Python loads as a scene file, the hand tracks the whole
    figure-eight, and the tiny film has its contact sheet, metrics and trajectory."""
    proc = run_example("scene_from_python.py", tmp_path, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    scene = load_scene(tmp_path / "wave.toml")
    assert scene.name == "wave" and scene.n_frames == 60
    assert "wave: 60 frames, 60 reachable" in proc.stdout
    assert number("worst error", proc.stdout) < 1e-3
    film = tmp_path / "film"
    doc = json.loads((film / "metrics.json").read_text())
    assert doc["summary"][0]["frames"] == 8
    assert doc["summary"][0]["on_target_when_reachable"] == 1.0
    sheet = matplotlib.image.imread(film / "contact_sheet.png")
    assert sheet.shape[1] >= 4 * 160  # four thumbnails of 160 x 120 side by side
    assert (film / "trajectory.npz").is_file()


def test_export_dataset(tmp_path: Path) -> None:
    """The .npz and the CSV hold the same N pairs, and MuJoCo FK of stored joints gives
    the stored pose (checked here again on every row)."""
    proc = run_example("export_dataset.py", tmp_path, "300", cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "300 pairs" in proc.stdout and "closed form solved 300 of 300" in proc.stdout
    assert number("max FK error", proc.stdout) < 1e-9
    with np.load(tmp_path / "ik_pairs.npz") as npz:
        positions, quats, q = npz["positions"], npz["quats"], npz["q"]
    assert positions.shape == (300, 3) and quats.shape == (300, 4) and q.shape == (300, 7)
    table = np.loadtxt(tmp_path / "ik_pairs.csv", delimiter=",", skiprows=1)
    assert table.shape == (300, 14)
    np.testing.assert_allclose(table, np.hstack([positions, quats, q]), rtol=1e-8, atol=1e-9)
    header = (tmp_path / "ik_pairs.csv").read_text().splitlines()[0].split(",")
    arm = Chain()
    assert header[7:] == arm.joint_names
    for i in range(0, 300, 37):
        p, R = arm.fk(q[i])
        assert np.linalg.norm(p - positions[i]) < 1e-9
        assert np.abs(R - quat_to_mat(quats[i])).max() < 1e-9


def test_bad_argument_is_one_line(tmp_path: Path) -> None:
    """A bad count is refused by the script's parser in one line with exit status 2."""
    proc = run_example("export_dataset.py", tmp_path, "many", cwd=tmp_path)
    assert proc.returncode == 2
    assert "invalid int value: 'many'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []
