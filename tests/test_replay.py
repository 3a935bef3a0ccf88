"""Replay of a trajectory on real MuJoCo and EGL: the same frames as the render that
recorded it (compared pixel by pixel), from the .npz or the .csv, and a trajectory of
another model refused in one line."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.config.sweep_file import model_digest
from humanoid_ik.core.models import bundled_model_path, load_model
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.outputs.render import render_scene
from humanoid_ik.outputs.render.pipeline import replay_trajectory
from humanoid_ik.outputs.trajectory import load_trajectory
from tests.test_render import decode

W, H = 96, 72


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """showcase (hands, gaze, trails) rendered for 6 frames, every frame a PNG, with video."""
    root = tmp_path_factory.mktemp("render")
    sc = load_scene("showcase").with_overrides(frames=6, width=W, height=H)
    sc = replace(sc, render=replace(sc.render, snapshots=tuple(float(t) for t in range(6))))
    return render_scene(sc, root, plot=False)


def pixels(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB"))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["trajectory.npz", "trajectory.csv"])
def test_replay_gives_the_same_frames(rendered, tmp_path, kind):
    """Every PNG, the contact sheet and every decoded video frame of the replay equal the
    render's pixel for pixel (EGL on the CPU renders deterministically)."""
    traj = load_trajectory(rendered.folder / kind)
    out = replay_trajectory(
        traj, load_model(traj.model_file), tmp_path, digest=model_digest(traj.model_file)
    )
    assert out.frames == 6 and not out.interrupted
    assert [p.name for p in out.snapshots] == [p.name for p in rendered.snapshots]
    assert len(out.snapshots) == 6
    for a, b in zip(rendered.snapshots, out.snapshots, strict=True):
        np.testing.assert_array_equal(pixels(a), pixels(b))
    np.testing.assert_array_equal(pixels(rendered.contact_sheet), pixels(out.contact_sheet))
    frames_a, frames_b = decode(rendered.video), decode(out.video)
    assert len(frames_a) == len(frames_b) == 6
    for a, b in zip(frames_a, frames_b, strict=True):
        np.testing.assert_array_equal(a, b)
    # and the frames are not trivially equal: the arms and markers move between frames
    moved = np.abs(pixels(out.snapshots[0]).astype(int) - pixels(out.snapshots[3])).sum(axis=2)
    assert (moved > 60).sum() > 50


def test_replay_command(rendered, tmp_path, capsys):
    """`replay` with another camera and size writes its frames there; exit 0."""
    out = tmp_path / "p"
    args = ["replay", str(rendered.folder / "trajectory.npz"), "--out", str(out)]
    code = main([*args, "--camera", "side", "--width", "48", "--height", "32", "--no-video"])
    assert code == 0
    text = capsys.readouterr().out
    assert text.startswith("showcase: replayed 6 frame(s) 48x32 camera side")
    assert pixels(out / "frame_0000.png").shape == (32, 48, 3)
    assert (out / "contact_sheet.png").is_file() and not list(out.glob("*.mp4"))
    # the side view differs from the front view of the render
    assert f"wrote {out / 'frame_0005.png'}" in text


def test_replay_refuses_another_model(rendered, tmp_path, capsys):
    """A model file edited since the recording (another digest): exit 2, one line."""
    folder = tmp_path / "model"
    shutil.copytree(bundled_model_path().parent, folder)
    arm = folder / "humanoid.xml"
    arm.write_text(arm.read_text().replace('pos="0 0 -0.25"', 'pos="0 0 -0.27"', 1))
    out = tmp_path / "p"
    traj = str(rendered.folder / "trajectory.npz")
    code = main(["replay", traj, "--model", str(folder / "scene.xml"), "--out", str(out)])
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "was recorded on another version of" in err
    assert not out.exists() or not any(out.iterdir())


def test_replay_refuses_other_joints(rendered, tmp_path, capsys):
    """A model with other joints: exit 2, one line naming the joints."""
    other = tmp_path / "arm.xml"
    other.write_text(
        '<mujoco><worldbody><body><joint name="j"/><geom size=".1"/></body></worldbody></mujoco>'
    )
    traj = str(rendered.folder / "trajectory.npz")
    assert main(["replay", traj, "--model", str(other), "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not fit model" in err and "neck_yaw_joint" in err


def test_replay_bad_input(rendered, tmp_path, capsys):
    """Unknown camera, missing file: exit 2, one line each."""
    traj = str(rendered.folder / "trajectory.npz")
    assert main(["replay", traj, "--camera", "left", "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--camera 'left' not in model; cameras: front" in err
    assert main(["replay", str(tmp_path / "none.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err


def test_player_checks_the_model(rendered):
    """The player itself refuses a trajectory of another model digest."""
    traj = load_trajectory(rendered.folder / "trajectory.npz")
    from humanoid_ik.run.replay import TrajectoryPlayer

    with pytest.raises(TrajectoryFileError, match="another version"):
        TrajectoryPlayer(traj, load_model(None), digest="ffffffffffffffff")
    player = TrajectoryPlayer(traj, load_model(None), digest=traj.model_sha256)
    rec = player.step(4)
    np.testing.assert_array_equal(player.data.qpos, traj.qpos[4])
    np.testing.assert_allclose(
        player.data.site("right_palm_site").xpos, traj.effectors[0].achieved[4], atol=1e-12
    )
    assert rec.time == traj.time[4] and rec.samples[2].effector == "gaze_site"


@pytest.mark.slow
def test_replay_of_a_user_model_rebuilds_its_stage(tmp_path, capsys):
    """A URDF arm without floor, lights or cameras is filmed in the default stage; its
    replay builds the same stage from the trajectory and gives the same pixels."""
    scene = Path(__file__).parent / "models" / "arm7_circle.toml"
    out, back = tmp_path / "r", tmp_path / "p"
    common = ["--width", "64", "--height", "48", "--no-video"]
    assert main(["render", str(scene), "--frames", "4", "--out", str(out), *common]) == 0
    traj = load_trajectory(out / "trajectory.npz")
    assert traj.stage_points.shape[1] == 3 and len(traj.stage_points) > 0
    assert main(["replay", str(out / "trajectory.npz"), "--out", str(back), "--no-video"]) == 0
    capsys.readouterr()
    snaps = sorted(out.glob("frame_*.png"))
    assert snaps and [p.name for p in snaps] == [p.name for p in sorted(back.glob("frame_*.png"))]
    for a in snaps:
        np.testing.assert_array_equal(pixels(a), pixels(back / a.name))
    # the stage is there: the floor and lights make the frame far from black
    assert pixels(snaps[0]).mean() > 40
