"""What a scene run measured in one frame (:class:`FrameSamples`: one sample per
effector), and the columns of ``metrics.csv``.

The run's frames are kept by :class:`~humanoid_ik.run.recording.Recording`, the one
table of a run. Former names kept as deprecated aliases for one release: ``Metrics``
(now ``Recording``), ``FrameRecord`` (now ``FrameSamples``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["CSV_FIELDS", "EffectorSample", "FrameSamples"]


class EffectorSample(NamedTuple):
    """What one effector did in one frame (measured on the scene's ``MjData``); a named
    tuple: made once per effector and frame, read-only.

    Attributes:
        effector: the end effector's name (a site's or a body's).
        target_name: the target it tracks.
        task: ``reach`` or ``look_at``.
        target: target position ``(3,)`` [m].
        achieved: the end effector's position ``(3,)`` [m]; for ``look_at`` the gaze
            point (on the site's x axis, as far from the site as the target).
        position_error: distance from the end effector to the target [m]; for
            ``look_at`` the distance from the target to the gaze ray.
        orientation_error: angle between achieved and target orientation [rad] (pose
            targets), the gaze's angle off the target (``look_at``), else ``None``.
        iterations: the solver's iterations.
        solve_time: the solver's wall time [s] (a solver that moves several effectors
            at once splits its time equally).
        limit_margin: smallest distance of a chain joint to its range end [rad].
        reachable: the target lies within the chain's reach (``look_at``: the gaze can
            turn onto it within the joint ranges).
        on_target: within :data:`ON_TARGET_DISTANCE` (and :data:`ON_TARGET_ANGLE`).
        status: the solver's status.
    """

    effector: str
    target_name: str
    task: str
    target: NDArray[np.float64]
    achieved: NDArray[np.float64]
    position_error: float
    orientation_error: float | None
    iterations: int
    solve_time: float
    limit_margin: float
    reachable: bool
    on_target: bool
    status: str


@dataclass(frozen=True)
class FrameSamples:
    """One frame of a run: its index, time [s] and one sample per effector (scene
    order). What the frame loop hands its sinks; a
    :class:`~humanoid_ik.run.recording.Recording` keeps one per frame."""

    index: int
    time: float
    samples: tuple[EffectorSample, ...]

    @property
    def solve_time(self) -> float:
        """Total solver time of the frame [s]."""
        return float(sum(s.solve_time for s in self.samples))


CSV_FIELDS = [
    "frame",
    "time_s",
    "effector",
    "target_name",
    "task",
    "target_x",
    "target_y",
    "target_z",
    "achieved_x",
    "achieved_y",
    "achieved_z",
    "position_error_m",
    "orientation_error_rad",
    "iterations",
    "solve_time_s",
    "limit_margin_rad",
    "reachable",
    "on_target",
    "status",
]


def __getattr__(name: str) -> Any:
    if name == "Metrics":
        warnings.warn(
            "humanoid_ik.run.metrics.Metrics is deprecated; use "
            "humanoid_ik.run.recording.Recording",
            DeprecationWarning,
            stacklevel=2,
        )
        from humanoid_ik.run.recording import Recording

        return Recording
    if name == "FrameRecord":
        warnings.warn(
            "humanoid_ik.run.metrics.FrameRecord is deprecated; use "
            "humanoid_ik.run.metrics.FrameSamples",
            DeprecationWarning,
            stacklevel=2,
        )
        return FrameSamples
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
