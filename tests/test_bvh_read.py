"""Reading BVH (motion/bvh.py) against the independent reader bvhio, on clips of the
procedural human (motion/human.py) in several conventions, and on the BVH the project
exports for the bundled humanoid; the shipped clips of motions/ are what the generator
makes; bad files are one line naming the line and what was expected."""

from __future__ import annotations

from pathlib import Path

import bvhio
import mujoco
import numpy as np
import pytest

from humanoid_ik.core.models import bundled_model_path
from humanoid_ik.core.robot import joint_name
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.errors import BVHError, MotionError
from humanoid_ik.motion.bvh import Z_UP_FROM_Y_UP, euler_angles, parse_bvh, read_bvh
from humanoid_ik.motion.human import HUMAN_MOTIONS, SHIPPED, human_bvh
from humanoid_ik.outputs.bvh import bvh_text
from humanoid_ik.run.trajectory import Trajectory, qpos_names

MOTIONS = Path(__file__).resolve().parents[1] / "motions"

CONVENTIONS = [  # (style, order, positions, units, up)
    ("cmu", "ZXY", "root", "cm", "y"),
    ("cmu", "XYZ", "all", "m", "y"),
    ("mixamo", "YXZ", "root", "cm", "z"),
    ("mixamo", "ZXY", "all", "m", "z"),
    ("cmu", "ZYX", "root", "m", "z"),
    ("mixamo", "YZX", "all", "cm", "y"),
]


def bvhio_world(path: Path, frames: list[int]) -> dict[str, list[tuple[np.ndarray, np.ndarray]]]:
    """bvhio's world position and rotation of every joint (not end sites) at ``frames``:
    the rotation as the BVH's (bvhio's world rotation times the inverse of its rest one,
    since bvhio turns each joint's rest frame toward its child)."""
    root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    root.loadRestPose()
    rest = {n: _quat(j.RotationWorld) for n, j in joints.items()}
    out: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {n: [] for n in joints}
    for f in frames:
        root.loadPose(f)
        for n, j in joints.items():
            R = quat_to_mat(_quat(j.RotationWorld)) @ quat_to_mat(rest[n]).T
            out[n].append((np.array(j.PositionWorld, dtype=np.float64), R))
    return out


def _quat(q) -> np.ndarray:
    """A glm quaternion as (w, x, y, z), normalised (it is float32)."""
    out = np.array([q.w, q.x, q.y, q.z], dtype=np.float64)
    return out / np.linalg.norm(out)


@pytest.mark.parametrize(("style", "order", "positions", "units", "up"), CONVENTIONS)
def test_world_poses_match_bvhio(tmp_path, style, order, positions, units, up):
    """Every joint's world position within 1e-6 of the skeleton's height of bvhio's
    (bvhio computes in float32), its orientation within 1e-5, in 12 frames spread over a
    1,200-frame reach; end sites sit at their joint's pose times their offset."""
    path = tmp_path / "clip.bvh"
    text = human_bvh("reach", style=style, order=order, positions=positions, units=units, up=up)
    path.write_text(text)
    clip = read_bvh(path, convert=False)
    assert clip.n_frames == 1200 and clip.frame_time == pytest.approx(1 / 120)
    height = float(np.ptp(clip.skeleton.rest_positions(), axis=0).max())
    frames = list(range(0, 1200, 101))
    ref = bvhio_world(path, frames)
    assert set(ref) == set(clip.skeleton.joints) and len(ref) == 22
    worst_p = worst_r = 0.0
    for name, poses in ref.items():
        for f, (p, R) in zip(frames, poses, strict=True):
            worst_p = max(worst_p, float(np.abs(clip.position(name)[f] - p).max()))
            worst_r = max(worst_r, float(np.abs(clip.rotation(name)[f] - R).max()))
    assert worst_p < 1e-6 * height, (worst_p, height)
    assert worst_r < 1e-5, worst_r
    sk = clip.skeleton
    ends = [i for i, e in enumerate(sk.end_sites) if e]
    assert len(ends) == 5 and sk.names[ends[0]].endswith("Head_end")
    for i in ends:
        j = sk.parents[i]
        want = clip.positions[:, j] + np.einsum("fij,j->fi", clip.rotations[:, j], sk.offsets[i])
        np.testing.assert_allclose(clip.positions[:, i], want, atol=1e-9 * height)
    # the motion is real: the right hand travels tens of centimetres
    hand = clip.position(f"{'mixamorig:' if style == 'mixamo' else ''}RightHand")
    assert np.ptp(hand, axis=0).max() > 0.3 * height


def test_conventions_are_detected_and_converted_to_one_world():
    """Each convention is detected (unit and up axis) and, converted to metres and Z up,
    every convention gives the same world positions (1e-6 m) and orientations."""
    ref = None
    for style, order, positions, units, up in CONVENTIONS:
        text = human_bvh(
            "wave", style=style, order=order, positions=positions, units=units, up=up, decimals=9
        )
        clip = parse_bvh(text)
        assert (clip.units, clip.up) == (units, up), clip.detected
        assert "units" in clip.detected and "the head above the feet" in clip.detected
        if ref is None:
            ref = clip
            continue
        np.testing.assert_allclose(clip.positions, ref.positions, atol=1e-6)
        np.testing.assert_allclose(clip.rotations, ref.rotations, atol=1e-7)
    assert ref is not None
    head = ref.position("Head")  # Z up, metres: the head is 1.5 to 1.6 m up
    assert 1.45 < head[:, 2].min() and head[:, 2].max() < 1.65
    forced = parse_bvh(human_bvh("wave", seconds=0.5), units="m", up="z")
    assert forced.detected == "units m (given); up z (given)"
    assert forced.position("Head")[0, 1] > 100  # read as Z up in metres: the cm stay as they are


def test_quaternions_are_the_rotations():
    """The quaternions (w, x, y, z, w >= 0) are the rotation matrices."""
    clip = parse_bvh(human_bvh("arm_circles", seconds=0.25))
    q = clip.quaternions
    assert q.shape == (clip.n_frames, len(clip.names), 4) and np.all(q[..., 0] >= 0)
    for f, i in [(0, 0), (10, 7), (29, 12), (15, len(clip.names) - 1)]:
        np.testing.assert_allclose(quat_to_mat(q[f, i]), clip.rotations[f, i], atol=1e-12)


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_euler_angles_invert_the_channels(order):
    """euler_angles gives channel values whose rotations compose back to the matrix."""
    rng = np.random.default_rng(3)
    angles = rng.uniform(-80, 80, size=(50, 3))
    from humanoid_ik.motion.bvh import axis_rotations

    R = np.stack([np.eye(3)] * 50)
    for k, axis in enumerate(order):
        R = R @ axis_rotations(axis, angles[:, k])
    np.testing.assert_allclose(euler_angles(R, order), angles, atol=1e-9)


# ------------------------------------------------------------------ round trip


def humanoid_trajectory(model: mujoco.MjModel, frames: int = 40) -> Trajectory:
    """Random in-range poses of every hinge of the bundled humanoid, 30 frames/s."""
    rng = np.random.default_rng(7)
    qpos = np.tile(model.qpos0, (frames, 1))
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            lo, hi = model.jnt_range[j] if model.jnt_limited[j] else (-2.0, 2.0)
            qpos[:, model.jnt_qposadr[j]] = rng.uniform(lo, hi, frames)
    return Trajectory(
        time=np.arange(frames) / 30.0,
        qpos=qpos,
        qpos_names=tuple(qpos_names(model)),
        joint_names=tuple(joint_name(model, j) for j in range(model.njnt)),
        effectors=(),
        fps=30.0,
        scene="random",
        scene_file="",
        model_file=str(bundled_model_path()),
        model_sha256="",
    )


@pytest.mark.parametrize("units", ["m", "cm"])
def test_round_trip_through_the_exporter(tmp_path, units):
    """The bundled humanoid's BVH (outputs/bvh.py, as export-bvh writes it) read back:
    every body joint and site where MuJoCo puts it (1e-6 m, the reader's Z-up metres are
    MuJoCo's world), every joint's orientation MuJoCo's rotation from the rest pose
    (1e-6), and every joint where bvhio puts it (1e-6 of the skeleton's size)."""
    model = mujoco.MjModel.from_xml_path(str(bundled_model_path()))
    traj = humanoid_trajectory(model)
    path = tmp_path / "humanoid.bvh"
    path.write_text(bvh_text(traj, model, units=units))
    clip = read_bvh(path)
    assert clip.units == units and clip.up == "y" and clip.fps == pytest.approx(30.0)
    data, rest = mujoco.MjData(model), mujoco.MjData(model)
    mujoco.mj_kinematics(model, rest)
    sites = ["right_palm_site", "left_palm_site", "gaze_site"]
    bodies = ["right_forearm_link", "left_hand_link", "head_link", "torso_link"]
    assert set(sites + bodies) <= set(clip.names)
    worst_p = worst_r = 0.0
    for f in range(traj.n_frames):
        data.qpos[:] = traj.qpos[f]
        mujoco.mj_kinematics(model, data)
        for s in sites:
            worst_p = max(worst_p, float(np.abs(clip.position(s)[f] - data.site(s).xpos).max()))
        for b in bodies:
            want = data.body(b).xmat.reshape(3, 3) @ rest.body(b).xmat.reshape(3, 3).T
            worst_r = max(worst_r, float(np.abs(clip.rotation(b)[f] - want).max()))
    assert worst_p < 1e-6 and worst_r < 1e-6, (worst_p, worst_r)
    raw = read_bvh(path, convert=False)
    frames = list(range(0, traj.n_frames, 7))
    worst = 0.0
    for name, poses in bvhio_world(path, frames).items():
        for f, (p, _) in zip(frames, poses, strict=True):
            worst = max(worst, float(np.abs(raw.position(name)[f] - p).max()))
    scale = {"m": 1.0, "cm": 100.0}[units]
    assert worst < 1e-6 * scale, worst
    np.testing.assert_allclose(raw.positions @ Z_UP_FROM_Y_UP.T / scale, clip.positions, atol=1e-12)


# ------------------------------------------------------------------ shipped clips


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_clips_are_what_the_generator_makes(name):
    """motions/<name> has the hierarchy the generator writes, and every value within
    half a unit of its last digit (regenerated here)."""
    kwargs = SHIPPED[name]
    made = human_bvh(**kwargs)  # type: ignore[arg-type]
    shipped = (MOTIONS / name).read_text()
    cut = made.index("MOTION")
    assert shipped[:cut] == made[:cut]
    a, b = parse_bvh(shipped, convert=False), parse_bvh(made, convert=False)
    assert a.values.shape == b.values.shape == (240, b.skeleton.n_channels)
    digits = int(kwargs["decimals"])  # type: ignore[call-overload]
    np.testing.assert_allclose(a.values, b.values, rtol=0, atol=0.51 * 10.0**-digits)
    assert (MOTIONS / "README.md").read_text().count(name) == 1


def test_shipped_clips_read_with_their_conventions():
    """The shipped clips are detected as the README says."""
    want = {"reach_cmu.bvh": ("cm", "y"), "wave_mixamo.bvh": ("cm", "y")}
    want["arm_circles_zup_m.bvh"] = ("m", "z")
    for name, conv in want.items():
        clip = read_bvh(MOTIONS / name)
        assert (clip.units, clip.up) == conv and clip.fps == pytest.approx(120.0)


# ------------------------------------------------------------------ the generator


@pytest.mark.parametrize("motion", HUMAN_MOTIONS)
def test_generated_motion_is_human_like(motion):
    """1,200 frames at 120 Hz: the hands move at most 2.5 m/s with no jump, the elbows
    bend between 0 and 150 degrees, the hands stay within arm's length of the shoulders,
    and the clip starts and ends near rest."""
    clip = parse_bvh(human_bvh(motion))
    assert clip.n_frames == 1200
    for side in ("Left", "Right"):
        hand, elbow, shoulder = (clip.position(f"{side}{p}") for p in ("Hand", "ForeArm", "Arm"))
        speed = np.linalg.norm(np.diff(hand, axis=0), axis=1) * clip.fps
        assert speed.max() < 2.5
        accel = np.linalg.norm(np.diff(hand, 2, axis=0), axis=1) * clip.fps**2
        assert accel.max() < 25.0
        u, v = elbow - shoulder, hand - elbow
        cos = np.sum(u * v, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
        bend = np.degrees(np.arccos(np.clip(cos, -1, 1)))
        assert bend.min() >= 0 and bend.max() < 150
        reach = np.linalg.norm(hand - shoulder, axis=1)
        assert reach.max() <= 0.55 + 1e-9
    right = clip.position("RightHand")
    assert np.ptp(right, axis=0).max() > 0.3  # the right hand really moves
    assert np.linalg.norm(right[0] - right[-1]) < 0.05 or motion == "reach"


def test_generator_refuses_bad_parameters():
    """One MotionError per bad parameter, naming it and the valid values."""
    cases = [
        ({"motion": "run"}, "motion: expected one of arm_circles, reach, wave, got 'run'"),
        ({"style": "lafan"}, "style: expected one of cmu, mixamo, got 'lafan'"),
        ({"up": "x"}, "up: expected one of y, z, got 'x'"),
        ({"units": "ft"}, "units: expected one of cm, in, m, mm, got 'ft'"),
        ({"order": "XXY"}, "order: expected the three axes X, Y, Z in some order"),
        ({"seconds": 0}, "seconds: expected a number > 0 and <= 600, got 0"),
    ]
    for kwargs, message in cases:
        with pytest.raises(MotionError) as err:
            human_bvh(**kwargs)  # type: ignore[arg-type]
        assert str(err.value).startswith(message), str(err.value)


# ------------------------------------------------------------------ bad files

GOOD = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 10 20 30
0 90 0 0 0 0 0 0 0
"""


def test_a_small_file_by_hand():
    """A hand-written file: offsets, channels, the end site named after its joint."""
    clip = parse_bvh(GOOD, convert=False)
    sk = clip.skeleton
    assert sk.names == ("Hips", "Spine", "Spine_end") and sk.parents == (-1, 0, 1)
    assert sk.end_sites == (False, False, True) and sk.channels[2] == ()
    np.testing.assert_allclose(clip.position("Spine_end")[1], [0, 105, 0], atol=1e-12)
    # frame 0: Spine turns Rz(10) Rx(20) Ry(30); its end site 5 along its turned y
    from humanoid_ik.motion.bvh import axis_rotations

    R = axis_rotations("Z", [10]) @ axis_rotations("X", [20]) @ axis_rotations("Y", [30])
    np.testing.assert_allclose(clip.position("Spine_end")[0], [0, 100, 0] + 5 * R[0, :, 1])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD.replace("HIERARCHY", "HIERARCHIE"), "line 1: expected 'HIERARCHY', got 'HIERARCHIE'"),
        (GOOD.replace("OFFSET 0 10 0", "OFFSET 0 ten 0"), "line 8: expected OFFSET value 2 of 3"),
        (
            GOOD.replace(
                "Zrotation Xrotation Yrotation\n    End", "Zrotation Xrot Yrotation\n    End"
            ),
            "line 9: channel 'Xrot' unknown; channels: Xposition",
        ),
        (
            GOOD.replace("0 90 0 0 0 0 0 0 0", "0 90 0 0 0 0 0 0"),
            "line 20: frame 1 has 8 values; expected 9 (the channels of the hierarchy)",
        ),
        (
            GOOD.replace("Frames: 2", "Frames: 3"),
            "'Frames: 3' declares 3 frame rows; the file has 2",
        ),
        (
            GOOD.replace("Frame Time: 0.0333333", "Frame Time: 0"),
            "line 18: expected 'Frame Time: T' with T > 0",
        ),
        (
            GOOD.replace("0 90 0 0 0 0 10 20 30", "0 90 0 0 0 0 10 nan 30"),
            "line 19: expected a finite number, got 'nan'",
        ),
        (
            GOOD.replace("0 90 0 0 0 0 10 20 30", "0 90 0 0 0 0 10 x 30"),
            "line 19: expected a number, got 'x'",
        ),
        (
            GOOD.replace("MOTION", "ROOT Other\n{\nOFFSET 0 0 0\n}\nMOTION"),
            "line 16: a second ROOT; this reader takes one skeleton per file (one ROOT)",
        ),
        (
            GOOD.replace("  JOINT Spine", "  BONE Spine"),
            "line 6: expected OFFSET, CHANNELS, JOINT, End Site or '}', got 'BONE'",
        ),
        (GOOD.split("MOTION")[0], "no MOTION line; a BVH file has HIERARCHY then MOTION"),
        (
            GOOD.replace("    }\n  }\n}", "    }\n  }\n"),
            "line 15: the hierarchy ends early; expected OFFSET, CHANNELS, JOINT, End Site or '}'",
        ),
    ],
)
def test_bad_files_are_one_line(text, message):
    """Each syntax error: one line with the source, the line number and what was expected."""
    with pytest.raises(BVHError) as err:
        parse_bvh(text, source="bad.bvh")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("bad.bvh: ")
    assert message in msg, msg


def test_bad_options_and_names(tmp_path):
    """An unknown unit, up axis or joint name, a missing file: one line with the choices."""
    with pytest.raises(BVHError, match="units 'ft' unknown; choices: auto, cm, in, m, mm"):
        parse_bvh(GOOD, units="ft")
    with pytest.raises(BVHError, match="up axis 'x' unknown; choices: auto, y, z"):
        parse_bvh(GOOD, up="x")
    with pytest.raises(
        BVHError, match="joint 'Head' not in the BVH; joints: Hips, Spine, Spine_end"
    ):
        parse_bvh(GOOD).position("Head")
    with pytest.raises(BVHError, match="nothing.bvh: cannot read the file"):
        read_bvh(tmp_path / "nothing.bvh")
