"""The iterate / stall / restart rule every iterative solver follows, written once.

A solver iterates from each start (``Solver.starts``: ``q0``, then restarts) and keeps
the best pose it has seen:

- **stall**: a start ends when its cost has not dropped by 1 % over the last
  ``stall_window`` iterations (a window below 2 counts as 2): :class:`Stall`;
- **best pose**: among the poses seen, the one with the lowest :func:`pose_cost`,
  ``position error [m] + 0.1 orientation error [rad]``: :class:`Best`.

Used by the Jacobian family (``solvers/jacobian/loop.py``), ``ccd``, ``lm``'s restarts
(``solvers/jacobian/lm.py``; its compiled kernel applies the same stall rule to its own
objective inside a start) and the mink loop (``solvers/mink/``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["Best", "Stall", "pose_cost"]

PROGRESS = 0.99
"""A cost above this fraction of the cost ``stall_window`` iterations earlier is a stall
(less than 1 % progress)."""


def pose_cost(position_error: float, orientation_error: float | None = None) -> float:
    """The cost that ranks poses: ``position error [m] + 0.1 orientation error [rad]``
    (a position target: the position error)."""
    return position_error if not orientation_error else position_error + 0.1 * orientation_error


class Stall:
    """The stall rule of one start: call it with each iteration's cost, in order.

    Args:
        window: ``stall_window``, the iterations over which 1 % progress is expected
            (at least 2).
    """

    __slots__ = ("history", "window")

    def __init__(self, window: int):
        self.window = max(2, int(window))
        self.history = [math.inf] * self.window

    def __call__(self, iteration: int, cost: float) -> bool:
        """True when iteration ``iteration`` (from 0) with ``cost`` ends the start: from
        iteration ``window`` on, a cost above 99 % of the cost ``window`` iterations
        earlier."""
        slot = iteration % self.window
        if iteration >= self.window and cost > PROGRESS * self.history[slot]:
            return True
        self.history[slot] = cost
        return False


class Best:
    """The best pose seen over the starts of a solve (lowest cost; the first on a tie).

    Args:
        q0: the first start, the answer until a pose is seen.
    """

    __slots__ = ("cost", "q", "start")

    def __init__(self, q0: NDArray[np.float64]):
        self.q = q0.copy()
        self.cost = math.inf
        self.start = 0

    def offer(self, q: NDArray[np.float64], cost: float, start: int = 0) -> bool:
        """Keep ``q`` (copied) when its ``cost`` is lower than the best so far; ``start``
        is the index of the start it came from. Returns whether it was kept."""
        if cost < self.cost:
            self.q[:] = q
            self.cost, self.start = cost, start
            return True
        return False
