"""The one definition of position, orientation and gaze errors and of "on target"."""

import math

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, TargetError, make_solver
from humanoid_ik.config.scene import load_scene
from humanoid_ik.core.measures import (
    ON_TARGET_ANGLE,
    ON_TARGET_DISTANCE,
    axis_vector,
    gaze_error,
    on_target,
    orientation_error,
    pose_error,
)
from humanoid_ik.run.runner import run_scene

GAZE_SCENE = """
name = "gaze_{axis}"
duration = 2.0
fps = 10
[[targets]]
name = "spot"
motion = {{ kind = "circle", center = {center}, radius = 0.08, normal = {normal}, period = 2.0 }}
[[effectors]]
site = "gaze_site"
target = "spot"
task = "look_at"
solver = {{ name = "{solver}", options = {{ forward_axis = "{axis}" }} }}
"""
# a point the neck can turn each axis onto: the scene for z, and one for x and y
CENTERS = {
    "x": ([0.75, 0.10, 1.75], [1, 0, 0]),
    "y": ([0.30, 0.70, 1.62], [0, 0, 1]),  # the neck turns y only in the horizontal plane
    "z": ([0.35, 0.0, 2.3], [0, 0, 1]),
}


def test_gaze_error_of_a_known_geometry():
    """A site at the origin aiming x at (1, 1, 0): 45 degrees off, missing by sin(45) * sqrt(2);
    a target behind the site misses by its whole distance."""
    R = np.eye(3)
    miss, angle = gaze_error(np.zeros(3), R, axis_vector("x"), np.array([1.0, 1.0, 0.0]))
    assert angle == pytest.approx(math.pi / 4)
    assert miss == pytest.approx(1.0)
    miss, angle = gaze_error(np.zeros(3), R, axis_vector("y"), np.array([1.0, 1.0, 0.0]))
    assert angle == pytest.approx(math.pi / 4) and miss == pytest.approx(1.0)
    miss, angle = gaze_error(np.zeros(3), R, axis_vector("z"), np.array([0.0, 0.0, -2.0]))
    assert angle == pytest.approx(math.pi) and miss == pytest.approx(2.0)
    assert gaze_error(np.zeros(3), R, axis_vector("x"), np.zeros(3)) == (0.0, 0.0)


def test_axis_vector_names_and_bad_values():
    """Axis names give unit vectors; a vector is normalised; a bad axis names the choices."""
    assert axis_vector("y").tolist() == [0.0, 1.0, 0.0]
    assert axis_vector([0.0, 0.0, 2.0]).tolist() == [0.0, 0.0, 1.0]
    with pytest.raises(TargetError, match="axis 'w' unknown; axes: x, y, z"):
        axis_vector("w")
    with pytest.raises(TargetError, match="non-zero 3-vector"):
        axis_vector([0.0, 0.0, 0.0])


def test_orientation_error_is_the_rotation_angle():
    """A site turned 0.3 rad about any axis from the target is 0.3 rad off, in both the
    scalar measure and the solvers' error vector."""
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, axis, 0.3)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, quat)
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    assert orientation_error(R, identity) == pytest.approx(0.3, abs=1e-12)
    out, buf = np.empty(6), np.empty((2, 4))
    ep, er = pose_error(np.zeros(3), R, np.array([0.0, 0.0, 1.0]), identity, out, buf)
    assert ep == pytest.approx(1.0) and er == pytest.approx(0.3, abs=1e-12)
    # the world-frame rotation vector turns the site back onto the target: -0.3 about axis
    assert out[3:] == pytest.approx(-0.3 * axis, abs=1e-12)


def test_on_target_thresholds():
    """On target within 1 mm, and for a pose within 0.01 rad as well."""
    assert on_target(ON_TARGET_DISTANCE) and not on_target(ON_TARGET_DISTANCE * 1.01)
    assert on_target(0.0, ON_TARGET_ANGLE) and not on_target(0.0, ON_TARGET_ANGLE * 1.01)


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_gaze_scene_is_on_target_for_every_forward_axis(axis, tmp_path):
    """A look_at effector aiming any site axis is measured along that axis: every frame
    converged and on target (the runner once measured the x axis whatever the solver
    aimed)."""
    center, normal = CENTERS[axis]
    path = tmp_path / f"gaze_{axis}.toml"
    path.write_text(GAZE_SCENE.format(axis=axis, center=center, normal=normal, solver="look_at"))
    metrics = run_scene(load_scene(path))
    assert len(metrics) == 20
    statuses = [f.samples[0].status for f in metrics.frames]
    assert statuses == ["converged"] * 20
    miss = metrics.series(0, "position_error")
    angle = metrics.series(0, "orientation_error")
    assert miss.max() < 1e-4 and angle.max() < 1e-4
    assert metrics.summary()[0]["on_target_when_reachable"] == 1.0
    # the achieved gaze point lies on the chosen axis, as far out as the target
    s = metrics.frames[-1].samples[0]
    assert np.linalg.norm(s.achieved - s.target) < 1e-4


def test_mink_gaze_aims_the_chosen_axis(tmp_path):
    """mink's gaze task aims its forward_axis option, and the runner measures that axis."""
    center, normal = CENTERS["z"]
    path = tmp_path / "gaze_z.toml"
    path.write_text(GAZE_SCENE.format(axis="z", center=center, normal=normal, solver="mink"))
    metrics = run_scene(load_scene(path))
    assert metrics.summary()[0]["on_target_when_reachable"] == 1.0
    assert metrics.series(0, "orientation_error").max() < 1e-3


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_look_at_solver_reports_the_measure(axis):
    """The look_at solver's reported errors are the shared gaze measure of its axis."""
    chain = Chain(None, "gaze_site")
    center = np.array(CENTERS[axis][0])
    res = make_solver("look_at", forward_axis=axis).solve(chain, center)
    assert res.converged
    chain.set_q(res.q)
    miss, angle = gaze_error(chain.position, chain.rotation, axis_vector(axis), center)
    assert res.position_error == pytest.approx(miss, abs=1e-15)
    assert res.orientation_error == pytest.approx(angle, abs=1e-15)
    assert angle < 1e-6


def test_signed_axes_name_a_frame_axis_and_its_opposite():
    """``-x`` is the opposite of ``x`` (a head frame that looks backwards, as iCub's);
    ``axis_name`` names a direction along a frame axis and nothing else."""
    from humanoid_ik.core.measures import axis_vector
    from humanoid_ik.core.rotations import axis_name

    assert axis_vector("-x").tolist() == [-1.0, 0.0, 0.0]
    assert axis_vector("-z").tolist() == [0.0, 0.0, -1.0]
    assert [axis_name(v) for v in ([0, -2, 0], [0, 0, 1], [1, 1, 0])] == ["-y", "z", None]


def test_look_at_aims_an_opposite_axis():
    """``look_at`` with ``forward_axis = "-x"`` turns the head so the gaze frame's -x
    points at the target (MuJoCo FK of the answer)."""
    from humanoid_ik import Chain, solve
    from humanoid_ik.core.measures import axis_vector, gaze_error

    head = Chain(site="gaze_site")
    q = 0.5 * (head.lower + head.upper) + 0.3 * (head.upper - head.lower) * np.array([0.8, -0.6])
    p, R = head.fk(q)
    target = p - 0.5 * R[:, 0]  # behind the face, where -x looks at that posture
    res = solve(head, target, "look_at", forward_axis="-x", q0=head.q_home)
    p, R = head.fk(res.q)
    assert res.converged and gaze_error(p, R, axis_vector("-x"), target).angle < 1e-6
    assert gaze_error(p, R, axis_vector("x"), target).angle > 3.0  # x looks away
