"""The options of the mink solver: the one place their defaults and bounds are written.

:class:`MinkOptions` is what ``make_solver("mink", ...)``, scene and sweep files and
:class:`~humanoid_ik.solvers.mink.upper_body.UpperBodyIK` all take. Checks, in order:

- every field by the rule of :mod:`humanoid_ik.solvers.options` (type from the default;
  a number finite and >= 0; the ``BOUNDS`` below, inclusive);
- then, when the object is made (also when it is made directly, not parsed): the options
  that must be strictly positive (:data:`POSITIVE`) and ``collision_pairs``
  (:func:`collision_pairs_problem`), normalised to tuples so the object stays hashable.

This module does not import mink.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from humanoid_ik.core.rotations import SIGNED_AXES
from humanoid_ik.errors import SolverError
from humanoid_ik.solvers.options import SolverOptions, option

__all__ = [
    "NAME",
    "POSITIVE",
    "CollisionPairs",
    "GeomGroup",
    "LIMBS",
    "MinkOptions",
    "collision_pairs_problem",
]

NAME = "mink"
"""The solver's name (in messages and results)."""

GeomGroup = tuple[str, ...]
"""Geom names, every one of which is kept apart from every geom of the other group."""
CollisionPairs = tuple[tuple[GeomGroup, GeomGroup], ...]
"""Pairs of geom groups kept apart."""
LIMBS = "limbs"
"""The ``collision_pairs`` value asking for the pairs derived from the model's limbs
(:func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`)."""

POSITIVE = frozenset(
    {"max_step", "max_velocity", "range_gain", "collision_gain", "detection_distance"}
)
"""Options that must be > 0 (their lower bound 0 itself is refused): a step, a speed,
a gain or a detection distance of 0 would never move or never see a pair."""

_PAIRS_SHAPE = f"pairs of geom-name groups, [[names], [names]], or '{LIMBS}'"


def collision_pairs_problem(value: Any) -> tuple[str, str, Any] | None:
    """What is wrong with ``value`` as ``collision_pairs``, or ``None`` when it fits.

    The shape: ``"limbs"`` (:data:`LIMBS`: the pairs derived from the model's limbs),
    or a list of pairs; a pair is a list of two groups; a group is a geom name or a
    non-empty list of geom names (non-empty strings). Names are not checked against a
    model here (the solver does that when it is built, and a scene file when it is
    loaded).

    Returns:
        ``(where, expected, got)``: the index path inside ``collision_pairs`` (``""``,
        ``"[0]"``, ``"[0][1]"``, ``"[0][1][2]"``), what was expected there and the value
        found.
    """
    if value == LIMBS:
        return None
    if not isinstance(value, (list, tuple)):
        return "", f"a list of {_PAIRS_SHAPE}", value
    for i, pair in enumerate(value):
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            return f"[{i}]", "two groups of geom names [[names], [names]]", pair
        for k, group in enumerate(pair):
            if isinstance(group, str):
                group = [group]
            if not isinstance(group, (list, tuple)) or not group:
                return f"[{i}][{k}]", "a geom name or a non-empty list of geom names", group
            for n, name in enumerate(group):
                if not isinstance(name, str) or not name:
                    return f"[{i}][{k}][{n}]", "a geom name", name
    return None


def _normalised_pairs(value: Any) -> CollisionPairs | str:
    """``value`` (checked) as a tuple of pairs of tuples of names; ``None`` is none,
    ``"limbs"`` stays."""
    if value is None:
        return ()
    if value == LIMBS:
        return LIMBS
    problem = collision_pairs_problem(value)
    if problem is not None:
        where, expected, got = problem
        raise SolverError(
            f"option 'collision_pairs{where}' of solver '{NAME}' must be {expected}, got {got!r}"
        )
    out = []
    for a, b in value:
        ga = (a,) if isinstance(a, str) else tuple(a)
        gb = (b,) if isinstance(b, str) else tuple(b)
        out.append((ga, gb))
    return tuple(out)


@dataclass(frozen=True)
class MinkOptions(SolverOptions):
    """Options of ``mink``: the single-chain solver, the multi-effector scene hook and
    :class:`~humanoid_ik.solvers.mink.upper_body.UpperBodyIK`.

    Attributes:
        max_iterations: QP steps per start (per :meth:`UpperBodyIK.solve` call).
        restarts: further starts (seeded random poses) after a stall (single chain).
        seed: seed of the random restarts.
        max_step: largest joint move per iteration [rad] (> 0).
        stall_window: steps without a 1 % gain that count as a stall.
        position_cost: weight of the hand position error [1/m].
        orientation_cost: weight of the hand orientation error [1/rad].
        gaze_cost: weight of the gaze error.
        pole_cost: weight of the elbow's distance from its pole's half-plane [1/m]
            (a hand target's ``pole``; low, so the hands win).
        posture_cost: weight of the pull toward ``home`` [1/rad].
        posture_gain: fraction of the way back to ``home`` asked for per step, in [0, 1]
            (below 1 so its pull in the null space of the hand tasks does not overshoot).
        damping: Levenberg-Marquardt damping on ``dq`` (all tasks).
        lm_damping: error-scaled damping of the hand tasks (mink's).
        range_gain: fraction of the distance to a range end one step may use, in (0, 1].
        collision_pairs: pairs of geom-name groups kept apart, every geom of a group
            against every geom of the other (``()``: no collision avoidance). The model's
            own geom names: nothing here knows a particular robot (the bundled scenes
            name the bundled humanoid's pairs, ``scenes/upper_body_mink.toml``); or
            ``"limbs"``: each forearm and hand against the torso and head, hand against
            hand, derived from the limbs found in the model
            (:func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`).
        collision_gain: a pair may close this fraction of its margin over
            ``min_distance`` per step, in (0, 1].
        min_distance: the smallest distance kept between the geoms of a pair [m].
        detection_distance: pairs farther apart than this add no row [m] (> 0).
        dt: with ``dt > 0`` [s] each scene frame is one tracking step of ``dt``.
        max_velocity: joint speed limit of tracking steps [rad/s] (> 0).
        qp_solver: the qpsolvers backend.
        forward_axis: the axis (``x``, ``y``, ``z``, or ``-x``, ``-y``, ``-z``) of the
            ``look_at`` site's frame that is aimed at the target
            (:meth:`MinkSolver.gaze_axis`).
    """

    max_iterations: int = 200
    restarts: int = 20
    seed: int = 0
    max_step: float = 0.2
    stall_window: int = 10
    position_cost: float = 1.0
    orientation_cost: float = 0.5
    gaze_cost: float = 1.0
    pole_cost: float = 0.1
    posture_cost: float = 1e-3
    posture_gain: float = 0.1
    damping: float = 1e-12
    lm_damping: float = 0.0
    range_gain: float = 0.95
    collision_pairs: CollisionPairs | str = ()
    collision_gain: float = 0.85
    min_distance: float = 0.01
    detection_distance: float = 0.1
    dt: float = 0.0
    max_velocity: float = 4.0
    qp_solver: str = "daqp"
    forward_axis: str = option("x", valid=SIGNED_AXES)

    BOUNDS: ClassVar[Mapping[str, tuple[float, float]]] = {
        "max_iterations": (0, 100_000),
        "restarts": (0, 1_000),
        "stall_window": (0, 100_000),
        "max_step": (0.0, 2.0 * math.pi),
        "dt": (0.0, 10.0),
        "max_velocity": (0.0, 1e3),
        "posture_gain": (0.0, 1.0),
        "range_gain": (0.0, 1.0),
        "collision_gain": (0.0, 1.0),
    }
    """Steps, restarts and the stall window bound a solve's time; a step larger than a
    turn, a tracking step over 10 s or a joint speed over 1000 rad/s is an input
    mistake; gains are fractions. :data:`POSITIVE` refuses the lower bound 0 itself."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "collision_pairs", _normalised_pairs(self.collision_pairs))
        bounds = self.bounds()
        for key in sorted(POSITIVE):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                continue  # a type error: parse reports it before the object is made
            if not (math.isfinite(value) and value > 0):
                rule = "> 0"
                if key in bounds:
                    rule += f" and <= {bounds[key][1]:g}"
                raise SolverError(
                    f"option '{key}' of solver '{NAME}' must be a finite number {rule}, "
                    f"got {value!r}"
                )

    @classmethod
    def parse(cls, solver: str, given: Mapping[str, Any]) -> MinkOptions:
        """:meth:`SolverOptions.parse`, with a pointer for the removed ``collisions`` and
        a plain message for a ``qp_solver`` that is not a name (whether it is installed
        is checked when the solver is built).

        Raises:
            SolverError: an unknown name (the valid ones are listed) or a bad value.
        """
        if "collisions" in given:
            raise SolverError(
                f"option 'collisions' of solver '{solver}' was replaced by "
                "'collision_pairs': name the geom pairs to keep apart, e.g. "
                "collision_pairs = [[['right_hand_collision'], ['torso_collision']]] "
                "(the bundled humanoid's: scenes/upper_body_mink.toml)"
            )
        qp = given.get("qp_solver", "daqp")
        if not isinstance(qp, str) or not qp:
            raise SolverError(
                f"option 'qp_solver' of solver '{solver}' must be the name of a qpsolvers "
                f"backend (daqp, ...), got {qp!r}"
            )
        return super().parse(solver, given)
