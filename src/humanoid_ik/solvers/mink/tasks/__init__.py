"""Our mink tasks, one per file as in mink: a plain position task and a gaze task.

Importing this package imports mink.
"""

from humanoid_ik.solvers.mink.tasks.buffered import BufferedTask
from humanoid_ik.solvers.mink.tasks.gaze import GazeTask
from humanoid_ik.solvers.mink.tasks.position import PositionTask

__all__ = ["BufferedTask", "GazeTask", "PositionTask"]
