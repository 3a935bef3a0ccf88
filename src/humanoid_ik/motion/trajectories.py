"""Target motions: where a target is at time ``t`` [s].

Every motion is a frozen dataclass whose parameters are checked in ``__post_init__``
(a bad one raises :class:`~humanoid_ik.errors.TrajectoryError` naming the parameter,
what it must be and what it was) and whose :meth:`Motion.position` is a pure function
of time, so a scene renders the same frames every run.

Motions: :class:`Points` (fixed points with holds), :class:`Circle` (in any plane),
:class:`FigureEight`, :class:`Lissajous`, :class:`Waypoints` (linear or smooth),
:class:`RandomWalk` (seeded) and :class:`OutAndBack` (leaves the workspace and returns).
:class:`Orientation` gives a target orientation over time (for pose targets) and
:class:`TargetTrack` puts a motion and an orientation together into a
:class:`~humanoid_ik.core.types.Target` per instant.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from humanoid_ik.core.types import Target
from humanoid_ik.errors import TrajectoryError

__all__ = [
    "MOTIONS",
    "Circle",
    "FigureEight",
    "Lissajous",
    "Motion",
    "Orientation",
    "OutAndBack",
    "Points",
    "RandomWalk",
    "TargetTrack",
    "Waypoints",
    "hermite",
    "plane_basis",
    "smoothstep",
]


# ----------------------------------------------------------------------------- checks
# Shared with the scene loader: each returns the converted value or raises
# TrajectoryError(field, expected, got).
def check_number(name: str, value: Any, *, low: float | None = None, strict: bool = False) -> float:
    """``value`` as a finite float, ``> low`` (``strict``) or ``>= low``."""
    if low is None:
        expected = "a number"
    else:
        expected = f"a number {'>' if strict else '>='} {low:g}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
        raise TrajectoryError(name, expected, value)
    v = float(value)
    if not math.isfinite(v):
        raise TrajectoryError(name, expected, value)
    if low is not None and (v <= low if strict else v < low):
        raise TrajectoryError(name, expected, value)
    return v


def check_int(name: str, value: Any, *, low: int | None = None) -> int:
    """``value`` as an int ``>= low`` (a float with an integer value is accepted)."""
    expected = "an integer" if low is None else f"an integer >= {low}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer)):
        raise TrajectoryError(name, expected, value)
    if isinstance(value, float) and (not math.isfinite(value) or value != int(value)):
        raise TrajectoryError(name, expected, value)
    v = int(value)
    if low is not None and v < low:
        raise TrajectoryError(name, expected, value)
    return v


def check_bool(name: str, value: Any) -> bool:
    """``value`` when it is ``true`` or ``false``."""
    if not isinstance(value, (bool, np.bool_)):
        raise TrajectoryError(name, "true or false", value)
    return bool(value)


def check_vector(
    name: str, value: Any, n: int = 3, *, low: float | None = None, nonzero: bool = False
) -> NDArray[np.float64]:
    """``value`` as a read-only float64 ``(n,)`` array of finite numbers."""
    what = {3: "[x, y, z]", 4: "[w, x, y, z]"}.get(n, f"{n} numbers")
    expected = f"{n} numbers {what}" if n in (3, 4) else what
    if low is not None:
        expected += f", each >= {low:g}"
    if nonzero:
        expected += ", not all zero"
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TrajectoryError(name, expected, value)
    items = list(value)
    if len(items) != n or any(
        isinstance(v, bool) or not isinstance(v, (int, float, np.number)) for v in items
    ):
        raise TrajectoryError(name, expected, value)
    arr = np.array(items, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise TrajectoryError(name, expected, value)
    if low is not None and np.any(arr < low):
        raise TrajectoryError(name, expected, value)
    if nonzero and float(np.linalg.norm(arr)) < 1e-12:
        raise TrajectoryError(name, expected, value)
    arr.setflags(write=False)
    return arr


def check_points(name: str, value: Any, *, minimum: int = 1) -> NDArray[np.float64]:
    """``value`` as a read-only ``(N, 3)`` array with ``N >= minimum``."""
    expected = f"a list of at least {minimum} point(s) [x, y, z]"
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)):
        raise TrajectoryError(name, expected, value)
    if len(value) < minimum:
        raise TrajectoryError(name, expected, value)
    rows = [check_vector(f"{name}[{i}]", p) for i, p in enumerate(value)]
    arr = np.array(rows, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def check_choice(name: str, value: Any, valid: Sequence[str]) -> str:
    """``value`` when it is one of ``valid``."""
    if not isinstance(value, str) or value not in valid:
        raise TrajectoryError(name, f"one of {', '.join(repr(v) for v in valid)}", value)
    return value


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


# ----------------------------------------------------------------------------- helpers
def smoothstep(u: float) -> float:
    """Cosine ease ``s(u) = (1 - cos(pi u)) / 2`` for ``u`` clipped to [0, 1].

    ``s(0) = 0``, ``s(1) = 1`` and ``s'(0) = s'(1) = 0``: the target starts and stops at rest.
    """
    u = min(max(u, 0.0), 1.0)
    return 0.5 * (1.0 - math.cos(math.pi * u))


def hermite(
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    m0: NDArray[np.float64],
    m1: NDArray[np.float64],
    h: float,
    s: float,
) -> NDArray[np.float64]:
    """Cubic Hermite point on a segment of duration ``h`` [s] at fraction ``s`` in [0, 1].

    ``p(s) = (2s^3 - 3s^2 + 1) p0 + (s^3 - 2s^2 + s) h m0 + (-2s^3 + 3s^2) p1
    + (s^3 - s^2) h m1`` with end velocities ``m0``, ``m1`` in [m/s].
    """
    s2, s3 = s * s, s * s * s
    return (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * h * m0
        + (-2 * s3 + 3 * s2) * p1
        + (s3 - s2) * h * m1
    )


def plane_basis(normal: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit in-plane axes ``(u, v)`` of the plane with ``normal``, with ``u x v = n``.

    ``v`` is the in-plane direction closest to world up (+z), or to +x when the plane is
    horizontal; ``u = v x n``. For the frontal plane (``n = +x``, the humanoid faces +x)
    ``u = +y`` and ``v = +z``.
    """
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    ref = np.array([0.0, 0.0, 1.0])
    if abs(float(n @ ref)) > 0.999:
        ref = np.array([1.0, 0.0, 0.0])
    v = ref - float(ref @ n) * n
    v /= np.linalg.norm(v)
    u = np.cross(v, n)
    return u, v


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


# ----------------------------------------------------------------------------- motions
class Motion(ABC):
    """Where a target is over time. Subclasses are frozen dataclasses."""

    kind: ClassVar[str]
    """The name a scene file uses in ``motion.kind``."""
    summary: ClassVar[str]

    @abstractmethod
    def position(self, t: float) -> NDArray[np.float64]:
        """Target position ``(3,)`` [m] at time ``t`` [s] (``t < 0`` is read as 0)."""

    def positions(self, times: ArrayLike) -> NDArray[np.float64]:
        """Positions ``(N, 3)`` [m] at each of ``times`` ``(N,)`` [s]."""
        return np.array([self.position(float(t)) for t in np.asarray(times, dtype=np.float64)])

    @classmethod
    def parameters(cls) -> list[str]:
        """The parameter names (the keys a scene's ``motion`` table may hold besides kind)."""
        return [f.name for f in fields(cls) if f.init]  # type: ignore[arg-type]

    @classmethod
    def required(cls) -> list[str]:
        """Parameters without a default."""
        from dataclasses import MISSING

        return [
            f.name
            for f in fields(cls)  # type: ignore[arg-type]
            if f.init and f.default is MISSING and f.default_factory is MISSING
        ]


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
        _set(self, "points", check_points("points", self.points))
        _set(self, "hold", check_number("hold", self.hold, low=0.0, strict=True))
        _set(self, "travel", check_number("travel", self.travel, low=0.0))
        _set(self, "loop", check_bool("loop", self.loop))

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


@dataclass(frozen=True)
class Circle(Motion):
    """A circle in the plane through ``center`` with ``normal``.

    ``p(t) = c + r (cos th u + sin th v)``, ``th = 2 pi t / period + phase`` (negated when
    ``reverse``), with ``(u, v)`` from :func:`plane_basis`: counter-clockwise seen from
    the side the normal points to.

    Args:
        center: ``(3,)`` [m].
        radius: [m], > 0.
        normal: plane normal ``(3,)``, not zero (default +x: the frontal plane).
        period: time of one turn [s], > 0.
        phase: start angle [rad].
        reverse: turn clockwise instead.
    """

    kind: ClassVar[str] = "circle"
    summary: ClassVar[str] = "a circle in any plane"
    center: NDArray[np.float64]
    radius: float
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    period: float = 4.0
    phase: float = 0.0
    reverse: bool = False
    u: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    v: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _set(self, "center", check_vector("center", self.center))
        _set(self, "radius", check_number("radius", self.radius, low=0.0, strict=True))
        _set(self, "normal", check_vector("normal", self.normal, nonzero=True))
        _set(self, "period", check_number("period", self.period, low=0.0, strict=True))
        _set(self, "phase", check_number("phase", self.phase))
        _set(self, "reverse", check_bool("reverse", self.reverse))
        u, v = plane_basis(self.normal)
        _set(self, "u", u)
        _set(self, "v", v)

    def angle(self, t: float) -> float:
        """``th(t)`` [rad]."""
        th = 2.0 * math.pi * max(t, 0.0) / self.period
        return (-th if self.reverse else th) + self.phase

    def position(self, t: float) -> NDArray[np.float64]:
        th = self.angle(t)
        return self.center + self.radius * (math.cos(th) * self.u + math.sin(th) * self.v)


@dataclass(frozen=True)
class FigureEight(Motion):
    """A figure-eight (a 1:2 Lissajous curve) in the plane through ``center``.

    ``p(t) = c + (w/2) sin(th) u + (h/2) sin(2 th) v`` with ``th = 2 pi t / period + phase``
    and ``(u, v)`` from :func:`plane_basis`: lying (like infinity) ``width`` across and
    ``height`` tall; it crosses itself at the centre.

    Args:
        center: ``(3,)`` [m].
        width: extent along ``u`` [m], > 0.
        height: extent along ``v`` [m], > 0.
        normal: plane normal ``(3,)`` (default +x).
        period: time of one loop [s], > 0.
        phase: start angle [rad].
    """

    kind: ClassVar[str] = "figure8"
    summary: ClassVar[str] = "a figure-eight in any plane"
    center: NDArray[np.float64]
    width: float
    height: float
    normal: NDArray[np.float64] = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    period: float = 6.0
    phase: float = 0.0
    u: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    v: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _set(self, "center", check_vector("center", self.center))
        _set(self, "width", check_number("width", self.width, low=0.0, strict=True))
        _set(self, "height", check_number("height", self.height, low=0.0, strict=True))
        _set(self, "normal", check_vector("normal", self.normal, nonzero=True))
        _set(self, "period", check_number("period", self.period, low=0.0, strict=True))
        _set(self, "phase", check_number("phase", self.phase))
        u, v = plane_basis(self.normal)
        _set(self, "u", u)
        _set(self, "v", v)

    def position(self, t: float) -> NDArray[np.float64]:
        th = 2.0 * math.pi * max(t, 0.0) / self.period + self.phase
        return (
            self.center
            + 0.5 * self.width * math.sin(th) * self.u
            + 0.5 * self.height * math.sin(2.0 * th) * self.v
        )


@dataclass(frozen=True)
class Lissajous(Motion):
    """A Lissajous curve: ``p_i(t) = c_i + A_i sin(2 pi f_i t + phi_i)`` per world axis.

    Args:
        center: ``(3,)`` [m].
        amplitude: ``(3,)`` [m], each >= 0.
        frequency: ``(3,)`` [Hz], each >= 0.
        phase: ``(3,)`` [rad].
    """

    kind: ClassVar[str] = "lissajous"
    summary: ClassVar[str] = "a Lissajous curve (a sine per axis)"
    center: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    frequency: NDArray[np.float64]
    phase: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        _set(self, "center", check_vector("center", self.center))
        _set(self, "amplitude", check_vector("amplitude", self.amplitude, low=0.0))
        _set(self, "frequency", check_vector("frequency", self.frequency, low=0.0))
        _set(self, "phase", check_vector("phase", self.phase))

    def position(self, t: float) -> NDArray[np.float64]:
        t = max(t, 0.0)
        return self.center + self.amplitude * np.sin(
            2.0 * math.pi * self.frequency * t + self.phase
        )


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
        _set(self, "points", pts)
        _set(self, "speed", check_number("speed", self.speed, low=0.0, strict=True))
        _set(
            self,
            "interpolation",
            check_choice("interpolation", self.interpolation, self.interpolation_choices),
        )
        _set(self, "loop", check_bool("loop", self.loop))
        ring = np.vstack([pts, pts[:1]]) if self.loop else pts
        lengths = np.linalg.norm(np.diff(ring, axis=0), axis=1)
        if np.any(lengths < 1e-9):
            i = int(np.argmax(lengths < 1e-9))
            raise TrajectoryError(
                "points",
                f"consecutive points apart (points[{i}] and points[{(i + 1) % len(pts)}] coincide)",
                self.points.tolist(),
            )
        times = np.concatenate([[0.0], np.cumsum(lengths / self.speed)])
        _set(self, "times", times)
        _set(self, "velocities", _hermite_tangents(pts, times, self.loop))

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
    ``k_0``), so a seed always gives the same path.

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
        _set(self, "center", check_vector("center", self.center))
        _set(self, "half_extent", check_vector("half_extent", self.half_extent, low=0.0))
        _set(self, "step", check_number("step", self.step, low=0.0, strict=True))
        _set(self, "interval", check_number("interval", self.interval, low=0.0, strict=True))
        _set(self, "seed", check_int("seed", self.seed, low=0))
        start = self.center if self.start is None else check_vector("start", self.start)
        _set(self, "start", start)
        _set(self, "_rng", np.random.default_rng(self.seed))
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

    def knot(self, i: int) -> NDArray[np.float64]:
        """Knot ``i`` ``(3,)`` [m] (drawn in order, so knot ``i`` never depends on the caller)."""
        while len(self._knots) <= i:
            step = self._rng.normal(0.0, self.step, 3)
            self._knots.append(self.reflect(self._knots[-1] + step))
        return self._knots[i]

    def position(self, t: float) -> NDArray[np.float64]:
        t = max(t, 0.0)
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

    def __post_init__(self) -> None:
        _set(self, "start", check_vector("start", self.start))
        _set(self, "far", check_vector("far", self.far))
        _set(self, "rest", check_number("rest", self.rest, low=0.0))
        _set(self, "out", check_number("out", self.out, low=0.0, strict=True))
        _set(self, "hold", check_number("hold", self.hold, low=0.0))
        _set(self, "back", check_number("back", self.back, low=0.0, strict=True))

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
        return self.start + self.fraction(t) * (self.far - self.start)


MOTIONS: dict[str, type[Motion]] = {
    cls.kind: cls
    for cls in (Points, Circle, FigureEight, Lissajous, Waypoints, RandomWalk, OutAndBack)
}


# ----------------------------------------------------------------------------- orientation
def _quat_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


@dataclass(frozen=True)
class Orientation:
    """A target orientation over time: ``quat`` rocked about a world ``axis``.

    ``q(t) = exp(axis * amplitude * sin(2 pi t / period)) * quat`` (wxyz, the rocking
    applied in the world frame); ``amplitude = 0`` holds ``quat``.

    Args:
        quat: unit quaternion ``(4,)`` wxyz (norm within 1e-3 of 1).
        axis: rocking axis ``(3,)``, not zero (default +z).
        amplitude: rocking amplitude [rad], >= 0.
        period: rocking period [s], > 0.
    """

    quat: NDArray[np.float64]
    axis: NDArray[np.float64] = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    amplitude: float = 0.0
    period: float = 4.0

    def __post_init__(self) -> None:
        q = check_vector("quat", self.quat, 4, nonzero=True)
        if abs(float(np.linalg.norm(q)) - 1.0) > 1e-3:
            raise TrajectoryError("quat", "a unit quaternion [w, x, y, z]", self.quat)
        q = q / np.linalg.norm(q)
        q.setflags(write=False)
        _set(self, "quat", q)
        a = check_vector("axis", self.axis, nonzero=True)
        a = a / np.linalg.norm(a)
        a.setflags(write=False)
        _set(self, "axis", a)
        _set(self, "amplitude", check_number("amplitude", self.amplitude, low=0.0))
        _set(self, "period", check_number("period", self.period, low=0.0, strict=True))

    @classmethod
    def parameters(cls) -> list[str]:
        """The keys a scene's ``orientation`` table may hold."""
        return [f.name for f in fields(cls)]

    def quat_at(self, t: float) -> NDArray[np.float64]:
        """Unit wxyz quaternion ``(4,)`` at time ``t`` [s]."""
        if self.amplitude == 0.0:
            return np.array(self.quat)
        angle = self.amplitude * math.sin(2.0 * math.pi * max(t, 0.0) / self.period)
        rock = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * self.axis])
        return _quat_mul(rock, self.quat)


@dataclass(frozen=True)
class TargetTrack:
    """A named target: a motion and, for pose targets, an orientation.

    Args:
        name: the target's name (effectors refer to it).
        motion: where it is over time.
        orientation: its orientation over time, or ``None`` for a position target.
    """

    name: str
    motion: Motion
    orientation: Orientation | None = None

    @property
    def is_pose(self) -> bool:
        """True when the target has an orientation."""
        return self.orientation is not None

    def at(self, t: float) -> Target:
        """The :class:`~humanoid_ik.core.types.Target` at time ``t`` [s]."""
        quat = None if self.orientation is None else self.orientation.quat_at(t)
        return Target(self.motion.position(t), quat)
