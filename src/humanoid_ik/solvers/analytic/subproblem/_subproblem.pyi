"""Type stub of the compiled ``_subproblem`` module (``_subproblem.c``)."""

import numpy as np
from numpy.typing import NDArray

MAX_SOLUTIONS: int
"""The most solutions one call returns."""

class Arm:
    """A 6-hinge arm in its base frame at zero, in the family's order; with ``locked``
    0 or 6, a 7-hinge arm whose first or last joint is searched."""

    def __init__(
        self,
        family: int,
        position_case: int,
        reverse: bool,
        axes: NDArray[np.float64],
        points: NDArray[np.float64],
        end_rotation: NDArray[np.float64],
        end_position: NDArray[np.float64],
        wrist: NDArray[np.float64],
        meet: NDArray[np.float64],
        locked: int = -1,
        locked_axis: NDArray[np.float64] | None = None,
        locked_point: NDArray[np.float64] | None = None,
    ) -> None: ...
    def solutions(
        self,
        position: NDArray[np.float64],
        quaternion: NDArray[np.float64],
        base: NDArray[np.float64],
        start: NDArray[np.float64],
        /,
    ) -> list[tuple[float, ...]]: ...
    def solve(
        self,
        position: NDArray[np.float64],
        quaternion: NDArray[np.float64],
        base: NDArray[np.float64],
        start: NDArray[np.float64],
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        tol: float,
        out: NDArray[np.float64],
        /,
    ) -> tuple[int, int, int]: ...
    def solve_many(
        self,
        positions: NDArray[np.float64],
        quaternions: NDArray[np.float64],
        base: NDArray[np.float64],
        start: NDArray[np.float64],
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        tol: float,
        out: NDArray[np.float64],
        info: NDArray[np.float64],
        /,
    ) -> None: ...
