"""Target motions: each formula from the docstrings, evaluated, and every bad parameter."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from humanoid_ik.core.checks import MAX_POINTS, check_int, check_vector
from humanoid_ik.core.rotations import quat_to_mat, rotation_log
from humanoid_ik.core.types import Target
from humanoid_ik.errors import MotionError, TargetError
from humanoid_ik.motion import (
    MAX_KNOTS,
    MOTIONS,
    Circle,
    FigureEight,
    Lissajous,
    Orientation,
    OutAndBack,
    Points,
    RandomWalk,
    TargetTrack,
    Waypoints,
    hermite,
    plane_basis,
    smoothstep,
)

C = np.array([0.4, -0.3, 1.2])


# ----------------------------------------------------------------------------- helpers
def test_smoothstep_ends_and_middle():
    """s(0) = 0, s(1) = 1, s(1/2) = 1/2, clipped outside [0, 1], zero slope at both ends."""
    assert smoothstep(0.0) == 0.0
    assert smoothstep(1.0) == pytest.approx(1.0)
    assert smoothstep(0.5) == pytest.approx(0.5)
    assert smoothstep(-3.0) == 0.0 and smoothstep(7.0) == pytest.approx(1.0)
    h = 1e-6
    assert smoothstep(h) / h == pytest.approx(0.0, abs=1e-5)
    assert (1.0 - smoothstep(1.0 - h)) / h == pytest.approx(0.0, abs=1e-5)


def test_hermite_ends_and_velocities():
    """p(0) = p0, p(1) = p1 and dp/dt at the ends equals m0, m1 [m/s] for duration h."""
    p0, p1 = np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, 0.0])
    m0, m1 = np.array([0.5, 0.0, 0.0]), np.array([0.0, -1.0, 0.3])
    h, ds = 2.0, 1e-6
    np.testing.assert_allclose(hermite(p0, p1, m0, m1, h, 0.0), p0)
    np.testing.assert_allclose(hermite(p0, p1, m0, m1, h, 1.0), p1)
    v0 = (hermite(p0, p1, m0, m1, h, ds) - p0) / (ds * h)
    v1 = (p1 - hermite(p0, p1, m0, m1, h, 1.0 - ds)) / (ds * h)
    np.testing.assert_allclose(v0, m0, atol=1e-5)
    np.testing.assert_allclose(v1, m1, atol=1e-5)


@pytest.mark.parametrize("normal", [(1, 0, 0), (0, 0, 1), (0, 0, -2), (1, -2, 0.5)])
def test_plane_basis_is_right_handed_and_in_plane(normal):
    """u, v are unit, orthogonal, normal to n and u x v = n / |n|."""
    n = np.array(normal, dtype=float)
    n /= np.linalg.norm(n)
    u, v = plane_basis(normal)
    assert np.linalg.norm(u) == pytest.approx(1.0) and np.linalg.norm(v) == pytest.approx(1.0)
    assert abs(u @ v) < 1e-12 and abs(u @ n) < 1e-12 and abs(v @ n) < 1e-12
    np.testing.assert_allclose(np.cross(u, v), n, atol=1e-12)


def test_plane_basis_frontal_plane():
    """For the frontal plane (n = +x) u = +y and v = +z (up)."""
    u, v = plane_basis([1, 0, 0])
    np.testing.assert_allclose(u, [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(v, [0, 0, 1], atol=1e-12)


# ----------------------------------------------------------------------------- motions
def test_circle_formula_and_plane():
    """p(t) = c + r (cos th u + sin th v): start at c + r u, a quarter turn at c + r v, every
    point r from c in the plane; reverse turns the other way."""
    c = Circle(C, 0.12, normal=[1, 0, 0], period=4.0)
    np.testing.assert_allclose(c.position(0.0), C + [0, 0.12, 0], atol=1e-12)
    np.testing.assert_allclose(c.position(1.0), C + [0, 0, 0.12], atol=1e-12)
    np.testing.assert_allclose(c.position(4.0), c.position(0.0), atol=1e-12)
    pts = c.positions(np.linspace(0, 4, 37))
    np.testing.assert_allclose(np.linalg.norm(pts - C, axis=1), 0.12, atol=1e-12)
    np.testing.assert_allclose((pts - C) @ [1, 0, 0], 0.0, atol=1e-12)
    r = Circle(C, 0.12, period=4.0, reverse=True)
    np.testing.assert_allclose(r.position(1.0), C - [0, 0, 0.12], atol=1e-12)


def test_circle_in_a_tilted_plane_with_phase():
    """A circle about a tilted normal stays in its plane; phase pi/2 starts at c + r v."""
    n = np.array([1.0, 1.0, 1.0]) / math.sqrt(3)
    c = Circle(C, 0.1, normal=n * 3, phase=math.pi / 2)
    _, v = plane_basis(n)
    np.testing.assert_allclose(c.position(0.0), C + 0.1 * v, atol=1e-12)
    pts = c.positions(np.linspace(0, 5, 50))
    np.testing.assert_allclose((pts - C) @ n, 0.0, atol=1e-12)


def test_figure_eight_formula():
    """p = c + (w/2) sin th u + (h/2) sin 2th v: centre at t = 0 and T/2, the widest point
    +w/2 along u at T/4, and extents w/2 and h/2."""
    f = FigureEight(C, 0.30, 0.16, normal=[1, 0, 0], period=6.0)
    np.testing.assert_allclose(f.position(0.0), C, atol=1e-12)
    np.testing.assert_allclose(f.position(3.0), C, atol=1e-12)
    np.testing.assert_allclose(f.position(1.5), C + [0, 0.15, 0], atol=1e-12)
    np.testing.assert_allclose(f.position(0.75), C + [0, 0.15 / math.sqrt(2), 0.08], atol=1e-12)
    pts = f.positions(np.linspace(0, 6, 601)) - C
    assert pts[:, 1].max() == pytest.approx(0.15, abs=1e-6)
    assert pts[:, 2].max() == pytest.approx(0.08, abs=1e-6)
    np.testing.assert_allclose(pts[:, 0], 0.0, atol=1e-12)


def test_lissajous_formula():
    """p_i = c_i + A_i sin(2 pi f_i t + phi_i) on each axis."""
    A, f, ph = np.array([0.0, 0.1, 0.2]), np.array([0.0, 0.5, 0.25]), np.array([0, 0, 1.0])
    L = Lissajous(C, A, f, ph)
    for t in (0.0, 0.3, 1.7, 5.0):
        np.testing.assert_allclose(
            L.position(t), C + A * np.sin(2 * math.pi * f * t + ph), atol=1e-12
        )


def test_points_hold_travel_and_loop():
    """Points: held for `hold`, half-way (smoothstep 1/2) mid-travel, looping back to the
    first; without loop the last point stays."""
    pts = [[0.3, -0.2, 1.0], [0.5, -0.2, 1.2], [0.4, -0.4, 1.3]]
    m = Points(pts, hold=1.0, travel=0.5)
    np.testing.assert_allclose(m.position(0.0), pts[0])
    np.testing.assert_allclose(m.position(0.99), pts[0])
    np.testing.assert_allclose(m.position(1.25), np.mean(pts[:2], axis=0), atol=1e-12)
    np.testing.assert_allclose(m.position(1.6), pts[1])
    np.testing.assert_allclose(m.position(4.25), np.mean([pts[2], pts[0]], axis=0), atol=1e-12)
    np.testing.assert_allclose(m.position(4.6), pts[0])
    once = Points(pts, hold=1.0, travel=0.5, loop=False)
    np.testing.assert_allclose(once.position(100.0), pts[2])
    jump = Points(pts, hold=1.0, travel=0.0)
    np.testing.assert_allclose(jump.position(1.0), pts[1])


def test_waypoints_linear_constant_speed():
    """Linear waypoints move at `speed` along straight segments and pass each point at the
    cumulative segment times; a closed loop returns to the first point."""
    pts = np.array([[0.3, -0.2, 1.0], [0.5, -0.2, 1.0], [0.5, -0.2, 1.3]])
    w = Waypoints(pts, speed=0.2, interpolation="linear", loop=True)
    np.testing.assert_allclose(w.times, [0.0, 1.0, 2.5, 2.5 + math.hypot(0.2, 0.3) / 0.2])
    np.testing.assert_allclose(w.position(1.0), pts[1], atol=1e-12)
    np.testing.assert_allclose(w.position(2.5), pts[2], atol=1e-12)
    np.testing.assert_allclose(w.position(w.duration), pts[0], atol=1e-12)
    dt = 0.01
    p = w.positions(np.arange(0.0, w.duration, dt))
    speeds = np.linalg.norm(np.diff(p, axis=0), axis=1) / dt
    corners = np.abs(speeds - 0.2) > 1e-6
    assert corners.sum() <= 3  # only the steps that cut a corner are shorter
    np.testing.assert_allclose(speeds[~corners], 0.2, atol=1e-9)


def test_waypoints_smooth_passes_points_with_continuous_velocity():
    """Smooth waypoints pass through every point at its time with the same velocity on
    both sides (C1), and an open path starts and ends at rest."""
    pts = np.array([[0.3, -0.2, 1.0], [0.5, -0.1, 1.1], [0.45, -0.3, 1.35], [0.3, -0.35, 1.2]])
    w = Waypoints(pts, speed=0.2, interpolation="smooth", loop=True)
    h = 1e-6
    for i in range(len(pts)):
        t = w.times[i]
        np.testing.assert_allclose(w.position(t), pts[i], atol=1e-12)
        if i > 0:
            left = (w.position(t) - w.position(t - h)) / h
            right = (w.position(t + h) - w.position(t)) / h
            np.testing.assert_allclose(left, right, atol=1e-4)
    o = Waypoints(pts, speed=0.2, interpolation="smooth", loop=False)
    v0 = (o.position(h) - o.position(0.0)) / h
    np.testing.assert_allclose(v0, 0.0, atol=1e-5)
    np.testing.assert_allclose(o.position(o.duration + 5), pts[-1])


def test_random_walk_is_seeded_bounded_and_order_free():
    """The same seed gives the same path whatever order times are asked in; another seed
    gives another path; the path stays in the box and passes every knot."""
    kw = {"center": C, "half_extent": [0.1, 0.05, 0.08], "step": 0.06, "interval": 0.5}
    times = np.linspace(0, 8, 161)
    a = RandomWalk(seed=3, **kw).positions(times)
    b_walk = RandomWalk(seed=3, **kw)
    late = b_walk.position(7.9)
    b = b_walk.positions(times)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(late, a[158], atol=0)
    c = RandomWalk(seed=4, **kw).positions(times)
    assert np.abs(a - c).max() > 0.01
    lo, hi = C - [0.1, 0.05, 0.08], C + [0.1, 0.05, 0.08]
    assert np.all(a >= lo - 1e-12) and np.all(a <= hi + 1e-12)
    np.testing.assert_allclose(a[0], C)
    walk = RandomWalk(seed=3, **kw)
    for k in range(1, 6):
        np.testing.assert_allclose(walk.position(0.5 * k), walk.knot(k), atol=1e-12)


def test_random_walk_reflect_folds_into_box():
    """reflect() mirrors a point at the box faces: 0.03 past a face lands 0.03 inside."""
    w = RandomWalk([0, 0, 0], [0.1, 0.1, 0.0], seed=0)
    np.testing.assert_allclose(w.reflect(np.array([0.13, -0.12, 0.5])), [0.07, -0.08, 0.0])


def test_out_and_back_phases():
    """Rest at start, ease out, hold at far, ease back, repeat with period rest+out+hold+back."""
    s, f = np.array([0.35, -0.3, 1.15]), np.array([1.05, -0.4, 1.45])
    m = OutAndBack(s, f, rest=1.0, out=1.5, hold=1.0, back=1.5)
    assert m.period == 5.0
    np.testing.assert_allclose(m.position(0.5), s)
    np.testing.assert_allclose(m.position(1.75), (s + f) / 2, atol=1e-12)
    np.testing.assert_allclose(m.position(3.0), f)
    np.testing.assert_allclose(m.position(4.25), (s + f) / 2, atol=1e-12)
    np.testing.assert_allclose(m.position(5.2), s)
    fr = [m.fraction(t) for t in np.linspace(1.0, 2.5, 20)]
    assert all(b >= a for a, b in zip(fr, fr[1:], strict=False))


def test_orientation_rocks_about_the_axis():
    """q(t) = exp(axis A sin(2 pi t / T)) q0: q(0) = q0, at T/4 the rotation from q0 is A
    about the axis; every q is unit."""
    q0 = np.array([0.7071068, 0.0, -0.7071068, 0.0])
    o = Orientation(q0, axis=[0, 0, 2], amplitude=0.3, period=4.0)
    np.testing.assert_allclose(o.quat_at(0.0), q0 / np.linalg.norm(q0), atol=1e-12)
    q = o.quat_at(1.0)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    # R(q) R(q0)' is the rocking rotation, applied in the world frame: 0.3 rad about +z
    rock = quat_to_mat(q) @ quat_to_mat(o.quat).T
    np.testing.assert_allclose(rotation_log(rock), [0.0, 0.0, 0.3], atol=1e-9)
    fixed = Orientation(q0)
    np.testing.assert_allclose(fixed.quat_at(3.0), fixed.quat)


def test_target_track_builds_targets():
    """A track gives a position target, or a pose target when it has an orientation."""
    m = Circle(C, 0.1)
    t = TargetTrack("ball", m)
    assert not t.is_pose and t.at(0.5).quat is None
    np.testing.assert_allclose(t.at(0.5).position, m.position(0.5))
    p = TargetTrack("ball", m, Orientation([1, 0, 0, 0]))
    assert p.is_pose
    np.testing.assert_allclose(p.at(0.0).quat, [1, 0, 0, 0])


def test_curves_in_floats_equal_their_array_formulas_to_the_bit():
    """Circle, FigureEight and OutAndBack compute their positions in floats: the same
    values, to the bit, as their formulas on numpy arrays, each call a new float64 (3,)
    array of its own."""
    n = np.array([1.0, 2.0, -0.5])
    c = Circle(C, 0.13, normal=n, period=2.7, phase=0.4, reverse=True)
    f = FigureEight(C, 0.26, 0.14, normal=n, period=6.0, phase=-1.1)
    s, far = np.array([0.35, -0.30, 1.15]), np.array([1.05, -0.40, 1.45])
    o = OutAndBack(s, far, rest=0.3, out=1.1, hold=0.2, back=0.9)
    u, v = plane_basis(n)
    for t in np.linspace(-0.5, 13.0, 301).tolist():
        th = c.angle(t)
        formulas = [
            (c, C + 0.13 * (math.cos(th) * u + math.sin(th) * v)),
            (
                f,
                C
                + 0.5 * 0.26 * math.sin(2 * math.pi * max(t, 0.0) / 6.0 - 1.1) * u
                + 0.5 * 0.14 * math.sin(2.0 * (2 * math.pi * max(t, 0.0) / 6.0 - 1.1)) * v,
            ),
            (o, s + o.fraction(t) * (far - s)),
        ]
        for motion, want in formulas:
            got = motion.position(t)
            assert got.dtype == np.float64 and got.shape == (3,) and got.flags.owndata
            np.testing.assert_array_equal(got, want)
            assert got is not motion.position(t)


def test_target_from_motion_takes_the_array_and_keeps_the_bound():
    """Target.from_motion keeps a motion's array (made read-only) and checks only its
    bound, with the constructor's errors; anything else gets the constructor's checks."""
    p = np.array([0.4, -0.3, 1.2])
    t = Target.from_motion(p)
    assert t.position is p and not p.flags.writeable and t.quat is None and t.rotation is None
    assert repr(t) == repr(Target([0.4, -0.3, 1.2])) and not t.is_pose
    for bad, message in (
        ([0.4, 2e6, 1.2], "target position [0.4, 2000000.0, 1.2] lies beyond 1e+06 m"),
        ([0.4, math.nan, 1.2], "target position [0.4, nan, 1.2] is not finite"),
        ([0.4, -0.3, 1.2, 0.0], "target position must have 3 values (x, y, z), got shape (4,)"),
    ):
        with pytest.raises(TargetError, match=re.escape(message)):
            Target.from_motion(np.array(bad))
    with pytest.raises(TargetError, match="target position must be numbers"):
        Target.from_motion(["a", 0, 0])  # type: ignore[arg-type]
    listed = Target.from_motion([1, 2, 3])  # type: ignore[arg-type]
    assert listed.position.dtype == np.float64 and listed.position.tolist() == [1.0, 2.0, 3.0]
    q = np.array([1.0 + 1e-7, 0.0, 0.0, 0.0])  # a pose goes through the constructor
    posed = Target.from_motion(np.array([0.1, 0.2, 0.3]), q)
    assert posed.quat is not None and posed.quat.tolist() == [1.0, 0.0, 0.0, 0.0]
    np.testing.assert_array_equal(posed.rotation, np.eye(3))


def test_a_track_past_the_coordinate_bound_is_a_target_error():
    """A motion that runs past 1e6 m gives the target error of user input, not a target."""
    far = TargetTrack("far", OutAndBack([0.0, 0.0, 1.0], [3e6, 0.0, 1.0], rest=0.0))
    assert far.at(0.0).position.tolist() == [0.0, 0.0, 1.0]
    with pytest.raises(TargetError, match="lies beyond 1e"):
        far.at(1.5)


def test_motion_registry_and_parameters():
    """Every motion kind is registered under its name; parameters() lists the init fields
    and required() those without defaults."""
    assert set(MOTIONS) == {
        "points",
        "circle",
        "figure8",
        "lissajous",
        "waypoints",
        "random_walk",
        "out_and_back",
    }
    assert Circle.required() == ["center", "radius"]
    assert "u" not in Circle.parameters() and "reverse" in Circle.parameters()
    assert "_knots" not in RandomWalk.parameters()


# ----------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("build", "field", "expected"),
    [
        (lambda: Circle(C, -1.0), "radius", "a number > 0"),
        (lambda: Circle(C, "big"), "radius", "a number > 0"),
        (lambda: Circle(C, 0.1, normal=[0, 0, 0]), "normal", "not all zero"),
        (lambda: Circle(C, 0.1, period=0), "period", "a number > 0"),
        (lambda: Circle(C, 0.1, reverse=1), "reverse", "true or false"),
        (lambda: Circle([1, 2], 0.1), "center", "3 numbers [x, y, z]"),
        (lambda: Circle([1, 2, float("nan")], 0.1), "center", "3 numbers"),
        (lambda: Circle("abc", 0.1), "center", "3 numbers"),
        (lambda: FigureEight(C, 0.0, 0.1), "width", "a number > 0"),
        (lambda: FigureEight(C, 0.1, -1), "height", "a number > 0"),
        (lambda: Lissajous(C, [0.1, -0.1, 0], [1, 1, 1]), "amplitude", "each >= 0"),
        (lambda: Lissajous(C, [0.1, 0.1, 0], [1, True, 1]), "frequency", "3 numbers"),
        (lambda: Points([]), "points", "at least 1 point"),
        (lambda: Points("here"), "points", "at least 1 point"),
        (lambda: Points([[1, 2, 3], [1, 2]]), "points[1]", "3 numbers"),
        (lambda: Points([[1, 2, 3]], hold=0), "hold", "a number > 0"),
        (lambda: Points([[1, 2, 3]], travel=-1), "travel", "a number >= 0"),
        (lambda: Waypoints([[1, 2, 3]]), "points", "at least 2 point"),
        (lambda: Waypoints([[1, 2, 3], [1, 2, 3]]), "points", "coincide"),
        (lambda: Waypoints([[1, 2, 3], [1, 2, 4]], speed=0), "speed", "a number > 0"),
        (
            lambda: Waypoints([[1, 2, 3], [1, 2, 4]], interpolation="cubic"),
            "interpolation",
            "one of 'linear', 'smooth'",
        ),
        (lambda: RandomWalk(C, [0.1, 0.1, 0.1], seed=-1), "seed", "an integer >= 0"),
        (lambda: RandomWalk(C, [0.1, 0.1, 0.1], seed=1.5), "seed", "an integer >= 0"),
        (lambda: RandomWalk(C, [0.1, 0.1, 0.1], step=0), "step", "a number > 0"),
        (lambda: RandomWalk(C, [0.1, -0.1, 0.1]), "half_extent", "each >= 0"),
        (lambda: OutAndBack(C, C, out=0), "out", "a number > 0"),
        (lambda: OutAndBack(C, C, rest=-1), "rest", "a number >= 0"),
        (lambda: Orientation([1, 1, 0, 0]), "quat", "a unit quaternion"),
        (lambda: Orientation([0, 0, 0, 0]), "quat", "not all zero"),
        (lambda: Orientation([1, 0, 0, 0], axis=[0, 0, 0]), "axis", "not all zero"),
        (lambda: Orientation([1, 0, 0, 0], amplitude=-0.1), "amplitude", "a number >= 0"),
    ],
)
def test_bad_parameters_name_the_field(build, field, expected):
    """Each bad parameter raises MotionError naming the field, the expectation and the
    value given."""
    with pytest.raises(MotionError) as info:
        build()
    assert info.value.field == field
    assert expected in info.value.expected
    assert str(info.value).startswith(f"{field}: expected ")


def test_error_message_shows_the_value_as_toml():
    """The message shows strings quoted, booleans as true/false and lists in brackets."""
    with pytest.raises(MotionError, match=r"^radius: expected a number > 0, got 'big'$"):
        Circle(C, "big")
    with pytest.raises(MotionError, match=r"got true$"):
        Circle(C, True)
    with pytest.raises(MotionError, match=r"got \[1, 2\]$"):
        check_vector("center", [1, 2])
    with pytest.raises(MotionError, match=r"an integer, got 'x'$"):
        check_int("n", "x")


def test_random_walk_keeps_a_bounded_number_of_knots():
    """A random walk draws at most MAX_KNOTS knots: it reaches ``horizon`` seconds, and a
    later time (or knot) is a MotionError at once, without drawing knots first."""
    walk = RandomWalk([0.4, -0.3, 1.2], [0.1, 0.1, 0.1], interval=0.5)
    assert walk.horizon == (MAX_KNOTS - 3) * 0.5
    tiny = RandomWalk([0.4, -0.3, 1.2], [0.1, 0.1, 0.1], interval=1e-6)
    end = tiny.position(tiny.horizon)  # the last instant it covers works
    assert np.all(np.isfinite(end)) and len(tiny._knots) <= MAX_KNOTS
    with pytest.raises(MotionError, match=r"^t: expected a time <= 0.099997 s"):
        tiny.position(tiny.horizon * 1.001)
    with pytest.raises(MotionError, match=r"^knot: expected an index < 100000"):
        walk.knot(MAX_KNOTS)
    assert len(walk._knots) == 1


def test_points_are_bounded():
    """At most MAX_POINTS points; the message gives the count, not the list."""
    Points([[0.0, 0.0, 0.0]] * MAX_POINTS)
    with pytest.raises(MotionError) as err:
        Waypoints([[0.0, 0.0, float(i)] for i in range(MAX_POINTS + 1)])
    assert str(err.value) == f"points: expected at most {MAX_POINTS} points, got {MAX_POINTS + 1}"
