"""Paths through points: :class:`Points` (fixed points with holds), :class:`Waypoints`
(linear or smooth), :class:`RandomWalk` (seeded) and :class:`OutAndBack` (leaves the
workspace and returns)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.checks import (
    check_bool,
    check_choice,
    check_int,
    check_number,
    check_points,
    check_vector,
)
from humanoid_ik.errors import MotionError
from humanoid_ik.motion.base import Motion, hermite, set_frozen, smoothstep

__all__ = ["MAX_KNOTS", "OutAndBack", "Points", "RandomWalk", "Waypoints"]

MAX_KNOTS = 100_000
"""Most knots a :class:`RandomWalk` draws and keeps (about 12 MB); it runs for
``(MAX_KNOTS - 3) * interval`` seconds (its :attr:`~RandomWalk.horizon`)."""


@dataclass(frozen=True)
class Points(Motion):
    """Fixed points held in turn: ``hold`` [s] at each point, ``travel`` [s] between them.

    A move from ``a`` to ``b`` follows ``a + smoothstep(u) (b - a)``; ``travel = 0`` jumps.
    With ``loop`` the sequence repeats (back to the first point), else it stays at the last.

    Args:
        points: ``(N, 3)`` [m], at least one.
        hold: time at each point [s], > 0.
        travel: time of each move [s], >= 0.
        loop: repeat the sequence.
    """

    kind: ClassVar[str] = "points"
    summary: ClassVar[str] = "fixed points, each held for a while"
    points: NDArray[np.float64]
    hold: float = 1.0
    travel: float = 0.5
    loop: bool = True

    def __post_init__(self) -> None:
        set_frozen(self, "points", check_points("points", self.points))
        set_frozen(self, "hold", check_number("hold", self.hold, low=0.0, strict=True))
        set_frozen(self, "travel", check_number("travel", self.travel, low=0.0))
        set_frozen(self, "loop", check_bool("loop", self.loop))

    def position(self, t: float) -> NDArray[np.float64]:
        pts = self.points
        n = len(pts)
        step = self.hold + self.travel
        t = max(t, 0.0)
        if self.loop:
            t = math.fmod(t, n * step)
        i = int(t // step)
        if i >= n:
            return pts[-1].copy()
        into = t - i * step
        if into <= self.hold or self.travel == 0.0 or (i == n - 1 and not self.loop):
            return pts[i].copy()
        nxt = pts[(i + 1) % n]
        s = smoothstep((into - self.hold) / self.travel)
        return pts[i] + s * (nxt - pts[i])


def _hermite_tangents(
    pts: NDArray[np.float64], times: NDArray[np.float64], closed: bool
) -> NDArray[np.float64]:
    """Finite-difference velocities [m/s] at the knots (zero at the ends of an open path)."""
    n = len(pts)
    m = np.zeros_like(pts)
    if n < 3 and not closed:
        return m
    for i in range(n):
        if closed:
            prev_p, next_p = pts[(i - 1) % n], pts[(i + 1) % n]
            h_prev = times[i] - times[i - 1] if i > 0 else times[n] - times[n - 1]
            h_next = times[i + 1] - times[i]
            m[i] = (next_p - prev_p) / (h_prev + h_next)
        elif 0 < i < n - 1:
            m[i] = (pts[i + 1] - pts[i - 1]) / (times[i + 1] - times[i - 1])
    return m


@dataclass(frozen=True)
class Waypoints(Motion):
    """A path through ``points`` at ``speed``: straight segments (``linear``) or a C1 cubic
    Hermite spline through every point (``smooth``).

    Segment ``i`` lasts ``h_i = |p_{i+1} - p_i| / speed``. ``linear`` moves at constant
    speed; ``smooth`` uses the velocities ``m_i = (p_{i+1} - p_{i-1}) / (t_{i+1} - t_{i-1})``
    (zero at the ends of an open path) in :func:`hermite`. With ``loop`` the path closes
    back to the first point and repeats; else the target stays at the last point.

    Args:
        points: ``(N, 3)`` [m], at least 2.
        speed: [m/s], > 0.
        interpolation: ``linear`` or ``smooth``.
        loop: close the path and repeat it.
    """

    kind: ClassVar[str] = "waypoints"
    summary: ClassVar[str] = "a path through waypoints, linear or smooth"
    interpolation_choices: ClassVar[tuple[str, ...]] = ("linear", "smooth")
    points: NDArray[np.float64]
    speed: float = 0.2
    interpolation: str = "smooth"
    loop: bool = True
    times: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    velocities: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        pts = check_points("points", self.points, minimum=2)
        set_frozen(self, "points", pts)
        set_frozen(self, "speed", check_number("speed", self.speed, low=0.0, strict=True))
        set_frozen(
            self,
            "interpolation",
            check_choice("interpolation", self.interpolation, self.interpolation_choices),
        )
        set_frozen(self, "loop", check_bool("loop", self.loop))
        ring = np.vstack([pts, pts[:1]]) if self.loop else pts
        lengths = np.linalg.norm(np.diff(ring, axis=0), axis=1)
        if np.any(lengths < 1e-9):
            i = int(np.argmax(lengths < 1e-9))
            raise MotionError(
                "points",
                f"consecutive points apart (points[{i}] and points[{(i + 1) % len(pts)}] coincide)",
                self.points.tolist(),
            )
        times = np.concatenate([[0.0], np.cumsum(lengths / self.speed)])
        set_frozen(self, "times", times)
        set_frozen(self, "velocities", _hermite_tangents(pts, times, self.loop))

    @property
    def duration(self) -> float:
        """Time of one pass along the path [s]."""
        return float(self.times[-1])

    def position(self, t: float) -> NDArray[np.float64]:
        pts, times = self.points, self.times
        t = max(t, 0.0)
        if self.loop:
            t = math.fmod(t, self.duration)
        elif t >= self.duration:
            return pts[-1].copy()
        i = int(np.searchsorted(times, t, side="right")) - 1
        i = min(max(i, 0), len(times) - 2)
        h = float(times[i + 1] - times[i])
        s = (t - times[i]) / h
        j = (i + 1) % len(pts)
        if self.interpolation == "linear":
            return pts[i] + s * (pts[j] - pts[i])
        return hermite(pts[i], pts[j], self.velocities[i], self.velocities[j], h, s)


@dataclass(frozen=True)
class RandomWalk(Motion):
    """A seeded random walk inside a box, smoothed by a cubic Hermite spline.

    Knots come every ``interval`` [s]: ``k_0 = start`` and
    ``k_{i+1} = reflect(k_i + N(0, step^2 I))`` with a ``numpy`` generator seeded by
    ``seed`` and each coordinate reflected back into ``center +- half_extent``. The
    target passes through every knot with velocities by finite differences (zero at
    ``k_0``), so a seed always gives the same path. Knots are kept once drawn, at most
    :data:`MAX_KNOTS` of them: the walk covers :attr:`horizon` seconds, and a time past
    it is a :class:`~humanoid_ik.errors.MotionError`.

    Args:
        center: box centre ``(3,)`` [m].
        half_extent: box half sizes ``(3,)`` [m], each >= 0.
        step: standard deviation of a step per axis [m], > 0.
        interval: time between knots [s], > 0.
        seed: generator seed, an integer >= 0.
        start: first knot ``(3,)`` [m] (default: the centre), moved into the box.
    """

    kind: ClassVar[str] = "random_walk"
    summary: ClassVar[str] = "a seeded random walk in a box"
    center: NDArray[np.float64]
    half_extent: NDArray[np.float64]
    step: float = 0.05
    interval: float = 0.5
    seed: int = 0
    start: NDArray[np.float64] | None = None
    _knots: list[NDArray[np.float64]] = field(
        init=False, repr=False, compare=False, default_factory=list
    )
    _rng: np.random.Generator = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_frozen(self, "center", check_vector("center", self.center))
        set_frozen(self, "half_extent", check_vector("half_extent", self.half_extent, low=0.0))
        set_frozen(self, "step", check_number("step", self.step, low=0.0, strict=True))
        set_frozen(self, "interval", check_number("interval", self.interval, low=0.0, strict=True))
        set_frozen(self, "seed", check_int("seed", self.seed, low=0))
        start = self.center if self.start is None else check_vector("start", self.start)
        set_frozen(self, "start", start)
        set_frozen(self, "_rng", np.random.default_rng(self.seed))
        self._knots.append(self.reflect(np.array(start, dtype=np.float64)))

    def reflect(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        """``p`` folded back into the box, mirror-wise at each face."""
        lo = self.center - self.half_extent
        w = 2.0 * self.half_extent
        out = p.copy()
        for i in range(3):
            if w[i] == 0.0:
                out[i] = lo[i]
                continue
            y = math.fmod(p[i] - lo[i], 2.0 * w[i])
            if y < 0:
                y += 2.0 * w[i]
            out[i] = lo[i] + (2.0 * w[i] - y if y > w[i] else y)
        return out

    @property
    def horizon(self) -> float:
        """The latest time [s] the walk reaches with :data:`MAX_KNOTS` knots."""
        return (MAX_KNOTS - 3) * self.interval

    def knot(self, i: int) -> NDArray[np.float64]:
        """Knot ``i`` ``(3,)`` [m] (drawn in order, so knot ``i`` never depends on the caller).

        Raises:
            MotionError: ``i >= MAX_KNOTS``.
        """
        if i >= MAX_KNOTS:
            raise MotionError("knot", f"an index < {MAX_KNOTS} (MAX_KNOTS)", i)
        while len(self._knots) <= i:
            step = self._rng.normal(0.0, self.step, 3)
            self._knots.append(self.reflect(self._knots[-1] + step))
        return self._knots[i]

    def position(self, t: float) -> NDArray[np.float64]:
        t = max(t, 0.0)
        if not t <= self.horizon:
            raise MotionError(
                "t",
                f"a time <= {self.horizon:g} s (a random_walk draws at most {MAX_KNOTS} "
                f"knots, one every interval = {self.interval:g} s)",
                t,
            )
        h = self.interval
        i = int(t // h)
        s = t / h - i
        p0, p1 = self.knot(i), self.knot(i + 1)
        m0 = np.zeros(3) if i == 0 else (p1 - self.knot(i - 1)) / (2.0 * h)
        m1 = (self.knot(i + 2) - p0) / (2.0 * h)
        return self.reflect(hermite(p0, p1, m0, m1, h, s))


@dataclass(frozen=True)
class OutAndBack(Motion):
    """Leaves the reachable workspace and comes back, on repeat.

    Rests at ``start`` for ``rest`` [s], moves to ``far`` in ``out`` [s], holds there for
    ``hold`` [s], returns in ``back`` [s]; each move eases with :func:`smoothstep`. Put
    ``start`` within reach and ``far`` beyond it: the arm points at the target while it
    is away and recovers when it returns.

    Args:
        start: ``(3,)`` [m].
        far: ``(3,)`` [m].
        rest, out, hold, back: phase durations [s]; ``out`` and ``back`` > 0, the others
            >= 0.
    """

    kind: ClassVar[str] = "out_and_back"
    summary: ClassVar[str] = "leaves the workspace and comes back"
    start: NDArray[np.float64]
    far: NDArray[np.float64]
    rest: float = 1.0
    out: float = 1.5
    hold: float = 1.0
    back: float = 1.5
    _floats: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_frozen(self, "start", check_vector("start", self.start))
        set_frozen(self, "far", check_vector("far", self.far))
        set_frozen(self, "_floats", (*self.start.tolist(), *(self.far - self.start).tolist()))
        set_frozen(self, "rest", check_number("rest", self.rest, low=0.0))
        set_frozen(self, "out", check_number("out", self.out, low=0.0, strict=True))
        set_frozen(self, "hold", check_number("hold", self.hold, low=0.0))
        set_frozen(self, "back", check_number("back", self.back, low=0.0, strict=True))

    @property
    def period(self) -> float:
        """Time of one excursion [s]: ``rest + out + hold + back``."""
        return self.rest + self.out + self.hold + self.back

    def fraction(self, t: float) -> float:
        """How far along from ``start`` (0) to ``far`` (1) the target is at ``t``."""
        t = math.fmod(max(t, 0.0), self.period)
        if t < self.rest:
            return 0.0
        t -= self.rest
        if t < self.out:
            return smoothstep(t / self.out)
        t -= self.out
        if t < self.hold:
            return 1.0
        t -= self.hold
        return 1.0 - smoothstep(t / self.back)

    def position(self, t: float) -> NDArray[np.float64]:
        # start + f (far - start) per coordinate in floats (the array expression's order)
        f = self.fraction(t)
        s0, s1, s2, d0, d1, d2 = self._floats
        return np.array((s0 + f * d0, s1 + f * d1, s2 + f * d2))
