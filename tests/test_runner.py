"""The scene runner on real MuJoCo: every bundled scene tracks its reachable targets within
1 mm, the reachability flag follows the workspace, and metrics come from MjData."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace
from typing import ClassVar

import mujoco
import numpy as np
import pytest

from humanoid_ik.config.scene import SolverSpec, bundled_scenes, load_scene
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.measures import ON_TARGET_DISTANCE, gaze_error
from humanoid_ik.core.types import EffectorGoal
from humanoid_ik.errors import HumanoidIKError, SceneError
from humanoid_ik.outputs.atomic import atomic_path, write_json, write_text
from humanoid_ik.run.runner import (
    SceneRunner,
    chain_reach,
    run_scene,
)
from humanoid_ik.solvers import SOLVERS
from humanoid_ik.solvers.jacobian.dls import DLS

SHOULDER_R = np.array([0.0, -0.19, 1.40])
ARM_REACH = 0.30 + 0.25 + 0.08  # upper arm + forearm + wrist to palm site [m]


@pytest.fixture(scope="module")
def runs():
    """Every bundled scene run in full (no rendering)."""
    return {p.stem: run_scene(p) for p in bundled_scenes()}


def test_chain_reach_of_the_arm(right_arm):
    """The arm's base is the shoulder and its reach 0.30 + 0.25 + 0.08 = 0.63 m."""
    base, reach = chain_reach(right_arm)
    np.testing.assert_allclose(base, SHOULDER_R, atol=1e-12)
    assert reach == pytest.approx(ARM_REACH, abs=1e-12)


def test_every_scene_reaches_its_reachable_targets_within_1mm(runs):
    """Every bundled scene keeps each reachable target within 1 mm once converged.

    Once an effector has converged (its first frame on target), on every later frame
    where the target is within reach the site measured on MjData is within 1 mm of it
    (pose targets: and within 0.01 rad). Solvers that track under a velocity limit take
    a few frames to get there from home; the others converge on frame 0."""
    for name, m in runs.items():
        assert len(m) == m.scene.n_frames
        for k, eff in enumerate(m.scene.effectors):
            err = m.series(k, "position_error")
            reach = m.series(k, "reachable").astype(bool)
            on = m.series(k, "on_target").astype(bool)
            assert on.any(), (name, eff.site)
            first = int(np.argmax(on))
            rate_limited = m.scene.solver.options.get("dt", 0.0) > 0.0
            assert first == 0 or (rate_limited and first <= 10), (name, eff.site, first)
            reach[:first] = False
            assert reach.any(), name
            assert err[reach].max() < 1e-3, (name, eff.site, err[reach].max())
            if m.scene.target(eff.target).is_pose:
                ang = m.series(k, "orientation_error")
                assert ang[reach].max() < 1e-2, (name, ang[reach].max())
            assert m.series(k, "on_target")[reach].all(), name


def test_metrics_are_measured_on_mjdata():
    """Metrics are read from MjData, not from the solver.

    Achieved position is MjData's site_xpos after mj_forward, the error its distance to
    the target, the limit margin Chain.limit_margin of the applied joints."""
    sc = load_scene("both_hands")
    run = SceneRunner(sc)
    for i in range(5):
        rec = run.step(i)
        for k, s in enumerate(rec.samples):
            sid = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_SITE, s.effector)
            np.testing.assert_array_equal(s.achieved, run.data.site_xpos[sid])
            assert s.position_error == pytest.approx(np.linalg.norm(s.target - s.achieved))
            chain = run.chains[k]
            q = run.data.qpos[chain.qpos_adr]
            assert s.limit_margin == pytest.approx(chain.limit_margin(q))
            np.testing.assert_allclose(s.target, sc.target(s.target_name).motion.position(rec.time))
        assert rec.time == pytest.approx(i / sc.fps)
        assert rec.solve_time == pytest.approx(sum(s.solve_time for s in rec.samples))


def test_fk_of_the_written_qpos_matches(runs):
    """An independent FK of the last frame's joints puts the palm where the metrics say.

    The joints written for the last frame put the palm (by an independent Chain FK)
    where the metrics say."""
    m = runs["circle"]
    sc = m.scene
    run = SceneRunner(sc)
    for i in range(sc.n_frames):
        run.step(i)
    chain = Chain(None, "right_palm_site")
    p, _ = chain.fk(run.q[0])
    np.testing.assert_allclose(p, m.frames[-1].samples[0].achieved, atol=1e-12)


def test_warm_start_keeps_the_arm_continuous(runs):
    """Warm starts keep the circle cheap and the arm continuous.

    Warm-started from the previous frame, the circle costs at most 5 iterations per frame
    after the first and no joint moves more than 0.1 rad between frames."""
    m = runs["circle"]
    it = m.series(0, "iterations")
    assert it[1:].max() <= 5
    sc = m.scene
    run = SceneRunner(sc)
    prev = run.q[0].copy()
    for i in range(sc.n_frames):
        run.step(i)
        if i > 0:
            assert np.abs(run.q[0] - prev).max() < 0.1
        prev = run.q[0].copy()


def test_unreachable_flag_follows_the_workspace(runs):
    """The reachable flag is false exactly while the target is beyond the arm's reach.

    out_of_reach: the flag is false exactly while the target is farther than 0.63 m
    from the shoulder, it is set and cleared again, and the arm recovers to 1 mm."""
    m = runs["out_of_reach"]
    reach = m.series(0, "reachable").astype(bool)
    targets = np.array([f.samples[0].target for f in m.frames])
    dist = np.linalg.norm(targets - SHOULDER_R, axis=1)
    np.testing.assert_array_equal(reach, dist <= ARM_REACH)
    assert reach[0] and not reach.all() and reach[-1]
    first_out = int(np.argmin(reach))
    back = first_out + int(np.argmax(reach[first_out:]))
    assert back > first_out
    err = m.series(0, "position_error")
    assert err[back:].max() < ON_TARGET_DISTANCE
    assert not m.series(0, "on_target")[~reach].any()


def test_arm_points_at_the_target_out_of_reach(runs):
    """Out of reach, the arm stretches and points at the target.

    While the target is out of reach the arm is stretched (palm > 0.6 m from the
    shoulder) and points at it (within 0.1 degree)."""
    m = runs["out_of_reach"]
    for f in m.frames:
        s = f.samples[0]
        if s.reachable:
            continue
        hand, tgt = s.achieved - SHOULDER_R, s.target - SHOULDER_R
        assert np.linalg.norm(hand) > 0.6
        cos = hand @ tgt / (np.linalg.norm(hand) * np.linalg.norm(tgt))
        assert math.degrees(math.acos(min(1.0, cos))) < 0.1


def test_gaze_points_the_x_axis_at_the_target():
    """The gaze site's x axis points at the target, and the gaze point lies on it.

    gaze: every frame the gaze site's x axis points at the target within 1e-5 rad and
    the achieved gaze point lies on that axis at the target's distance."""
    sc = load_scene("gaze")
    run = SceneRunner(sc)
    sid = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_SITE, "gaze_site")
    for i in range(0, sc.n_frames, 7):
        s = run.step(i).samples[0]
        p, x = run.data.site_xpos[sid], run.data.site_xmat[sid].reshape(3, 3)[:, 0]
        v = s.target - p
        ang = math.acos(min(1.0, float(x @ v) / float(np.linalg.norm(v))))
        assert ang < 1e-5 and s.orientation_error == pytest.approx(ang, abs=1e-8)
        np.testing.assert_allclose(s.achieved, p + np.linalg.norm(v) * x, atol=1e-12)
        assert s.reachable and s.on_target


def test_solver_override_and_effector_solver():
    """--solver replaces the scene's solver for reaching effectors; the gaze keeps look_at."""
    sc = load_scene("showcase").with_overrides(solver="ccd")
    run = SceneRunner(sc)
    assert [s.name for s in run.specs] == ["ccd", "ccd", "look_at"]
    assert run.solver_labels() == ["ccd", "ccd", "look_at"]


def test_interrupt_keeps_the_frames_so_far():
    """Ctrl-C during run() returns the frames so far with `interrupted` set."""
    run = SceneRunner(load_scene("circle"))

    def stop(rec):
        if rec.index == 4:
            raise KeyboardInterrupt

    m = run.run(on_frame=stop)
    assert m.interrupted and len(m) == 5


class _Recorder:
    """A frame sink that keeps each record and the right palm's position on the data it is
    handed; raises ``error`` at frame ``stop_at``."""

    def __init__(self, stop_at=None, error=None):
        self.records, self.palms = [], []
        self.stop_at, self.error = stop_at, error

    def add_frame(self, record, data):
        if record.index == self.stop_at:
            raise self.error
        self.records.append(record)
        self.palms.append(data.site("right_palm_site").xpos.copy())


def test_sinks_take_every_frame_with_its_data():
    """run() hands each frame's record and MjData at that frame to every sink, in order.

    The sinks see the same records as the returned metrics, the data at that frame (the
    palm where the record says), and the metrics get one loop time per frame."""
    run = SceneRunner(load_scene("circle"))
    a, b = _Recorder(), _Recorder()
    m = run.run(frames=7, sinks=[a, b])
    assert a.records == b.records == m.frames and [r.index for r in m.frames] == list(range(7))
    for rec, palm in zip(a.records, a.palms, strict=True):
        np.testing.assert_array_equal(palm, rec.samples[0].achieved)
    assert len(m.frame_times) == 7 and all(t > 0 for t in m.frame_times)
    assert not m.interrupted


def test_ctrl_c_in_a_sink_keeps_the_frames_before_it():
    """Ctrl-C inside a sink at frame 4 returns frames 0-3 with `interrupted` set.

    The metrics are the last sink: a frame interrupted while an output takes it is not
    counted, so every output holds at least the frames the metrics report."""
    run = SceneRunner(load_scene("circle"))
    sink = _Recorder(stop_at=4, error=KeyboardInterrupt())
    m = run.run(sinks=[sink])
    assert m.interrupted and len(m) == 4 and len(sink.records) == 4


def test_an_error_in_a_sink_propagates():
    """Any exception from a sink other than Ctrl-C leaves run() unchanged."""
    run = SceneRunner(load_scene("circle"))
    with pytest.raises(OSError, match="disk full"):
        run.run(sinks=[_Recorder(stop_at=2, error=OSError("disk full"))])


def test_csv_and_json_round_trip(tmp_path, runs):
    """The metrics CSV and JSON hold the documented columns and the same samples.

    The CSV has one row per frame and effector with the documented columns; the JSON
    holds the scene, the summary and the same samples."""
    m = runs["both_hands"]
    c = write_text(tmp_path / "m.csv", m.csv_text())
    j = write_json(tmp_path / "m.json", m.to_dict())
    rows = list(csv.DictReader(c.open()))
    assert len(rows) == 2 * len(m)
    assert rows[1]["effector"] == "left_palm_site" and rows[1]["frame"] == "0"
    assert float(rows[3]["position_error_m"]) == pytest.approx(
        m.frames[1].samples[1].position_error
    )
    assert rows[0]["reachable"] == "True" and rows[0]["orientation_error_rad"] == ""
    doc = json.loads(j.read_text())
    assert doc["scene"] == "both_hands" and doc["frames"] == len(m)
    assert [e["solver"] for e in doc["effectors"]] == ["dls(restarts=0)", "dls(restarts=0)"]
    assert doc["summary"][0]["reachable_frames"] == len(m)
    assert doc["summary"][0]["max_position_error_reachable_m"] < 1e-3
    assert len(doc["samples"]) == 2 * len(m)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.csv", "m.json"]


def test_atomic_path_leaves_nothing_on_failure(tmp_path):
    """A failed write leaves neither the file nor a temporary; a good one only the file."""
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("disk full")
    assert list(tmp_path.iterdir()) == []
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".out.")
        tmp.write_text("whole")
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]
    assert target.read_text() == "whole"


def test_bad_model_path_is_a_scene_error(tmp_path):
    """A scene whose model file vanished fails with a SceneError at the model key."""
    sc = replace(load_scene("circle"), model=tmp_path / "gone.xml")
    with pytest.raises(SceneError, match=r"model: model file '.*gone.xml' does not exist"):
        SceneRunner(sc)


class _Joint(DLS):
    """A multi-effector solver for the hook test: records each call, solves by DLS."""

    name: ClassVar[str] = "joint_test"
    solves_effectors: ClassVar[bool] = True
    calls: ClassVar[list[list[str]]] = []

    def solve_effectors(self, goals):
        type(self).calls.append([g.task for g in goals])
        assert all(isinstance(g, EffectorGoal) for g in goals)
        return [
            SOLVERS["look_at"]().solve(g.chain, g.target, g.q0)
            if g.task == "look_at"
            else self.solve(g.chain, g.target, g.q0)
            for g in goals
        ]


def test_multi_effector_hook(monkeypatch):
    """A multi-effector solver gets all its effectors in one call per frame.

    A solver with solve_effectors gets every effector that uses it in one call per
    frame, look_at effectors included, and its results are applied and measured."""
    monkeypatch.setitem(SOLVERS, "joint_test", _Joint)
    _Joint.calls.clear()
    sc = load_scene("showcase").with_overrides(solver=SolverSpec("joint_test", {"restarts": 0}))
    run = SceneRunner(sc)
    m = run.run(frames=6)
    assert _Joint.calls == [["reach", "reach", "look_at"]] * 6
    for k in range(3):
        assert m.series(k, "position_error").max() < 1e-3
    t = m.series(0, "solve_time")
    np.testing.assert_allclose(t, m.series(2, "solve_time"))  # split equally


def test_multi_effector_result_count_is_checked(monkeypatch):
    """A multi-effector solver returning the wrong number of results is an error."""

    class Short(_Joint):
        name: ClassVar[str] = "short_test"

        def solve_effectors(self, goals):
            return super().solve_effectors(goals)[:1]

    monkeypatch.setitem(SOLVERS, "short_test", Short)
    sc = load_scene("both_hands").with_overrides(solver=SolverSpec("short_test", {"restarts": 0}))
    with pytest.raises(HumanoidIKError, match=r"returned 1 results for 2 effectors"):
        SceneRunner(sc).step(0)


@pytest.mark.skipif("mink" not in SOLVERS, reason="the mink solver is not registered")
def test_mink_moves_both_hands_and_gaze_together():
    """mink solves the showcase's hands and gaze in one call and tracks them to 1 mm.

    With mink, the showcase's two hands and gaze are solved in one call and tracked to
    1 mm."""
    sc = load_scene("showcase").with_overrides(solver="mink", frames=10)
    run = SceneRunner(sc)
    assert [members for _, members in run.solvers] == [(0, 1, 2)]
    m = run.run()
    for k in range(3):
        assert m.series(k, "position_error").max() < 1e-3


def test_solvers_are_prepared_before_the_first_frame():
    """The runner has each solver build its per-chain data (the seed library) when it is
    made, so no frame's solve time pays for it."""
    run = SceneRunner(load_scene("circle").with_overrides(solver=SolverSpec("dls", {})))

    def built_again(chain):
        raise AssertionError("the seed library was not built before the run")

    lib = run.chains[0].derived(("seed_library", 4000, 7), built_again)
    assert lib.q.shape == (4000, run.chains[0].n)


def test_gaze_errors_are_the_gaze_measure_of_the_frame():
    """A look_at effector's errors are its result's, and they are the gaze measure of the
    frame the run shows: gaze_error of the gaze site on the frame's MjData, to the bit;
    its gaze point lies on the site's x axis at the target's distance."""
    sc = load_scene("showcase")
    run = SceneRunner(sc)
    sid = mujoco.mj_name2id(run.model, mujoco.mjtObj.mjOBJ_SITE, "gaze_site")
    x = np.array([1.0, 0.0, 0.0])
    for i in range(0, sc.n_frames, 11):
        s = run.step(i).samples[2]
        assert s.task == "look_at"
        p, R = run.data.site_xpos[sid], run.data.site_xmat[sid]
        miss, angle = gaze_error(p, R, x, s.target)
        assert (s.position_error, s.orientation_error) == (miss, angle)
        assert type(s.position_error) is float and type(s.orientation_error) is float
        v = s.target - p
        np.testing.assert_allclose(s.achieved, p + np.linalg.norm(v) * R.reshape(3, 3)[:, 0])


def test_effectors_on_one_target_share_its_position():
    """The showcase's right hand and gaze track one target: each frame it moves once, both
    samples hold its position, which is the motion's at the frame's time, to the bit."""
    sc = load_scene("showcase")
    m = SceneRunner(sc).run(frames=40)
    motion = sc.target("circle").motion
    for f in m.frames:
        hand, _, gaze = f.samples
        assert hand.target_name == gaze.target_name == "circle"
        assert hand.target is gaze.target and not hand.target.flags.writeable
        np.testing.assert_array_equal(hand.target, motion.position(f.time))


def test_limit_margin_is_the_nearest_range_end():
    """Each sample's limit margin is the smallest distance of the chain's joints (as the
    frame applied them) to a range end, to the bit: min(q - lower, upper - q)."""
    run = SceneRunner(load_scene("both_hands"))
    for i in range(0, 180, 13):
        rec = run.step(i)
        for k, s in enumerate(rec.samples):
            chain = run.chains[k]
            q = run.data.qpos[chain.qpos_adr]
            want = float(np.min(np.minimum(q - chain.lower, chain.upper - q)))
            assert s.limit_margin == want and 0.0 < want < math.pi


def test_solvers_lists_each_solver_with_its_effectors():
    """One solver object per distinct spec: the showcase's hands share one dls (each
    solved alone), the gaze has look_at."""
    run = SceneRunner(load_scene("showcase"))
    (a, ia), (b, ib), (c, ic) = run.solvers
    assert (ia, ib, ic) == ((0,), (1,), (2,))
    assert a is b and a.name == "dls" and c.name == "look_at"
