"""Trajectories of scene runs on real MuJoCo: `run` and `render` write trajectory.npz/.csv,
both read back to the same typed Trajectory, the joint values reproduce the measured
positions through MuJoCo's forward kinematics, and bad files or models are refused in
one line."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.config.sweep_file import model_digest
from humanoid_ik.core.models import bundled_model_path, load_model
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.outputs.run_files import write_run
from humanoid_ik.outputs.trajectory import load_trajectory, write_trajectory
from humanoid_ik.run.runner import SceneRunner, frame_loop
from humanoid_ik.run.trajectory import Trajectory, check_trajectory_model, qpos_names

ARM7 = Path(__file__).resolve().parents[1] / "examples" / "urdf_arm" / "arm7.urdf"


@pytest.fixture(scope="module")
def showcase(tmp_path_factory):
    """The showcase scene (two hands and the gaze) run for 12 frames over its 6 s."""
    folder = tmp_path_factory.mktemp("showcase")
    scene = load_scene("showcase").with_overrides(frames=12)
    return scene, write_run(scene, folder)


@pytest.fixture(scope="module")
def posed(tmp_path_factory):
    """A scene with a pose target (figure8_pose), 6 frames."""
    folder = tmp_path_factory.mktemp("posed")
    return write_run(load_scene("figure8_pose").with_overrides(frames=6), folder)


def test_run_writes_both_files_and_they_agree(showcase):
    """trajectory.npz and trajectory.csv read back to identical trajectories."""
    _, out = showcase
    npz, csv = out.trajectory
    assert npz.name == "trajectory.npz" and csv.name == "trajectory.csv"
    a, b = load_trajectory(npz), load_trajectory(csv)
    assert a.n_frames == b.n_frames == 12
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.qpos, b.qpos)
    assert a.qpos_names == b.qpos_names and a.joint_names == b.joint_names
    for ea, eb in zip(a.effectors, b.effectors, strict=True):
        np.testing.assert_array_equal(ea.q, eb.q)
        np.testing.assert_array_equal(ea.target, eb.target)
        np.testing.assert_array_equal(ea.achieved, eb.achieved)
        np.testing.assert_array_equal(ea.position_error, eb.position_error)
        assert ea.status == eb.status and ea.solver == eb.solver


def test_trajectory_header(showcase):
    """Scene, files, the model digest, solvers, frame times and the joint names."""
    scene, out = showcase
    t = load_trajectory(out.trajectory[0])
    assert t.scene == "showcase" and t.scene_file == str(scene.path)
    assert t.model_file == str(bundled_model_path())
    assert t.model_sha256 == model_digest(bundled_model_path()) and len(t.model_sha256) == 16
    assert [e.solver for e in t.effectors] == ["dls", "dls", "look_at"]
    assert [e.site for e in t.effectors] == ["right_palm_site", "left_palm_site", "gaze_site"]
    assert [e.kind for e in t.effectors] == ["site", "site", "site"]
    assert t.fps == pytest.approx(2.0) and not t.interrupted
    np.testing.assert_allclose(t.time, np.arange(12) / 2.0)
    assert t.qpos.shape == (12, 16) and t.qpos_names[0] == "neck_yaw_joint"
    assert t.effectors[0].joints[0] == "right_shoulder_flexion_joint"
    assert t.effectors[2].joints == ("neck_yaw_joint", "neck_pitch_joint")
    assert t.render.camera == "front"


def test_a_body_effector_is_named_as_a_body(tmp_path):
    """A scene whose effector is a body (URDF arm's tool_link): both files' headers name
    it under ``body`` (no ``site``), it reads back as a body with the same columns, and
    a file written before the kind was kept (``site`` naming the body) still reads."""
    (tmp_path / "tool.toml").write_text(
        f"""name = "tool"
model = "{ARM7}"
duration = 0.1
fps = 30
[[targets]]
name = "p"
motion = {{ kind = "points", points = [[0.3, 0.2, 0.9]] }}
[[effectors]]
body = "tool_link"
target = "p"
"""
    )
    out = write_run(load_scene(tmp_path / "tool.toml"), tmp_path / "run")
    npz, csv = out.trajectory
    header = json.loads(csv.read_text().splitlines()[0][2:])
    assert header["effectors"][0]["body"] == "tool_link" and "site" not in header["effectors"][0]
    for path in (npz, csv):
        e = load_trajectory(path).effectors[0]
        assert (e.kind, e.site) == ("body", "tool_link")
    assert "tool_link.target_x" in csv.read_text().splitlines()[1].split(",")
    old = {
        **header,
        "effectors": [
            {
                "site": "tool_link",
                **{k: v for k, v in header["effectors"][0].items() if k != "body"},
            }
        ],
    }
    lines = csv.read_text().splitlines()
    legacy = tmp_path / "legacy.csv"
    legacy.write_text("# " + json.dumps(old) + "\n" + "\n".join(lines[1:]) + "\n")
    e = load_trajectory(legacy).effectors[0]
    assert (e.kind, e.site) == ("site", "tool_link")
    np.testing.assert_array_equal(e.achieved, load_trajectory(csv).effectors[0].achieved)
    with pytest.raises(TrajectoryFileError, match="kind: expected one of site, body, got 'camera'"):
        replace(load_trajectory(npz).effectors[0], kind="camera")


def test_chain_columns_are_the_qpos_columns(showcase):
    """Each effector's chain joints are the qpos columns of the same names."""
    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    for e in t.effectors:
        for k, name in enumerate(e.joints):
            np.testing.assert_array_equal(e.q[:, k], t.joint(name))


def test_qpos_reproduces_the_measured_positions(showcase):
    """MuJoCo FK of each recorded qpos puts the palms where the metrics measured them."""
    _, out = showcase
    t = load_trajectory(out.trajectory[1])
    model = load_model(t.model_file)
    data = mujoco.MjData(model)
    for i in range(t.n_frames):
        data.qpos[:] = t.qpos[i]
        mujoco.mj_kinematics(model, data)
        for e, samples in zip(t.effectors[:2], (0, 1), strict=True):
            np.testing.assert_allclose(data.site(e.site).xpos, e.achieved[i], atol=1e-12)
            rec = out.metrics.frames[i].samples[samples]
            np.testing.assert_array_equal(rec.achieved, e.achieved[i])
    assert np.ptp(t.effectors[0].target, axis=0).max() > 0.1


def test_statuses_and_flags_match_the_metrics(showcase):
    """Status, on-target and reachable flags per frame as the metrics have them."""
    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    for k, e in enumerate(t.effectors):
        assert list(e.status) == [f.samples[k].status for f in out.metrics.frames]
        assert e.on_target.tolist() == [f.samples[k].on_target for f in out.metrics.frames]
        assert e.reachable.tolist() == [f.samples[k].reachable for f in out.metrics.frames]
    assert all(e.on_target.all() for e in t.effectors)


def test_pose_target_orientation_is_recorded(posed):
    """A pose target's orientation (wxyz) is in both files, unit quaternions."""
    a, b = (load_trajectory(p) for p in posed.trajectory)
    quats = a.effectors[0].target_quat
    assert quats is not None and quats.shape == (6, 4)
    np.testing.assert_allclose(np.linalg.norm(quats, axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(quats, b.effectors[0].target_quat)
    scene = load_scene("figure8_pose").with_overrides(frames=6)
    np.testing.assert_allclose(quats[3], scene.targets[0].orientation.quat_at(a.time[3]))


def test_csv_columns(showcase):
    """The CSV: a JSON header line, then frame, time, every qpos name, effector columns."""
    _, out = showcase
    lines = out.trajectory[1].read_text().splitlines()
    header = json.loads(lines[0][2:])
    assert header["format"] == "humanoid-ik trajectory" and header["version"] == 1
    cols = lines[1].split(",")
    assert cols[:3] == ["frame", "time_s", "neck_yaw_joint"]
    assert "right_palm_site.target_x" in cols and "gaze_site.status" in cols
    assert len(lines) == 2 + 12


def test_render_writes_the_trajectory_too(tmp_path):
    """A render (one sink more in the same loop) writes the trajectory of its frames."""
    from humanoid_ik.outputs.render import render_scene

    scene = load_scene("circle").with_overrides(frames=3, width=32, height=24)
    out = render_scene(scene, tmp_path, video=False, plot=False)
    assert [p.name for p in out.trajectory] == ["trajectory.npz", "trajectory.csv"]
    assert all(p in out.files() for p in out.trajectory)
    t = load_trajectory(out.trajectory[0])
    assert t.n_frames == 3
    np.testing.assert_array_equal(
        t.effectors[0].achieved[2], out.metrics.frames[2].samples[0].achieved
    )


def test_interrupted_run_keeps_its_frames(tmp_path):
    """Ctrl-C in the loop: the trajectory holds the frames every sink took and says it
    was cut."""
    scene = load_scene("circle").with_overrides(frames=10)
    runner = SceneRunner(scene)

    class Stop:
        def add_frame(self, frame, data):
            if frame.index == 3:
                raise KeyboardInterrupt

    recording = runner.run(sinks=[Stop()])
    t = recording.trajectory()
    assert t.interrupted and t.n_frames == 3 == len(recording)
    write_trajectory(t, tmp_path)
    back = load_trajectory(tmp_path / "trajectory.npz")
    assert back.interrupted and back.n_frames == 3


@pytest.mark.parametrize("suffix", ["npz", "csv"])
def test_a_trajectory_file_gives_back_every_sample_of_the_run(tmp_path, suffix):
    """One recording per run: what the files hold turns back into the run's frames,
    field for field (iterations, solve time, limit margin and orientation error were
    lost on the way back before)."""
    scene = load_scene("figure8_pose").with_overrides(frames=6)
    recording = SceneRunner(scene).run()
    write_trajectory(recording.trajectory(), tmp_path)
    back = load_trajectory(tmp_path / f"trajectory.{suffix}")
    for i, frame in enumerate(recording.frames):
        assert _same_frame(back.frame_samples(i), frame)
    assert any(s.orientation_error is not None for s in recording.frames[0].samples)
    assert all(s.iterations > 0 for f in recording.frames for s in f.samples[:1])


def _same_frame(a, b) -> bool:
    assert a.index == b.index and a.time == b.time
    for x, y in zip(a.samples, b.samples, strict=True):
        for name in x._fields:
            u, v = getattr(x, name), getattr(y, name)
            if isinstance(u, np.ndarray):
                np.testing.assert_array_equal(u, v)
            else:
                assert u == v, name
    return True


def test_frame_loop_stop():
    """The frame loop asks `stop` before each frame and ends there."""
    seen = []
    times, interrupted = frame_loop(10, seen.append, None, [], stop=lambda: len(seen) >= 4)
    assert seen == [0, 1, 2, 3] and len(times) == 4 and not interrupted


def test_model_check(showcase, tmp_path):
    """Other joints, another order, or another digest are refused naming the difference."""
    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    model = load_model(None)
    check_trajectory_model(t, model, model_digest(bundled_model_path()))
    other = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><joint name="j"/><geom size=".1"/></body></worldbody></mujoco>'
    )
    with pytest.raises(TrajectoryFileError, match="joints neck_yaw_joint, .* not in the model"):
        check_trajectory_model(t, other, None)
    shuffled = replace(t, qpos_names=t.qpos_names[::-1])
    with pytest.raises(TrajectoryFileError, match="another order"):
        check_trajectory_model(shuffled, model, None)
    with pytest.raises(TrajectoryFileError, match="another version .* pass the model"):
        check_trajectory_model(t, model, "0123456789abcdef")


def test_qpos_names_of_free_and_ball_joints():
    """A free joint has 7 named qpos entries, a ball joint 4, a hinge 1."""
    m = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint name='f'/><geom size='.1'/>"
        "<body><joint name='b' type='ball'/><geom size='.1'/>"
        "<body><joint name='h'/><geom size='.1'/></body></body></body></worldbody></mujoco>"
    )
    names = qpos_names(m)
    assert len(names) == m.nq == 12
    assert names[:3] == ["f:x", "f:y", "f:z"] and names[7:11] == ["b:qw", "b:qx", "b:qy", "b:qz"]
    assert names[11] == "h"


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: d / "missing.npz", "does not exist"),
        (lambda d: (d / "x.txt").write_text("x") and d / "x.txt", "neither .npz nor .csv"),
        (lambda d: (d / "x.npz").write_text("no zip") and d / "x.npz", "cannot read trajectory"),
        (lambda d: (d / "x.csv").write_text("a,b\n1,2\n") and d / "x.csv", "not a humanoid-ik"),
    ],
)
def test_bad_files(tmp_path, make, message):
    """A missing, foreign or broken file: one line naming it."""
    with pytest.raises(TrajectoryFileError, match=message) as err:
        load_trajectory(make(tmp_path))
    assert "\n" not in str(err.value)


def test_other_version_and_missing_column(showcase, tmp_path):
    """A newer version is named; a CSV without one of its columns names the column."""
    _, out = showcase
    lines = out.trajectory[1].read_text().splitlines()
    header = json.loads(lines[0][2:])
    newer = tmp_path / "newer.csv"
    newer.write_text("# " + json.dumps({**header, "version": 2}) + "\n" + "\n".join(lines[1:]))
    with pytest.raises(TrajectoryFileError, match="version 2; this humanoid-ik reads version 1"):
        load_trajectory(newer)
    cut = tmp_path / "cut.csv"
    rows = [",".join(r.split(",")[:-1]) for r in lines[1:]]  # drop the last column
    cut.write_text(lines[0] + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(TrajectoryFileError, match="lacks column 'gaze_site.limit_margin_rad'"):
        load_trajectory(cut)


def test_shapes_are_checked(showcase):
    """A Trajectory whose arrays disagree in shape is refused naming the array."""
    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    with pytest.raises(TrajectoryFileError, match=r"qpos: expected shape \(12, 16\)"):
        Trajectory(**{**t.__dict__, "qpos": t.qpos[:, :3]})
    with pytest.raises(TrajectoryFileError, match="fps: expected a number > 0"):
        Trajectory(**{**t.__dict__, "fps": 0.0})


def test_run_command(tmp_path, capsys):
    """`run` writes the metrics and the trajectory and prints one line per effector."""
    out = tmp_path / "o"
    assert main(["run", "showcase", "--frames", "6", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("showcase: 6 frame(s) at 1 frames/s")
    assert "right_palm_site -> circle (dls): reachable 6/6" in text
    for name in ("metrics.csv", "metrics.json", "trajectory.npz", "trajectory.csv"):
        assert (out / name).is_file() and f"wrote {out / name}" in text
    assert not list(out.glob("*.mp4")) and not list(out.glob("*.png"))
    t = load_trajectory(out / "trajectory.npz")
    assert t.n_frames == 6 and t.time[-1] == pytest.approx(5.0)


def test_run_command_until(tmp_path, capsys):
    """`--until 2 --frames 4` runs 4 frames over the first 2 s."""
    out = tmp_path / "o"
    assert main(["run", "circle", "--until", "2", "--frames", "4", "--out", str(out)]) == 0
    t = load_trajectory(out / "trajectory.csv")
    np.testing.assert_allclose(t.time, [0.0, 0.5, 1.0, 1.5])


def test_run_command_bad_input(tmp_path, capsys):
    """Bad input to `run`: exit 2, one line, no file."""
    out = tmp_path / "o"
    assert main(["run", "circle", "--until", "9", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--until 9 is after the end of scene 'circle' (4 s)" in err
    assert not out.exists()


def test_copied_trajectory_is_still_found(showcase, tmp_path):
    """A trajectory copied elsewhere still names its model by path and reads the same."""
    _, out = showcase
    copy = tmp_path / "t.npz"
    shutil.copy(out.trajectory[0], copy)
    assert Path(load_trajectory(copy).model_file) == bundled_model_path()


def test_more_refusals(showcase, tmp_path):
    """Unknown joint name, an archive without header or with a header lacking a key,
    effectors of another length, a model file that is gone: one line each."""
    from humanoid_ik.outputs.trajectory import open_trajectory

    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    with pytest.raises(TrajectoryFileError, match="joint 'knee' not in trajectory; joints: neck_"):
        t.joint("knee")
    bare = tmp_path / "bare.npz"
    np.savez(bare, time=np.zeros(2))
    with pytest.raises(TrajectoryFileError, match="is not a humanoid-ik trajectory file"):
        load_trajectory(bare)
    with np.load(out.trajectory[0]) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))
    del header["fps"]
    partial = tmp_path / "partial.npz"
    np.savez(partial, **{**arrays, "header": np.array(json.dumps(header))})
    with pytest.raises(TrajectoryFileError, match="fps: missing; expected a number >= 0.01"):
        load_trajectory(partial)
    with pytest.raises(TrajectoryFileError, match=r"effector 'right_palm_site' q: expected"):
        replace(t.effectors[0], status=t.effectors[0].status[:3])
    with pytest.raises(TrajectoryFileError, match="on_target: expected shape"):
        replace(t.effectors[0], on_target=t.effectors[0].on_target[:3])
    with pytest.raises(TrajectoryFileError, match="has 3 frame.*the trajectory has 12"):
        replace(t, effectors=(_cut(t.effectors[0], 3),))
    header = {**json.loads(str(arrays["header"])), "model_file": str(tmp_path / "gone.xml")}
    moved = tmp_path / "moved.npz"
    np.savez(moved, **{**arrays, "header": np.array(json.dumps(header))})
    with pytest.raises(TrajectoryFileError, match="gone.xml' of trajectory .* does not exist"):
        open_trajectory(moved)


def _cut(track, n):
    """An effector track cut to its first ``n`` frames."""
    return replace(
        track,
        q=track.q[:n],
        target=track.target[:n],
        target_quat=None if track.target_quat is None else track.target_quat[:n],
        achieved=track.achieved[:n],
        position_error=track.position_error[:n],
        on_target=track.on_target[:n],
        reachable=track.reachable[:n],
        status=track.status[:n],
        orientation_error=track.orientation_error[:n],
        iterations=track.iterations[:n],
        solve_time=track.solve_time[:n],
        limit_margin=track.limit_margin[:n],
    )


def test_the_former_names_of_the_recording_warn_and_still_work():
    """``Metrics`` and ``TrajectoryRecorder`` (deprecated for one release) name the
    recording: a ``TrajectoryRecorder`` sink handed to a run records what the run's own
    recording does."""
    import humanoid_ik.run.metrics as metrics
    import humanoid_ik.run.trajectory as trajectory
    from humanoid_ik.run.recording import Recording

    with pytest.warns(DeprecationWarning, match=r"run\.recording\.Recording"):
        assert metrics.Metrics is Recording
    scene = load_scene("circle").with_overrides(frames=4)
    runner = SceneRunner(scene)
    with pytest.warns(DeprecationWarning, match="TrajectoryRecorder is deprecated"):
        old = trajectory.TrajectoryRecorder(
            scene, runner.model, runner.chains, runner.targets, runner.solver_labels()
        )
    recording = runner.run(sinks=[old])
    np.testing.assert_array_equal(old.trajectory().qpos, recording.trajectory().qpos)
    assert old.trajectory().n_frames == 4


def test_the_former_record_names_warn_and_give_the_new_objects(tmp_path):
    """ "Record" named three things; the former names stay for one release, each use with
    a ``DeprecationWarning`` naming the new name, pointing at the line that used it, and
    giving the new object: ``FrameRecord`` is ``FrameSamples``, ``Trajectory.record`` is
    ``Trajectory.frame_samples``, and every name of ``outputs.record`` is
    ``outputs.run_files``' (``record_scene``: ``write_run``)."""
    import humanoid_ik.outputs.record as record
    import humanoid_ik.outputs.run_files as run_files
    import humanoid_ik.run.metrics as metrics

    with pytest.warns(
        DeprecationWarning, match=r"FrameRecord is deprecated; use .*FrameSamples"
    ) as said:
        assert metrics.FrameRecord is metrics.FrameSamples
    assert said[0].filename == __file__
    with pytest.warns(DeprecationWarning, match=r"run_files\.write_run"):
        from humanoid_ik.outputs.record import record_scene
    assert record_scene is run_files.write_run
    for name in [n for n in run_files.__all__ if n != "write_run"]:
        with pytest.warns(
            DeprecationWarning, match=rf"use humanoid_ik\.outputs\.run_files\.{name}$"
        ):
            assert getattr(record, name) is getattr(run_files, name)
    with pytest.raises(AttributeError, match="no attribute 'write_run'"):
        record.write_run  # noqa: B018 - only the old names resolve there

    recording = SceneRunner(load_scene("circle").with_overrides(frames=3)).run()
    traj = recording.trajectory()
    with pytest.warns(DeprecationWarning, match=r"Trajectory\.frame_samples") as said:
        old = traj.record(2)
    assert said[0].filename == __file__
    assert isinstance(old, metrics.FrameSamples) and old.index == 2
    assert _same_frame(old, traj.frame_samples(2)) and _same_frame(old, recording.frames[2])


def test_a_site_and_a_body_of_one_name_keep_their_own_columns(showcase, tmp_path):
    """Two effectors named alike (a site and a body ``right_palm_site``): the CSV tells
    their columns apart (``site:right_palm_site.``, ``body:right_palm_site.``) and
    reads each back as its own, as the npz does; a CSV written before, with both under
    ``right_palm_site.``, still reads right, by the columns' positions."""
    _, out = showcase
    t = load_trajectory(out.trajectory[0])
    site = t.effectors[0]
    body = replace(site, kind="body", target_name="other", target=site.target + 0.25)
    twin = replace(t, effectors=(site, body))
    npz, csv_path = write_trajectory(twin, tmp_path)
    names = csv_path.read_text().splitlines()[1].split(",")
    assert "site:right_palm_site.target_x" in names and "body:right_palm_site.target_x" in names
    assert len(set(names)) == len(names)
    legacy = tmp_path / "legacy.csv"
    text = csv_path.read_text().replace("site:right_palm_site.", "right_palm_site.")
    legacy.write_text(text.replace("body:right_palm_site.", "right_palm_site."))
    for path in (npz, csv_path, legacy):
        back = load_trajectory(path)
        assert [e.kind for e in back.effectors] == ["site", "body"]
        np.testing.assert_array_equal(back.effectors[0].target, site.target)
        np.testing.assert_array_equal(back.effectors[1].target, site.target + 0.25)
        assert back.effectors[1].target_name == "other"
