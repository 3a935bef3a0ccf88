"""The film of a retargeting (``outputs/render/skeleton.py``): the human skeleton placed
as the retargeting maps it (its arms point where the robot's hands are sent, scaled by
the arm lengths), beside the robot and clear of it, filmed with the robot from the
front: the frames, the skeleton's colour on the robot's right (the picture's left), the
robot on the other side, the snapshots and contact sheet; bad input in one line."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from PIL import Image

from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.models import load_model, model_file
from humanoid_ik.errors import MotionError, TrajectoryFileError
from humanoid_ik.experiments.retarget import find_human, retarget
from humanoid_ik.experiments.retarget.robot import RobotSide
from humanoid_ik.motion.bvh import read_bvh
from humanoid_ik.motion.human import human_bvh
from humanoid_ik.outputs.render.skeleton import (
    beside_robot,
    bone_radius,
    chain_length,
    film_with_skeleton,
    human_skeleton,
)
from humanoid_ik.outputs.render.video import mp4_complete
from tests.robots import robot_file

SMALL = RenderSpec(width=160, height=120, trail=0.0, contact_sheet=6)
"""A small film without trails (their colours are not the skeleton's, but keep it plain)."""


@pytest.fixture(scope="module")
def wave(tmp_path_factory) -> Path:
    """The procedural human's wave, 1 s at 120 Hz (CMU names, Y up, cm)."""
    path = tmp_path_factory.mktemp("clip") / "wave.bvh"
    path.write_text(human_bvh("wave", seconds=1.0))
    return path


def placed(clip_path: Path, robot: str, frames: int, beside: bool = True):
    """Retarget ``frames`` frames of the clip onto ``robot`` and place its skeleton as the
    retarget pipeline would: the trajectory, the model, the skeleton, its parents, the
    human and robot sides."""
    path = None if robot == "humanoid" else robot_file(robot)
    res = retarget(clip_path, path, None, frames=frames)
    clip = read_bvh(clip_path)
    human = find_human(clip)
    model = load_model(path)
    side = RobotSide(model, profile_for(model, path), str(model_file(path)))
    X = human_skeleton(
        clip.positions[:frames],
        shoulders=(human.arms["left"].shoulder, human.arms["right"].shoulder),
        human_arm=human.arms["left"].length,
        robot_shoulders=[side.arms[s].shoulder for s in ("left", "right")],
        robot_arm=side.arms["left"].length,
        forward=side.heading[:, 0],
        heading_pair=human.heading_pair,
    )
    if beside:
        X = beside_robot(X, model, res.trajectory.qpos, side.heading[:, 0])
    return res.trajectory, model, X, clip.skeleton.parents, human, side, clip


def colour_masks(path: Path) -> dict[str, np.ndarray]:
    """Pixels of the skeleton's violet, the bundled humanoid's skin, and bright grey (G1)."""
    im = np.asarray(Image.open(path)).astype(int)
    R, G, B = im[..., 0], im[..., 1], im[..., 2]
    return {
        "violet": (B > 120) & (B - G > 60) & (R - G > 25),
        "skin": (R > 140) & (R - B > 35) & (G - B > 15),
        "grey": (abs(R - G) < 15) & (abs(G - B) < 15) & (R > 140),
    }


def halves(mask: np.ndarray) -> tuple[int, int]:
    w = mask.shape[1]
    return int(mask[:, : w // 2].sum()), int(mask[:, w // 2 :].sum())


@pytest.mark.parametrize("robot", ["humanoid", "g1"])
def test_the_skeleton_points_its_arms_where_the_robot_reaches(wave, robot):
    """Overlaid (before moving it aside), every frame's human hand point lies from its
    shoulder in the direction the robot's hand target lies from the robot's shoulder
    (the retargeting's own mapping, 1e-9), at the arm-length ratio of the human's
    distance; the shoulders' midpoint is on the robot's."""
    traj, _, X, _, human, side, clip = placed(wave, robot, 60, beside=False)
    arm = human.arms["right"]
    target = next(e for e in traj.effectors if e.target_name == "right_hand").target
    s = side.arms["right"].length / arm.length
    hand = human.arms["right"].hand_point(X)  # the mean of the wrist's children
    for f in range(60):
        got = hand[f] - X[f, arm.shoulder]
        want = target[f] - side.arms["right"].shoulder
        np.testing.assert_allclose(
            got / np.linalg.norm(got), want / np.linalg.norm(want), atol=1e-9
        )
        human_d = np.linalg.norm(
            arm.hand_point(clip.positions[f : f + 1])[0] - clip.positions[f, arm.shoulder]
        )
        assert np.linalg.norm(got) == pytest.approx(s * human_d, rel=1e-9)
    mid = (X[:, human.arms["left"].shoulder] + X[:, arm.shoulder]) / 2
    robot_mid = (side.arms["left"].shoulder + side.arms["right"].shoulder) / 2
    np.testing.assert_allclose(mid, np.broadcast_to(robot_mid, mid.shape), atol=1e-12)
    if robot == "g1":  # G1's arm is two thirds of the human's: the skeleton is scaled down
        assert s == pytest.approx(0.652, abs=0.005)
    rest = clip.positions[0]
    nodes = (arm.shoulder, arm.elbow, arm.wrist, *arm.hand)
    assert chain_length(rest, nodes) == pytest.approx(arm.length, abs=1e-9)


def test_beside_the_robot_the_skeleton_clears_it_in_every_frame(wave):
    """Moved aside, the skeleton's nearest point (its joints' spheres included) is the
    gap to the robot's right of the robot's rightmost geom over all frames, and it is
    shifted by one distance for the whole film."""
    traj, model, over, *_ = placed(wave, "g1", 30, beside=False)
    forward = np.array([1.0, 0.0, 0.0])  # G1 faces +x
    X = beside_robot(over, model, traj.qpos, forward, gap=0.1)
    shift = X - over
    np.testing.assert_allclose(shift, np.broadcast_to(shift[0, 0], shift.shape), atol=1e-12)
    assert shift[0, 0, 0] == 0 and shift[0, 0, 2] == 0 and shift[0, 0, 1] < 0  # to the right
    data = mujoco.MjData(model)
    robot_min = np.inf
    for q in traj.qpos:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for b in range(1, model.nbody):  # every body's origin is inside the robot's extent
            robot_min = min(robot_min, float(data.xpos[b, 1]))
    skel_max = float(X[..., 1].max()) + 1.6 * bone_radius(X)
    # geoms reach past the bodies' origins: the gap is to them, a few cm further out
    assert robot_min - 0.1 - 0.15 < skel_max <= robot_min - 0.1 + 1e-9, (skel_max, robot_min)


def test_film_shows_the_robot_and_the_skeleton_from_the_front(wave, tmp_path):
    """The bundled humanoid (its own cameras: the front one is moved back to frame the
    skeleton, no note) and the human beside it: 6 frames in the MP4, four snapshots and
    a contact sheet of 6; in every snapshot the skeleton's violet is in the picture's
    left half (the robot's right, seen from the front) and not in the right, the
    humanoid's skin in the right half and not in the left."""
    traj, model, X, parents, *_ = placed(wave, "humanoid", 6)
    out = film_with_skeleton(traj, model, X, parents, tmp_path, render=SMALL)
    assert out.frames == 6 and out.notes == () and not out.interrupted
    assert out.video == tmp_path / "wave.mp4" and mp4_complete(out.video)
    assert [p.name for p in out.snapshots] == [f"frame_{i:04d}.png" for i in (0, 2, 3, 5)]
    assert out.contact_sheet == tmp_path / "contact_sheet.png"
    with Image.open(out.contact_sheet) as sheet:
        assert sheet.width > 4 * 160 and 2 * 120 < sheet.height < 3 * 120  # 4 a row: 2 rows
    for snap in out.snapshots:
        with Image.open(snap) as im:
            assert im.size == (160, 120)
        m = colour_masks(snap)
        left, right = halves(m["violet"])
        assert left > 150 and right == 0, (snap.name, left, right)
        left, right = halves(m["skin"])
        assert right > 150 and left == 0, (snap.name, left, right)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in out.files())


def test_film_of_g1_in_the_default_stage(wave, tmp_path):
    """G1 (a URDF: filmed in the default stage, whose cameras frame the skeleton too):
    the skeleton's violet on the picture's left half only, the robot's bright grey
    mostly on the right."""
    traj, model, X, parents, *_ = placed(wave, "g1", 4)
    out = film_with_skeleton(traj, model, X, parents, tmp_path, render=SMALL, name="g1_wave")
    assert out.frames == 4 and out.notes == ()
    assert out.video == tmp_path / "g1_wave.mp4" and mp4_complete(out.video)
    m = colour_masks(out.snapshots[0])
    left, right = halves(m["violet"])
    assert left > 100 and right == 0, (left, right)
    left, right = halves(m["grey"])
    assert right > 2 * left, (left, right)


def test_bad_skeletons_are_refused_in_one_line(wave, tmp_path):
    """A skeleton with another frame count, parents of another length or out of range, a
    bad film name, a bad placement argument: one line naming it; nothing written."""
    traj, model, X, parents, *_ = placed(wave, "humanoid", 3, beside=False)
    cases = [
        (X[:2], parents, None, "skeleton: expected world positions (3 frames, joints, 3)"),
        (X, parents[:-1], None, f"skeleton: expected {X.shape[1]} parents"),
        (X, (*parents[:-1], 99), None, "bad parent 99"),
        (X, parents, "../x", "film: expected a name of letters"),
    ]
    for skel, par, name, message in cases:
        with pytest.raises(TrajectoryFileError) as err:
            film_with_skeleton(traj, model, skel, par, tmp_path, render=SMALL, name=name)
        assert message in str(err.value) and "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []
    place = dict(shoulders=(1, 2), human_arm=1, robot_shoulders=[0, 0, 0], robot_arm=1)
    for bad, message in [
        ({"shoulders": (1, 1)}, "shoulders: expected one or two different node indices"),
        ({"robot_arm": 0}, "robot_arm: expected a length > 0"),
        ({"forward": [0, 0, 1]}, "forward: expected a direction with a horizontal part"),
    ]:
        with pytest.raises(MotionError, match=message):
            human_skeleton(X, **(place | {"forward": [1, 0, 0]} | bad))
