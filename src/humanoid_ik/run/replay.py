"""Playing a recorded :class:`~humanoid_ik.run.trajectory.Trajectory` back without solving:
per frame its ``qpos`` is written into the model's ``MjData``, ``mj_forward`` runs, and
the frame's samples (targets, achieved positions, flags) goes to the sinks through the
one frame loop, :func:`~humanoid_ik.run.runner.frame_loop`."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import mujoco

from humanoid_ik.core.models import reset_to_home
from humanoid_ik.run.metrics import FrameSamples
from humanoid_ik.run.runner import FrameSink, frame_loop
from humanoid_ik.run.trajectory import Trajectory, check_trajectory_model

__all__ = ["TrajectoryPlayer"]


class TrajectoryPlayer:
    """Writes a trajectory's frames into a model's data, one per step.

    Args:
        trajectory: what to play.
        model: the model it was recorded on.
        digest: the model file's digest, checked against the trajectory's (``None``:
            only the joints are checked).

    Raises:
        TrajectoryFileError: the trajectory does not fit the model.

    Attributes:
        model, data: MuJoCo's model and the data the frames are written to.
    """

    def __init__(self, trajectory: Trajectory, model: mujoco.MjModel, digest: str | None = None):
        check_trajectory_model(trajectory, model, digest)
        self.trajectory = trajectory
        self.model = model
        self.data = mujoco.MjData(model)
        reset_to_home(model, self.data)

    @property
    def n_frames(self) -> int:
        """Frames of the trajectory."""
        return self.trajectory.n_frames

    def step(self, index: int) -> FrameSamples:
        """Frame ``index``: its ``qpos`` in :attr:`data` after ``mj_forward``, and its
        samples."""
        self.data.qpos[:] = self.trajectory.qpos[index]
        mujoco.mj_forward(self.model, self.data)
        return self.trajectory.frame_samples(index)

    def run(
        self,
        sinks: Sequence[FrameSink] = (),
        on_frame: Callable[[FrameSamples], None] | None = None,
    ) -> tuple[list[float], bool]:
        """Play every frame to ``sinks``; returns each frame's wall time [s] and whether
        Ctrl-C stopped it early."""
        return frame_loop(self.n_frames, self.step, self.data, sinks, on_frame)
