"""Our mink tasks, one per file as in mink: a plain position task, a gaze task and
an elbow (pole) task.

Importing this package imports mink.
"""

from humanoid_ik.solvers.mink.tasks.buffered import BufferedTask
from humanoid_ik.solvers.mink.tasks.elbow import ElbowTask
from humanoid_ik.solvers.mink.tasks.gaze import GazeTask
from humanoid_ik.solvers.mink.tasks.position import PositionTask

__all__ = ["BufferedTask", "ElbowTask", "GazeTask", "PositionTask"]
