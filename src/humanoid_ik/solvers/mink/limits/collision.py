"""Keep geom pairs apart, with the bound on the displacement of one step."""

from __future__ import annotations

from collections.abc import Sequence

import mink
import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.solvers.mink.adapter import contact_normal_jacobian

__all__ = ["CollisionLimit", "GeomPairs"]

GeomPairs = Sequence[tuple[Sequence[str | int], Sequence[str | int]]]
"""Pairs of geom groups (names or ids): every geom of a group against every geom of the
other."""


class CollisionLimit(mink.Limit):
    """mink's collision avoidance rows with their bound in displacement form.

    Each geom pair closer than ``collision_detection_distance`` adds the row::

        -n' (J_2 - J_1) dq <= gain (d - d_min)      (0 when d <= d_min)

    the distance ``d`` [m] along the contact normal ``n`` (from ``mj_geomDistance``)
    may shrink by at most ``gain`` times its margin over ``d_min`` in one step. mink's
    ``CollisionAvoidanceLimit`` (1.3) divides that bound by ``dt`` although ``dq`` is a
    displacement, which lets geoms close ``1 / dt`` times faster at small steps; here
    the bound holds whatever the frame rate (at ``dt = 1`` both are the same). Pairs
    are chosen by mink (``CollisionAvoidanceLimit.geom_id_pairs``: geoms of one body or
    weld, of parent and child bodies, and those filtered out by contype/conaffinity are
    skipped); the rows are mink's contact normal Jacobian
    (:func:`~humanoid_ik.solvers.mink.adapter.contact_normal_jacobian`). Overlapping
    geoms (``d < 0``) get the row with the opposite sign.

    The row is the distance's first-order change; a step that slides a geom along a
    curved surface loses distance at second order. :meth:`distances` measures every
    pair after a step so the caller can shorten it (see ``UpperBodyIK``).

    Args:
        model: the MuJoCo model.
        geom_pairs: pairs of geom groups (names or ids), every geom of a group against
            every geom of the other (as for ``mink.CollisionAvoidanceLimit``).
        gain: fraction in (0, 1] of the margin a step may close.
        minimum_distance_from_collisions: ``d_min`` [m].
        collision_detection_distance: pairs farther than this [m] add no row.
        bound_relaxation: added to every bound [m].
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        geom_pairs: GeomPairs,
        gain: float = 0.85,
        minimum_distance_from_collisions: float = 0.005,
        collision_detection_distance: float = 0.01,
        bound_relaxation: float = 0.0,
    ):
        self.model = model
        self.gain = float(gain)
        self.minimum_distance_from_collisions = float(minimum_distance_from_collisions)
        self.collision_detection_distance = float(collision_detection_distance)
        self.bound_relaxation = float(bound_relaxation)
        chosen = mink.CollisionAvoidanceLimit(model, geom_pairs).geom_id_pairs
        self.geom_id_pairs: list[tuple[int, int]] = [(int(a), int(b)) for a, b in chosen]
        """The geom id pairs checked, as mink chose them."""
        n = len(self.geom_id_pairs)
        self._G = np.zeros((n, model.nv))  # (pairs, nv)
        self._h = np.empty(n)
        self._fromto = np.empty(6)
        self._scratch = (np.empty(3), np.empty((3, model.nv)), np.empty((3, model.nv)))
        self.last_distances = np.full(n, np.inf)
        """Distance [m] of every pair (capped at the detection distance) at the last
        :meth:`compute_qp_inequalities`."""

    def distances(self, data: mujoco.MjData, out: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fill ``out`` ``(pairs,)`` with each pair's distance [m], capped at the detection
        distance (negative when the geoms overlap)."""
        m, ft, cap = self.model, self._fromto, self.collision_detection_distance
        for i, (g1, g2) in enumerate(self.geom_id_pairs):
            out[i] = mujoco.mj_geomDistance(m, data, g1, g2, cap, ft)
        return out

    def compute_qp_inequalities(
        self, configuration: mink.Configuration, dt: float
    ) -> mink.Constraint:
        """``G dq <= h`` with one row per pair (``h = inf`` for a pair out of range);
        ``dt`` is unused, the bound is a displacement."""
        del dt
        m, data = self.model, configuration.data
        G, h, dist_out = self._G, self._h, self.last_distances
        G.fill(0.0)
        h.fill(np.inf)
        cap = self.collision_detection_distance
        dmin, gain = self.minimum_distance_from_collisions, self.gain
        ft, scratch = self._fromto, self._scratch
        for i, (g1, g2) in enumerate(self.geom_id_pairs):
            dist = mujoco.mj_geomDistance(m, data, g1, g2, cap, ft)
            dist_out[i] = dist
            if abs(dist - cap) < 1e-12:
                continue
            row = contact_normal_jacobian(m, data, g1, g2, ft, scratch)
            h[i] = (gain * (dist - dmin) if dist > dmin else 0.0) + self.bound_relaxation
            G[i] = -row if dist >= 0 else row
        return mink.Constraint(G=G, h=h)
