"""Reach, markers and the default stage on real robots (example-robot-data's URDFs).

The reach of an offset arm is sampled, not the polyline through its joints; a target
beyond it is not reachable. A film of a URDF robot faces it (its left appears on the
image's right in the front view) and frames its whole run (the robot and the targets
fill at least half of the frame height in every frame, from a segmentation render of
the film's model), and each target's marker, sized to the robot, shows in every frame
even inside a gripper."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from PIL import Image

from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.errors import NameNotFoundError
from humanoid_ik.outputs.render import (
    MARKER_RADIUS,
    marker_radius,
    project,
    render_scene,
)
from humanoid_ik.outputs.stage import facing, staged_model, trajectory_stage
from humanoid_ik.run.runner import run_scene
from tests.robots import robot_file

W, H = 96, 72
FRAMES = 3  # 0, 0.67 and 1.33 s: start, on the way out, holding

# each robot's arms: (end-effector body, how many root joints of its default chain are
# the torso's, left out so the arms share no joint)
ARMS = {
    "g1": [("left_rubber_hand", 3), ("right_rubber_hand", 3)],
    "talos": [("gripper_left_base_link", 2), ("gripper_right_base_link", 2)],
    "icub": [("l_hand", 3), ("r_hand", 3)],
    "so100": [("jaw", 0)],
    "kinova": [("j2s6s200_end_effector", 0)],
}
FORWARD = {"g1": (1, 0), "talos": (1, 0), "icub": (-1, 0), "so100": (0, -1)}
"""Where each robot faces: G1 and Talos +x, iCub -x (its root frame looks backward), SO-100
-y (its jaw points that way at home); Kinova's turntable base has no front."""


def arm_chains(model: mujoco.MjModel, name: str) -> list[Chain]:
    """The robot's arm chains (torso joints left out), on one robot state."""
    robot = Robot(model)
    out = []
    for body, torso in ARMS[name]:
        joints = Chain(robot, body=body).joint_names[torso:]
        out.append(Chain(robot, body=body, joints=joints))
    return out


def scene_file(
    name: str,
    path: Path,
    model: mujoco.MjModel,
    folder: Path,
    camera: str = "front",
    from_home: bool = False,
) -> Path:
    """A 3-frame scene (0, 0.67 and 1.33 s): each arm's target goes out from where the
    hand is at one seeded random pose 30 % of the way from home to where it is at
    another, holds there and comes back (DLS tracks it). A humanoid's arm starts at
    home, a single arm too with ``from_home``."""
    chains = arm_chains(model, name)
    rng = np.random.default_rng(1)
    text = [
        f'name = "{name}"\nmodel = "{path}"\nduration = 2.0\nfps = 1.5\n',
        '[solver]\nname = "dls"\n',
        f'[render]\nwidth = {W}\nheight = {H}\ncamera = "{camera}"\ncontact_sheet = 0\n'
        "trail = 0.0\n",
    ]
    for k, c in enumerate(chains):
        pose = c.q_home + 0.3 * (c.random_q(rng) - c.q_home)
        start, _ = c.fk(c.q_home if len(chains) == 2 or from_home else pose)
        far, _ = c.fk(c.q_home + 0.3 * (c.random_q(rng) - c.q_home))
        a, b = (", ".join(f"{v:.4f}" for v in p) for p in (start, far))
        text.append(
            f'[[targets]]\nname = "t{k}"\nmotion = {{ kind = "out_and_back", start = [{a}], '
            f"far = [{b}], rest = 0.0, out = 1.2, hold = 0.3, back = 0.5 }}\n"
        )
        joints = ", ".join(f'"{j}"' for j in c.joint_names)
        text.append(f'[[effectors]]\nbody = "{c.ee_name}"\njoints = [{joints}]\ntarget = "t{k}"\n')
    path = folder / f"{name}_{camera}{'_home' if from_home else ''}.toml"
    path.write_text("\n".join(text))
    return path


@pytest.fixture(scope="module")
def models():
    """Each robot's model, compiled once."""
    cache: dict[str, mujoco.MjModel] = {}

    def get(name: str) -> mujoco.MjModel:
        if name not in cache:
            cache[name] = load_model(robot_file(name))
        return cache[name]

    return get


# ----------------------------------------------------------------------------- reach
def _sampled_max(chain: Chain, n: int) -> float:
    """The largest distance of the end effector from the base over ``n`` random poses."""
    rng = np.random.default_rng(7)
    base = chain.base.copy()
    best = 0.0
    for _ in range(n):
        p, _ = chain.fk(chain.random_q(rng))
        best = max(best, float(np.linalg.norm(p - base)))
    chain.set_q(chain.q_home)
    return best


@pytest.mark.parametrize(
    ("name", "body", "polyline"), [("ur5", "tool0", 1.2396), ("panda", "panda_hand_tcp", 1.0897)]
)
def test_reach_of_an_offset_arm_is_sampled(models, monkeypatch, name, body, polyline):
    """UR5 and Panda: the reach is within 1 % of the farthest of 20,000 random poses (0.950
    and 0.947 m), and well below the polyline through the joint anchors (1.240 and
    1.090 m, still the upper bound); it is sampled once per chain (the robot keeps it),
    and two chains agree exactly."""
    import humanoid_ik.core.chain as chain_module

    builds = []
    sample = chain_module._sample_reach
    monkeypatch.setattr(chain_module, "_sample_reach", lambda c: builds.append(1) or sample(c))
    chain = Chain(models(name), body=body)
    base, reach = chain.reach()
    assert chain.reach() == (pytest.approx(base), reach) and len(builds) == 1
    big = _sampled_max(chain, 20_000)
    assert big * 0.99 <= reach <= big * 1.01, (reach, big)
    assert chain.reach_bound() == pytest.approx(polyline, abs=1e-4)
    assert reach < 0.9 * chain.reach_bound()
    np.testing.assert_allclose(base, chain.data.xanchor[chain.joint_ids[0]])
    again = Chain(models(name), body=body)
    assert again.reach()[1] == reach and len(builds) == 2


def test_a_target_beyond_the_sampled_reach_is_not_reachable(models, tmp_path):
    """A UR5 target 1.10 m from the base (inside the old polyline bound, 1.24 m) is not
    reachable, and the arm misses it; one 0.80 m away is reachable and reached."""
    model = robot_file("ur5")
    chain = Chain(models("ur5"), body="tool0")
    base, reach = chain.reach()
    assert 0.94 < reach < 0.96
    away = np.array([0.6, -0.8, 0.0])
    far, near = base + 1.10 * away, base + 0.80 * away
    pts = ", ".join(f"[{', '.join(f'{v:.5f}' for v in p)}]" for p in (far, near))
    path = tmp_path / "ur5.toml"
    path.write_text(
        f'name = "ur5_far"\nmodel = "{model}"\nduration = 2.0\nfps = 2\n[solver]\n'
        'name = "dls"\n[[targets]]\nname = "p"\n'
        f'motion = {{ kind = "points", points = [{pts}], hold = 1.0, travel = 0.0 }}\n'
        '[[effectors]]\nbody = "tool0"\ntarget = "p"\n'
    )
    rec = run_scene(load_scene(path))
    reachable = rec.series(0, "reachable").astype(bool).tolist()
    assert reachable == [False, False, True, True]
    err = rec.series(0, "position_error")
    assert err[:2].min() > 0.1 and err[2:].max() < 1e-3


def test_a_model_without_the_default_site_points_at_body(models, capsys):
    """A chain on a URDF without naming the end effector says that the default site is
    missing and names --body and the bodies at the ends of its hinge chains; the solve
    command prints it as one line."""
    with pytest.raises(NameNotFoundError) as info:
        Chain(models("ur5"))
    msg = str(info.value)
    assert msg.startswith("site 'right_palm_site' not in model; sites: (none)")
    assert "--body NAME (body=NAME)" in msg and msg.endswith("chain: ee_link, tool0")
    assert main(["solve", "--model", str(robot_file("ur5")), "--target", "0.5,0,0.5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("humanoid-ik: error: site 'right_palm_site'")


# ----------------------------------------------------------------------------- facing
@pytest.mark.parametrize("name", sorted(FORWARD))
def test_facing_from_where_the_arms_reach(models, name):
    """The stage's forward direction is each robot's front, within 30 degrees."""
    chains = arm_chains(models(name), name)
    f = facing(chains)
    want = np.array([*FORWARD[name], 0.0])
    assert f[2] == 0.0 and math.degrees(math.acos(min(1.0, float(f @ want)))) < 30, f


# ----------------------------------------------------------------------------- films
@pytest.fixture(scope="module")
def films(models, tmp_path_factory):
    """Each robot's scene filmed (3 frames at 96x72), with the film's model."""
    root = tmp_path_factory.mktemp("films")
    cache = {}

    def get(name: str):
        if name not in cache:
            sc = load_scene(scene_file(name, robot_file(name), models(name), root))
            out = render_scene(sc, root / name, video=False, plot=False)
            traj = out.metrics.trajectory()
            cache[name] = (sc, out, trajectory_stage(sc.model, traj, W / H))
        return cache[name]

    return get


def greenish(px: np.ndarray) -> bool:
    """A pixel of the on-target marker, lit or seen through its translucent halo (none of
    these robots is green)."""
    r, g, b = (int(v) for v in px)
    return g >= 100 and g - r >= 50 and g - b >= 40


def robot_rows(model: mujoco.MjModel, qpos: np.ndarray, camera: str) -> list[tuple[int, int]]:
    """Per pose of ``qpos`` ``(F, nq)``: the first and last image rows showing a geom of
    the robot (not the stage's floor), from a segmentation render of ``model``."""
    data = mujoco.MjData(model)
    floor = model.geom("stage_floor").id
    out = []
    with mujoco.Renderer(model, H, W) as r:
        r.enable_segmentation_rendering()
        for q in qpos:
            data.qpos[:] = q
            mujoco.mj_forward(model, data)
            r.update_scene(data, camera=camera)
            seg = r.render()
            robot = (seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)) & (seg[..., 0] != floor)
            rows = np.flatnonzero(robot.any(axis=1))
            out.append((int(rows.min()), int(rows.max())))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["g1", "talos", "icub", "so100", "kinova"])
def test_film_faces_the_robot_frames_its_run_and_shows_the_markers(films, name):
    """In every frame of the front view: the robot and its targets fill at least half of
    the frame height; each target's marker shows in its colour (green, on target) around
    where the target projects, also inside a gripper; and a humanoid's left shoulder
    appears to the right of its right one (the camera faces it)."""
    sc, out, model = films(name)
    data = mujoco.MjData(model)
    traj = out.metrics.trajectory()
    assert out.frames == FRAMES and len(out.snapshots) == FRAMES
    rows = robot_rows(model, traj.qpos, "front")
    for i, png in enumerate(out.snapshots):
        img = np.array(Image.open(png))
        top, bottom = rows[i]
        data.qpos[:] = traj.qpos[i]
        mujoco.mj_forward(model, data)
        for s in out.metrics.frames[i].samples:
            assert s.on_target, (name, i, s.effector)
            u, v, depth = project(model, data, "front", s.target, W, H)
            assert depth > 0 and 0 <= u < W and 0 <= v < H, (name, i, u, v)
            col, row = int(u), int(v)
            window = img[max(0, row - 3) : row + 4, max(0, col - 3) : col + 4].reshape(-1, 3)
            greens = sum(greenish(px) for px in window)
            assert greens >= 3, (name, i, s.effector, window.tolist())
            top, bottom = min(top, row), max(bottom, row)
        assert (bottom - top + 1) / H >= 0.5, (name, i, top, bottom)
    if len(ARMS[name]) == 2:  # left, right
        chains = arm_chains(model, name)
        (ul, _, _), (ur, _, _) = (project(model, data, "front", c.base, W, H) for c in chains)
        assert ul > ur + 2, (name, ul, ur)


@pytest.mark.parametrize("name", ["so100", "kinova"])
def test_film_from_home_frames_the_whole_run(models, tmp_path, name):
    """A single arm filmed from its home pose (its target starts where the hand is at
    home, goes 30 % of the way to a random pose and comes back): the first frame is the
    home pose, and in the rendered frames (segmentation of the film's model, front
    camera) the robot fills at least half of the height in every frame (SO-100 54, 62
    and 82 %, Kinova 53, 53 and 68 %: the stage frames the whole run, and the arm rises
    later), is never cut by the frame's top or bottom, and spans at least 85 % of the
    height over the run (89 %: the stage frames the geoms' surfaces, not their boxes,
    whose corners gave SO-100 81 %, 49 % at home)."""
    model = models(name)
    sc = load_scene(scene_file(name, robot_file(name), model, tmp_path, from_home=True))
    out = render_scene(sc, tmp_path / name, video=False, plot=False)
    traj = out.metrics.trajectory()
    (chain,) = arm_chains(model, name)
    np.testing.assert_allclose(traj.qpos[0][chain.qpos_adr], chain.q_home, atol=1e-6)
    rows = robot_rows(trajectory_stage(sc.model, traj, W / H), traj.qpos, "front")
    assert all((b - t + 1) / H >= 0.5 for t, b in rows), (name, rows)
    assert all(0 < t and b < H - 1 for t, b in rows), (name, rows)
    span = max(b for _, b in rows) - min(t for t, _ in rows) + 1
    assert span / H >= 0.85, (name, rows)


GEOMS = {
    "sphere": 'type="sphere" size="0.1"',
    "capsule": 'type="capsule" size="0.05 0.2"',
    "cylinder": 'type="cylinder" size="0.05 0.2"',
    "ellipsoid": 'type="ellipsoid" size="0.05 0.08 0.25"',
    "box": 'type="box" size="0.05 0.08 0.25"',
    "mesh": 'type="mesh" mesh="egg"',
}


@pytest.mark.parametrize("kind", sorted(GEOMS))
def test_stage_frames_the_surface_of_each_kind_of_geom(tmp_path, kind):
    """One geom of each kind, tilted (30 and 20 degrees), filmed alone from the front:
    it fills 85 to 92 % of the frame height (FILL is 90 %; 89 %, the sphere 92 %), not
    cut by the frame's top or bottom. Framed on the corners of its bounding box it
    filled 68 % (the ellipsoid, and the mesh: an ellipsoid of 642 vertices) to 85 % (the
    cylinder); only the box's corners are its own."""
    path = tmp_path / f"{kind}.xml"
    path.write_text(
        '<mujoco><asset><mesh name="egg" builtin="sphere" params="3" scale="0.05 0.08 0.25"/>'
        f'</asset><worldbody><body pos="0 0 0.5"><geom {GEOMS[kind]} euler="30 20 0" '
        'rgba="1 1 0 1"/></body></worldbody></mujoco>'
    )
    model = staged_model(path, aspect=W / H)
    ((top, bottom),) = robot_rows(model, np.zeros((1, model.nq)), "front")
    assert 0.85 <= (bottom - top + 1) / H <= 0.92 and 0 < top and bottom < H - 1, (top, bottom)


def test_markers_are_sized_to_the_robot(models):
    """A marker is to the arm and the hand what it is on the bundled humanoid (whose stay
    0.02 m): SO-100's core is half of that (its 0.45 m arm, 0.06 m hand), Talos's bigger
    (0.78 m arm, 0.18 m hand); a film of gazes only keeps 0.02 m."""
    assert marker_radius([Chain(), Chain(None, "left_palm_site")]) == pytest.approx(
        MARKER_RADIUS, abs=1e-12
    )
    assert marker_radius([]) == MARKER_RADIUS
    assert marker_radius(arm_chains(models("so100"), "so100")) == pytest.approx(0.0098, rel=0.05)
    assert marker_radius(arm_chains(models("talos"), "talos")) == pytest.approx(0.0246, rel=0.05)
