"""Portable scenes: limb effectors, targets placed relative to a limb, the bundled scenes
unchanged on the bundled humanoid, and the showcase on real humanoids (G1, Talos)."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik.cli.app import main
from humanoid_ik.config.placement import effector_chain
from humanoid_ik.config.scene import (
    bundled_scenes,
    bundled_scenes_dir,
    check_scene,
    load_scene,
    parse_scene,
)
from humanoid_ik.config.specs import EffectorSpec
from humanoid_ik.config.sweep_file import parse_sweep, target_set_chain
from humanoid_ik.core.limbs import find_limbs, limb_chain
from humanoid_ik.core.models import home_qpos, load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.errors import SceneError, SweepError
from humanoid_ik.outputs.stage import facing
from humanoid_ik.run.runner import SceneRunner
from tests.robots import g1_arm, robot_file

G1, TALOS = robot_file("g1"), robot_file("talos")

# The bundled scenes' targets as they were written in world coordinates (metres) before
# they were placed relative to the limbs: the reference the placed scenes must reproduce.
PATH = {
    "kind": "waypoints",
    "points": [[0.40, -0.35, 1.10], [0.42, -0.12, 1.28], [0.30, -0.20, 1.45], [0.35, -0.45, 1.35]],
    "speed": 0.2,
    "interpolation": "smooth",
    "loop": True,
}
CIRCLE = {"kind": "circle", "center": [0.42, -0.28, 1.32], "radius": 0.12, "normal": [1, 0, 0]}
EIGHT = {
    "kind": "figure8",
    "center": [0.40, 0.26, 1.15],
    "width": 0.26,
    "height": 0.14,
    "normal": [1, 0, 0],
}
OLD = {
    "both_hands": [
        {
            "kind": "lissajous",
            "center": [0.38, -0.32, 1.18],
            "amplitude": [0.0, 0.12, 0.10],
        },
        {
            "kind": "waypoints",
            "points": [
                [0.38, 0.22, 1.08],
                [0.38, 0.42, 1.08],
                [0.38, 0.42, 1.28],
                [0.38, 0.22, 1.28],
            ],
            "speed": 0.2,
        },  # noqa: E501
    ],
    "circle": [
        {"kind": "circle", "center": [0.40, -0.32, 1.20], "radius": 0.12, "normal": [1, 0, 0]}
    ],  # noqa: E501
    "figure8_pose": [
        {
            "kind": "figure8",
            "center": [0.42, -0.32, 1.20],
            "width": 0.30,
            "height": 0.16,
            "normal": [1, 0, 0],
        }
    ],
    "gaze": [{"kind": "lissajous", "center": [0.70, -0.20, 1.50], "amplitude": [0.0, 0.30, 0.15]}],
    "out_of_reach": [
        {"kind": "out_and_back", "start": [0.35, -0.30, 1.15], "far": [1.05, -0.40, 1.45]}
    ],
    "random_walk": [
        {
            "kind": "random_walk",
            "center": [0.32, 0.30, 1.22],
            "half_extent": [0.14, 0.14, 0.10],
            "step": 0.10,
        }
    ],
    "reach_points": [
        {
            "kind": "points",
            "points": [
                [0.45, -0.25, 1.05],
                [0.30, -0.30, 1.55],
                [0.50, -0.20, 1.35],
                [0.25, -0.45, 1.00],
            ],
        }
    ],  # noqa: E501
    "showcase": [CIRCLE, EIGHT],
    "upper_body_mink": [CIRCLE, EIGHT],
}
OLD_ORIENTATION = {"figure8_pose": {"quat": [0.7071068, 0.0, -0.7071068, 0.0], "axis": [0, 0, 1]}}
SITES = {"right_arm": "right_palm_site", "left_arm": "left_palm_site", "head": "gaze_site"}


def _old_doc(path: Path) -> dict:
    """The bundled scene at ``path`` as it was: world coordinates, site effectors."""
    doc = tomllib.loads(path.read_text())
    old = copy.deepcopy(doc)
    motions = OLD.get(path.stem, [PATH] if path.stem.startswith("compare_") else None)
    assert motions is not None, f"no reference for scene {path.stem}"
    for t, m in zip(old["targets"], motions, strict=True):
        t["motion"] = {**t["motion"], **m}  # the other keys (period, seed...) as they are
        if "orientation" in t:
            t["orientation"] = {**t["orientation"], **OLD_ORIENTATION[path.stem]}
    for e in old["effectors"]:
        e["site"] = SITES[e.pop("limb")]
    return old


def _scene(doc: dict, name: str = "x.toml", **kw):
    scene = parse_scene(doc, f"scenes/{name}", Path("scenes"), **kw)
    check_scene(scene)
    return scene


def _doc(motion: dict, **effector) -> dict:
    return {
        "duration": 1.0,
        "targets": [{"name": "t", "motion": motion}],
        "effectors": [{"target": "t", **(effector or {"limb": "right_arm"})}],
    }


# ----------------------------------------------------------------------------- limbs
def test_limb_effectors_are_the_limbs_chains_on_the_bundled_humanoid():
    scene = load_scene("showcase")
    model = load_model(None)
    profile = find_limbs(model)
    for eff, limb in zip(scene.effectors, ("right_arm", "left_arm", "head"), strict=True):
        assert eff.limb == limb
        assert eff.name == SITES[limb] and eff.kind == "site"
        assert eff.joints == profile.limb(limb).joints
    assert scene.notes == ()


def test_one_builder_makes_limb_site_and_torso_chains_on_g1():
    robot = Robot(load_model(G1))
    profile = find_limbs(robot.model)
    left = effector_chain(robot, EffectorSpec(None, "t", limb="left_arm"), profile)
    assert tuple(left.joint_names) == g1_arm("left")
    assert (left.ee_kind, left.ee_name) == ("body", "left_rubber_hand")
    torso = effector_chain(robot, EffectorSpec(None, "t", limb="left_arm", torso=True), profile)
    assert torso.joint_names[:3] == ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
    assert tuple(torso.joint_names[3:]) == g1_arm("left")
    site = effector_chain(robot, EffectorSpec(None, "t", body="left_rubber_hand"))
    assert site.joint_names[:3] == torso.joint_names[:3]  # the path rule reaches the waist
    assert left.robot is torso.robot is robot


# ----------------------------------------------------------------------------- placements
@pytest.mark.parametrize("model", [None, G1], ids=["humanoid", "g1"])
def test_placements_resolve_to_world_points_from_the_shoulder(model):
    m = load_model(model)
    data = mujoco.MjData(m)
    data.qpos[:] = home_qpos(m)
    mujoco.mj_kinematics(m, data)
    profile = find_limbs(m)
    first = profile.limb("right_arm").joints[0]
    shoulder = data.xanchor[m.joint(first).id].copy()  # the arm's first joint, at home
    reach = limb_chain(m, "right_arm", profile=profile).reach()[1]
    fwd = np.asarray(profile.forward)
    left = np.cross([0.0, 0.0, 1.0], fwd)
    assert np.allclose(fwd, [1.0, 0.0, 0.0]) and 0.4 < reach < 0.7
    doc = _doc(
        {"kind": "points", "points": {"limb": "right_arm", "at": [[0, 0, 0], [0.5, 0.25, -0.1]]}}
    )
    scene = _scene(doc, model=model)
    pts = scene.targets[0].motion.points
    assert np.allclose(pts[0], shoulder, atol=1e-12)  # at = [0, 0, 0] is the shoulder
    want = shoulder + reach * (0.5 * fwd + 0.25 * left - 0.1 * np.array([0.0, 0.0, 1.0]))
    assert np.allclose(pts[1], want, atol=1e-12)
    circle = {
        "kind": "circle",
        "center": {"limb": "right_arm", "at": [0.6, 0, 0]},
        "radius": {"limb": "right_arm", "reach": 0.2},
        "normal": {"robot": [0, 1, 0]},
    }
    c = _scene(_doc(circle), model=model).targets[0].motion
    assert c.radius == pytest.approx(0.2 * reach, abs=1e-15)
    assert np.allclose(c.normal, left) and np.allclose(c.center, shoulder + 0.6 * reach * fwd)


def test_head_placement_is_the_gaze_frame_sized_by_the_arms():
    doc = _doc({"kind": "points", "points": {"limb": "head", "at": [[0, 0, 0], [1, 0, 0]]}})
    pts = _scene(doc).targets[0].motion.points
    m = load_model(None)
    data = mujoco.MjData(m)
    data.qpos[:] = home_qpos(m)
    mujoco.mj_kinematics(m, data)
    gaze = data.site("gaze_site").xpos
    assert np.allclose(pts[0], gaze) and np.allclose(pts[1], gaze + [0.63, 0, 0])


def test_limb_lengths_and_orientations_in_the_robot_frame():
    walk = {
        "kind": "random_walk",
        "center": {"limb": "left_arm", "at": [0.5, 0, 0]},
        "half_extent": {"limb": "left_arm", "reach": [0.2, 0.1, 0.0]},
    }
    doc = _doc(walk, limb="left_arm")
    doc["targets"][0]["orientation"] = {
        "quat": {"robot": [0, 0, 0, 1]},
        "axis": {"robot": [0, 0, 1]},
    }
    t = _scene(doc).targets[0]
    assert np.allclose(t.motion.half_extent, [0.126, 0.063, 0.0])
    assert np.allclose(t.orientation.quat, [0, 0, 0, 1]) and np.allclose(
        t.orientation.axis, [0, 0, 1]
    )


# ----------------------------------------------------------------------------- bundled scenes
def test_every_bundled_scene_has_a_reference():
    assert len(bundled_scenes()) >= 18
    for p in bundled_scenes():
        assert p.stem in OLD or p.stem.startswith("compare_"), p.name
        doc = tomllib.loads(p.read_text())
        assert all("limb" in e for e in doc["effectors"]), p.name  # every effector by limb


@pytest.mark.parametrize("path", bundled_scenes(), ids=lambda p: p.stem)
def test_bundled_scene_gives_the_frames_it_gave_in_world_coordinates(path):
    new = load_scene(path)
    old = _scene(_old_doc(path), path.name)
    assert [e.name for e in new.effectors] == [e.name for e in old.effectors]
    assert [e.joints for e in new.effectors] == [tuple(c.joint_names) for c in check_scene(old)]
    times = np.arange(new.n_frames) / new.fps
    for a, b in zip(new.targets, old.targets, strict=True):
        assert np.abs(a.motion.positions(times) - b.motion.positions(times)).max() < 1e-8
        if a.orientation is not None:
            qa = [a.orientation.quat_at(t) for t in times]
            qb = [b.orientation.quat_at(t) for t in times]
            assert np.abs(np.array(qa) - np.array(qb)).max() < 1e-12
    frames = 60  # every third frame of the 30 fps scenes: warm starts over larger steps
    ra = SceneRunner(new.with_overrides(frames=frames)).run()
    rb = SceneRunner(old.with_overrides(frames=frames)).run()
    qa, qb = np.array(ra.qpos), np.array(rb.qpos)
    assert qa.shape == qb.shape == (frames, load_model(None).nq)
    assert np.abs(qa - qb).max() < 1e-6  # rad


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("mutate", "key", "words"),
    [
        (lambda d: d["effectors"][0].update(limb="torso"), "effectors[0].limb", "'right_arm'"),
        (lambda d: d["effectors"][0].update(joints=["a"]), "effectors[0].joints", "no joints"),
        (lambda d: d["effectors"][0].update(site="x"), "effectors[0].site", "site, limb"),
        (lambda d: d["effectors"][0].update(torso=1), "effectors[0].torso", "true or false"),
        (
            lambda d: d["targets"][0]["motion"].update(center={"at": [1, 0, 0]}),
            "targets[0].motion.center",
            "{ limb = NAME, at = [forward, left, up] }",
        ),
        (
            lambda d: d["targets"][0]["motion"].update(center={"limb": "leg", "at": [1, 0, 0]}),
            "targets[0].motion.center.limb",
            "'left_arm'",
        ),
        (
            lambda d: d["targets"][0]["motion"].update(radius={"limb": "right_arm", "reach": 0}),
            "targets[0].motion.radius",
            "> 0",
        ),
        (
            lambda d: d["targets"][0]["motion"].update(normal={"robot": [0, 0]}),
            "targets[0].motion.normal.robot",
            "a direction [x, y, z]",
        ),
        (lambda d: d.update(limbs="nowhere.toml"), "limbs", "not found"),
    ],
)
def test_bad_input_is_one_line_naming_the_key(mutate, key, words):
    doc = tomllib.loads((Path("scenes") / "circle.toml").read_text())
    mutate(doc)
    with pytest.raises(SceneError) as err:
        _scene(doc)
    text = str(err.value)
    assert "\n" not in text and f": {key}: " in text and words in text, text


def test_a_limb_the_model_lacks_names_the_model_limbs():
    doc = _doc({"kind": "points", "points": [[0.4, 0.0, 0.3]]}, limb="right_arm")
    with pytest.raises(
        SceneError,
        match=r"effectors\[0\]\.limb: expected a limb of the model "
        r"\(arm\), got 'right_arm'$",
    ):
        _scene(doc, model=robot_file("ur5"))
    doc = _doc({"kind": "points", "points": [[0.3, 0.0, 0.5]]}, limb="head")
    with pytest.raises(SceneError, match=r"effectors\[0\]\.limb: .*head is fixed"):
        _scene(doc, model=G1)  # a fixed head cannot reach


def test_sweep_target_set_by_limb():
    doc = {
        "solvers": ["dls"],
        "targets": [{"name": "g1_left", "n": 3, "limb": "left_arm", "model": str(G1)}],
    }
    job = parse_sweep(doc, "sweeps/x.toml").jobs[0]
    assert job.param["limb"] == "left_arm" and job.param["site"] is None
    chain = target_set_chain(load_model(G1), job.location, job.param)
    assert tuple(chain.joint_names) == g1_arm("left")
    doc["targets"][0]["model"] = str(robot_file("ur5"))
    with pytest.raises(SweepError, match=r"targets\[0\]\.limb: expected a limb of the model"):
        parse_sweep(doc, "sweeps/x.toml")


def test_stage_faces_the_profile_forward():
    icub = load_model(robot_file("icub"))
    profile = find_limbs(icub)
    assert profile.forward_from == "arms" and profile.forward[0] < -0.99  # iCub looks at -x
    assert np.allclose(facing((), None, profile), profile.forward)
    assert np.allclose(facing((), [[0.0, 0.5, 0.0]], None), [0.0, 1.0, 0.0])  # the cues


# ----------------------------------------------------------------------------- real humanoids
def _showcase(model: Path, frames: int = 30):
    scene = load_scene("showcase", model=model).with_overrides(frames=frames)
    runner = SceneRunner(scene)
    rec = runner.run()
    return scene, runner, rec


def _check_frames(scene, runner, rec, gaze: bool):
    m = runner.model
    for k, eff in enumerate(scene.effectors):
        samples = [f.samples[k] for f in rec.frames]
        reach = [s for s in samples if s.reachable]
        assert len(reach) >= 0.9 * len(samples)
        if eff.task == "reach":
            assert sum(s.on_target for s in reach) >= 0.99 * len(reach), eff.name
        else:
            assert gaze
            assert max(s.orientation_error for s in reach) < math.radians(1.0)
    lo, hi = m.jnt_range[:, 0], m.jnt_range[:, 1]
    for c in runner.chains:  # no joint of any chain out of its range, in any frame
        ids = c.joint_ids
        limited = m.jnt_limited[ids] != 0
        q = np.array(rec.qpos)[:, c.qpos_adr]
        assert np.all(q[:, limited] >= lo[ids][limited] - 1e-9)
        assert np.all(q[:, limited] <= hi[ids][limited] + 1e-9)


def test_showcase_on_g1_both_hands_and_a_fixed_head_said_once():
    scene, runner, rec = _showcase(G1)
    assert [e.limb for e in scene.effectors] == ["right_arm", "left_arm"]
    assert len(scene.notes) == 1 and "head is fixed" in scene.notes[0]
    assert "effectors[2]" in scene.notes[0]
    _check_frames(scene, runner, rec, gaze=False)


def test_showcase_on_talos_both_hands_and_the_gaze():
    scene, runner, rec = _showcase(TALOS)
    assert [e.name for e in scene.effectors] == [
        "gripper_right_base_link",
        "gripper_left_base_link",
        "head_2_link",
    ]
    assert scene.effectors[2].joints == ("head_1_joint", "head_2_joint")
    assert scene.notes == ()
    _check_frames(scene, runner, rec, gaze=True)


def test_both_arms_with_the_torso_share_it_in_one_qp_on_g1(tmp_path):
    """``torso = true`` on both arms: the waist is in both chains, which one solver that
    moves several effectors (mink) solves jointly: both hands on target, the waist
    moves, no joint out of range; a per-effector solver is refused in one line."""
    text = (bundled_scenes_dir() / "upper_body_mink.toml").read_text()
    for side in ("right", "left"):
        text = text.replace(f'limb = "{side}_arm"\n', f'limb = "{side}_arm"\ntorso = true\n')
    path = tmp_path / "torso.toml"
    path.write_text(text)
    scene = load_scene(path, model=G1).with_overrides(frames=20)
    chains = check_scene(scene)
    assert "waist_yaw_joint" in chains[0].joint_names and "waist_yaw_joint" in chains[1].joint_names
    runner = SceneRunner(scene)
    rec = runner.run()
    _check_frames(scene, runner, rec, gaze=False)
    waist = chains[0].qpos_adr[: list(chains[0].joint_names).index("waist_pitch_joint") + 1]
    assert np.ptp(np.array(rec.qpos)[:, waist], axis=0).max() > 0.05  # the torso helps
    dls = path.read_text().replace('name = "mink"', 'name = "dls"', 1)
    path.write_text(dls.replace('collision_pairs = "limbs"', "", 1))
    with pytest.raises(SceneError, match="joint 'waist_yaw_joint' is already moved by effectors"):
        check_scene(load_scene(path, model=G1))


def test_run_showcase_model_on_the_command_line(tmp_path, capsys):
    code = main(["run", "showcase", "--model", str(G1), "--frames", "6", "--out", str(tmp_path)])
    out = capsys.readouterr()
    assert code == 0
    assert out.err.count("head is fixed") == 1
    assert "right_rubber_hand -> circle" in out.out and "left_rubber_hand -> eight" in out.out
    assert (tmp_path / "trajectory.npz").is_file()


def test_gaze_scene_on_a_fixed_head_is_one_line():
    with pytest.raises(SceneError) as err:
        load_scene("gaze", model=G1)
    text = str(err.value)
    assert "\n" not in text
    assert text.endswith(
        ": effectors: expected an effector that can move; effectors[0]: the model's head is "
        "fixed (no joints to turn it): its look_at of 'fly' is left out"
    )
