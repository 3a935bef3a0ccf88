"""What the trajectory files of a run hold: every frame's full ``qpos`` with the targets
and each effector's samples, as a typed :class:`Trajectory`.

A run's :class:`~humanoid_ik.run.recording.Recording` makes one
(:meth:`~humanoid_ik.run.recording.Recording.trajectory`); a replay turns its frames
back into the run's frames, nothing lost (:meth:`Trajectory.frame_samples`).
:func:`check_trajectory_model` says whether a
trajectory fits a model (same joints in the same ``qpos`` order, same model digest).
The files (``trajectory.npz``, ``trajectory.csv``) are written and read by
:mod:`humanoid_ik.outputs.trajectory`; ``docs/formats.md`` documents them.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.specs import RenderSpec
from humanoid_ik.core.robot import joint_name
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.metrics import EffectorSample, FrameSamples

__all__ = [
    "EFFECTOR_KINDS",
    "TRAJECTORY_FORMAT",
    "TRAJECTORY_VERSION",
    "EffectorTrack",
    "Trajectory",
    "check_trajectory_model",
    "qpos_names",
]

TRAJECTORY_FORMAT = "humanoid-ik trajectory"
"""The ``format`` of a trajectory file's metadata."""
TRAJECTORY_VERSION = 1
"""The version of the trajectory files this package writes and reads."""
EFFECTOR_KINDS = ("site", "body")
"""What an effector's name may name (:attr:`EffectorTrack.kind`)."""

_FREE = ("x", "y", "z", "qw", "qx", "qy", "qz")
_BALL = ("qw", "qx", "qy", "qz")


def qpos_names(model: mujoco.MjModel) -> list[str]:
    """One name per ``qpos`` entry ``(nq,)``: a hinge or slide joint's name; ``joint:x``,
    ... ``joint:qz`` for a free joint; ``joint:qw`` ... ``joint:qz`` for a ball joint
    (a joint without a name is called ``joint<id>``)."""
    out: list[str] = []
    for j in range(model.njnt):
        name = joint_name(model, j)
        kind = int(model.jnt_type[j])
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            out += [f"{name}:{c}" for c in _FREE]
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            out += [f"{name}:{c}" for c in _BALL]
        else:
            out.append(name)
    return out


def _floats(value: object, shape: tuple[int, ...], what: str) -> NDArray[np.float64]:
    """``value`` as a float64 array of ``shape`` (``-1``: any length), else a one-line
    :class:`TrajectoryFileError` naming ``what``."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != len(shape) or any(
        s not in (-1, a) for s, a in zip(shape, arr.shape, strict=True)
    ):
        want = "(" + ", ".join("any" if s < 0 else str(s) for s in shape) + ")"
        raise TrajectoryFileError(f"{what}: expected shape {want}, got {arr.shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class EffectorTrack:
    """One effector over the frames of a trajectory (``F`` frames).

    Attributes:
        site: the end effector's name: a site's, or a body's (:attr:`kind` says which).
        target_name: the target it tracks.
        task: ``reach`` or ``look_at``.
        solver: the solver's label, e.g. ``dls(restarts=0)``.
        joints: the chain's joint names ``(n,)``.
        q: the chain's joint values ``(F, n)`` [rad] (also in :attr:`Trajectory.qpos`).
        target: the target position ``(F, 3)`` [m] (world frame).
        target_quat: the target orientation ``(F, 4)`` (wxyz), or ``None`` (position
            target).
        achieved: the site position ``(F, 3)`` [m]; for ``look_at`` the gaze point.
        position_error: ``(F,)`` [m], as in the metrics.
        on_target, reachable: ``(F,)`` booleans, as in the metrics.
        status: the solver's status per frame ``(F,)``.
        orientation_error: ``(F,)`` [rad], NaN where the metrics have none.
        iterations: the solver's iterations ``(F,)``.
        solve_time: the solver's wall time ``(F,)`` [s].
        limit_margin: the nearest joint's distance to its range end ``(F,)`` [rad].
        kind: ``site`` or ``body``: what :attr:`site` names.

    The four sample fields are in files from this release on; a file without them reads
    as NaN (0 iterations). A file that names its body effectors ``site`` (written before
    the kind was kept) reads as sites.
    """

    site: str
    target_name: str
    task: str
    solver: str
    joints: tuple[str, ...]
    q: NDArray[np.float64]
    target: NDArray[np.float64]
    target_quat: NDArray[np.float64] | None
    achieved: NDArray[np.float64]
    position_error: NDArray[np.float64]
    on_target: NDArray[np.bool_]
    reachable: NDArray[np.bool_]
    status: tuple[str, ...]
    orientation_error: NDArray[np.float64] | None = None
    iterations: NDArray[np.int64] | None = None
    solve_time: NDArray[np.float64] | None = None
    limit_margin: NDArray[np.float64] | None = None
    kind: str = "site"

    def __post_init__(self) -> None:
        if self.kind not in EFFECTOR_KINDS:
            raise TrajectoryFileError(
                f"effector '{self.site}' kind: expected one of {', '.join(EFFECTOR_KINDS)}, "
                f"got {self.kind!r}"
            )
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "status", tuple(str(s) for s in self.status))
        n = len(self.status)
        what = f"effector '{self.site}'"
        object.__setattr__(self, "q", _floats(self.q, (n, len(self.joints)), f"{what} q"))
        object.__setattr__(self, "target", _floats(self.target, (n, 3), f"{what} target"))
        object.__setattr__(self, "achieved", _floats(self.achieved, (n, 3), f"{what} achieved"))
        if self.target_quat is not None:
            quat = _floats(self.target_quat, (n, 4), f"{what} target_quat")
            object.__setattr__(self, "target_quat", quat)
        err = _floats(self.position_error, (n,), f"{what} position_error")
        object.__setattr__(self, "position_error", err)
        for name in ("on_target", "reachable"):
            flags = np.asarray(getattr(self, name), dtype=bool)
            if flags.shape != (n,):
                raise TrajectoryFileError(
                    f"{what} {name}: expected shape ({n},), got {flags.shape}"
                )
            flags.setflags(write=False)
            object.__setattr__(self, name, flags)
        for name in ("orientation_error", "solve_time", "limit_margin"):
            value = getattr(self, name)
            value = np.full(n, math.nan) if value is None else value
            object.__setattr__(self, name, _floats(value, (n,), f"effector '{self.site}' {name}"))
        its = np.zeros(n) if self.iterations is None else self.iterations
        its = _floats(its, (n,), f"effector '{self.site}' iterations")
        if not (np.isfinite(its).all() and (its >= 0).all() and (its == np.round(its)).all()):
            raise TrajectoryFileError(
                f"effector '{self.site}' iterations: expected whole numbers >= 0"
            )
        its = its.astype(np.int64)
        its.setflags(write=False)
        object.__setattr__(self, "iterations", its)


@dataclass(frozen=True)
class Trajectory:
    """A scene run's motion, frame by frame (``F`` frames, ``nq`` joint values).

    Attributes:
        time: each frame's time ``(F,)`` [s].
        qpos: the model's full ``qpos`` per frame ``(F, nq)`` [rad for hinges, m for
            slides, quaternions wxyz for ball and free joints].
        qpos_names: the name of each ``qpos`` column ``(nq,)`` (:func:`qpos_names`).
        joint_names: the model's joints in model order.
        effectors: each effector's track (scene order).
        fps: frames per second [1/s].
        scene: the scene's name.
        scene_file: the scene file, or ``""`` (a scene built in Python).
        model_file: the model file (MJCF) it ran on.
        model_sha256: :func:`~humanoid_ik.core.model_files.model_digest` of the model
            file (16 hex digits of SHA-256 over it, its includes and assets).
        render: how the scene is filmed (replay uses it unless told otherwise).
        interrupted: Ctrl-C stopped the run early.
        stage_points: the points ``(k, 3)`` [m] the default stage's cameras framed
            besides the model (:func:`~humanoid_ik.outputs.stage.staged_model`; the
            scene's target paths), so a replay builds the same stage.
    """

    time: NDArray[np.float64]
    qpos: NDArray[np.float64]
    qpos_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    effectors: tuple[EffectorTrack, ...]
    fps: float
    scene: str
    scene_file: str
    model_file: str
    model_sha256: str
    render: RenderSpec = field(default_factory=RenderSpec)
    interrupted: bool = False
    stage_points: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        for name in ("qpos_names", "joint_names", "effectors"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        points = _floats(self.stage_points, (-1, 3), "stage_points")
        object.__setattr__(self, "stage_points", points)
        n = np.asarray(self.time).shape[0] if np.ndim(self.time) == 1 else -1
        object.__setattr__(self, "time", _floats(self.time, (n,), "time"))
        qpos = _floats(self.qpos, (n, len(self.qpos_names)), "qpos")
        object.__setattr__(self, "qpos", qpos)
        for e in self.effectors:
            if len(e.status) != n:
                raise TrajectoryFileError(
                    f"effector '{e.site}' has {len(e.status)} frame(s); the trajectory has {n}"
                )
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise TrajectoryFileError(f"fps: expected a number > 0, got {self.fps!r}")

    @property
    def n_frames(self) -> int:
        """Frames ``F``."""
        return int(self.time.shape[0])

    def joint(self, name: str) -> NDArray[np.float64]:
        """One ``qpos`` column over the frames ``(F,)``, by its name.

        Raises:
            TrajectoryFileError: no such column (the names are listed).
        """
        if name not in self.qpos_names:
            raise TrajectoryFileError(
                f"joint '{name}' not in trajectory; joints: {', '.join(self.qpos_names)}"
            )
        return self.qpos[:, self.qpos_names.index(name)]

    def frame_samples(self, index: int) -> FrameSamples:
        """Frame ``index`` as the runner's :class:`FrameSamples` had it (a file written
        before these fields were kept gives NaN, ``None`` and 0 for them)."""
        samples = tuple(_sample(e, index) for e in self.effectors)
        return FrameSamples(index, float(self.time[index]), samples)

    def record(self, index: int) -> FrameSamples:
        """Deprecated (one release): :meth:`frame_samples`, by its former name."""
        warnings.warn(
            "humanoid_ik.run.trajectory.Trajectory.record is deprecated; use "
            "Trajectory.frame_samples",
            DeprecationWarning,
            stacklevel=2,
        )
        return self.frame_samples(index)

    def quats(self, index: int) -> list[NDArray[np.float64] | None]:
        """Each effector's target orientation (wxyz) at frame ``index``, or ``None``."""
        return [None if e.target_quat is None else e.target_quat[index] for e in self.effectors]


def _sample(e: EffectorTrack, index: int) -> EffectorSample:
    """Effector track ``e``'s sample at frame ``index``, as the run measured it."""
    orient = float(e.orientation_error[index])  # type: ignore[index]
    return EffectorSample(
        effector=e.site,
        target_name=e.target_name,
        task=e.task,
        target=e.target[index].copy(),
        achieved=e.achieved[index].copy(),
        position_error=float(e.position_error[index]),
        orientation_error=None if math.isnan(orient) else orient,
        iterations=int(e.iterations[index]),  # type: ignore[index]
        solve_time=float(e.solve_time[index]),  # type: ignore[index]
        limit_margin=float(e.limit_margin[index]),  # type: ignore[index]
        reachable=bool(e.reachable[index]),
        on_target=bool(e.on_target[index]),
        status=e.status[index],
    )


def check_trajectory_model(traj: Trajectory, model: mujoco.MjModel, digest: str | None) -> None:
    """Check that ``traj`` was recorded on ``model``: the same ``qpos`` columns (joint
    names, types and order) and, when ``digest`` is given, the same model digest.

    Raises:
        TrajectoryFileError: they differ (the first difference is named).
    """
    names = qpos_names(model)
    if tuple(names) != traj.qpos_names:
        missing = [n for n in traj.qpos_names if n not in names]
        extra = [n for n in names if n not in traj.qpos_names]
        if missing or extra:
            what = f"joints {', '.join(missing)} not in the model" if missing else ""
            what += ("; " if what and extra else "") + (
                f"model joints {', '.join(extra)} not in the trajectory" if extra else ""
            )
        else:
            what = "the joints are in another order"
        raise TrajectoryFileError(
            f"trajectory of scene '{traj.scene}' does not fit model '{traj.model_file}': {what}"
        )
    if digest is not None and digest != traj.model_sha256:
        raise TrajectoryFileError(
            f"trajectory of scene '{traj.scene}' was recorded on another version of "
            f"'{traj.model_file}' (model sha256 {traj.model_sha256}, the file now has "
            f"{digest}); pass the model it was recorded on with --model"
        )


def __getattr__(name: str) -> Any:
    if name == "TrajectoryRecorder":
        warnings.warn(
            "humanoid_ik.run.trajectory.TrajectoryRecorder is deprecated; the runner's "
            "humanoid_ik.run.recording.Recording records the trajectory",
            DeprecationWarning,
            stacklevel=2,
        )
        from humanoid_ik.run.recording import Recording

        def recorder(scene: Any, model: Any, chains: Any, targets: Any, solvers: Any) -> Any:
            """``TrajectoryRecorder(scene, model, chains, targets, solvers)``."""
            return Recording(scene, solvers, model, chains, targets)

        return recorder
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
