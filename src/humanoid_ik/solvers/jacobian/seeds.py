"""A library of seeded start poses for restarts: the poses whose FK lies nearest a target.

A local solver that stalls from its start (a joint range blocks the way, or a local
minimum) restarts better from a pose whose end effector already lies near the target
than from a uniform random one. The library holds ``size`` seeded random in-range joint
vectors and their FK (from MuJoCo), built once per chain.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import Target
from humanoid_ik.solvers.jacobian import _lm_kernel

__all__ = [
    "ROTATION_LENGTH",
    "SeedLibrary",
    "grid",
    "random_starts",
    "restart_poses",
    "seed_library",
]

ROTATION_LENGTH = 0.3
"""What one radian of rotation weighs in the library's ranking [m/rad]."""


class SeedLibrary:
    """Joint vectors ``q (size, n)`` with FK positions ``(size, 3)`` and rotations
    ``(size, 3, 3)``, ordered by the cells of a grid over the positions (:func:`grid`).

    Args:
        chain: the chain (its scratch data is restored to the current pose afterwards).
        size: number of poses.
        seed: generator seed.
    """

    def __init__(self, chain: Chain, size: int = 4000, seed: int = 7):
        rng = np.random.default_rng(seed)
        saved = chain.q
        q = np.array([chain.random_q(rng) for _ in range(size)]).reshape(size, chain.n)
        positions = np.empty((size, 3))
        rotations = np.empty((size, 3, 3))
        for i, qi in enumerate(q):
            chain.set_q(qi)
            positions[i] = chain.position
            rotations[i] = chain.rotation
        chain.set_q(saved)
        # by cell: a ranking visits the cells outward from the target's
        self.grid, cell = grid(positions)
        order = np.argsort(cell, kind="stable")
        self.q, self.positions, self.rotations = q[order], positions[order], rotations[order]
        count = int(np.prod(self.grid[4:]))
        self.cells = np.searchsorted(cell[order], np.arange(count + 1)).astype(np.int64)
        self._flat = (
            self.positions.reshape(-1), self.rotations.reshape(-1), self.grid, self.cells
        )  # fmt: skip
        # the library as the compiled loop takes it (_lm_kernel.Kernel.solve)
        self.packed = (*self._flat, self.q.reshape(-1), ROTATION_LENGTH)

    def nearest(
        self, target: Target, count: int, length: float = ROTATION_LENGTH
    ) -> NDArray[np.float64]:
        """The ``count`` poses ``(count, n)`` nearest ``target``, nearest first, by the
        distance [m] plus ``length`` [m/rad] times ``1 - cos`` of the rotation angle for
        a pose target; equal costs in library order. In C (``_lm_kernel.seed_nearest``),
        cell ring by cell ring outward from the target's cell until the ring's distance
        alone exceeds the ``count``-th cost: 2-3 us for 4,000 poses (8-9 us when it
        visited them outward along x alone, 40-60 us ranked with numpy, as much as the
        ``lm`` start it is for)."""
        index = np.empty(min(count, self.q.shape[0]), dtype=np.int64)
        rot = None if target.rotation is None else target.rotation.reshape(9)
        found = _lm_kernel.seed_nearest(*self._flat, target.position, rot, length, index)
        return self.q[index[:found]]


def grid(positions: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """A grid of cubic cells over ``positions`` ``(L, 3)``, about 8 positions per cell
    of their bounding box (at most 64 cells along an axis; 1, 4, 16 and 32 per cell
    ranked Baxter's, G1's, Panda's and UR5's libraries no faster): ``(7,)`` = the corner of cell
    ``(0, 0, 0)``, the side [m] and the counts along x, y, z, as ``_lm_kernel`` takes it;
    and each position's cell ``(L,)``, ``(iz gy + iy) gx + ix``."""
    low = positions.min(axis=0)
    extent = positions.max(axis=0) - low
    side = max(float(np.cbrt(8 * np.prod(extent) / len(positions))), float(extent.max()) / 64)
    if not side > 0.0:  # every position in one plane, a line or a point
        side = max(float(extent.max()) / 64, 1e-3)
    dims = np.clip(np.ceil(extent / side), 1, 64).astype(np.int64)
    side = max(side, float((extent / dims).max()))
    at = np.clip(np.floor((positions - low) / side), 0, dims - 1).astype(np.int64)
    cell = (at[:, 2] * dims[1] + at[:, 1]) * dims[0] + at[:, 0]
    return np.array([*low, side, *dims], dtype=np.float64), cell


def seed_library(chain: Chain, size: int = 4000, seed: int = 7) -> SeedLibrary:
    """The chain's library of ``size`` poses, built on first use and kept with the chain
    (:meth:`Chain.derived`)."""
    return chain.derived(("seed_library", size, seed), lambda c: SeedLibrary(c, size, seed))


def restart_poses(
    chain: Chain,
    q0: NDArray[np.float64],
    target: Target | None,
    restarts: int,
    library_seeds: int,
    seed: int,
) -> Iterator[NDArray[np.float64]]:
    """The starts of a local solver: ``q0``, then ``restarts`` poses, the library's
    ``library_seeds`` poses nearest ``target`` alternating with seeded random in-range
    ones (the library's nearest poses may share one blocked basin; random ones do not).
    Each pose is a fresh array the caller may change."""
    yield q0.copy()
    near: NDArray[np.float64] | None = None
    used = drawn = 0
    for k in range(restarts):
        if k % 2 == 0 and target is not None and used < library_seeds:
            if near is None:  # ranked only when a restart is needed
                near = seed_library(chain).nearest(target, library_seeds)
            if used < near.shape[0]:
                used += 1
                yield near[used - 1].copy()
                continue
        yield random_starts(chain, seed, restarts)[drawn].copy()
        drawn += 1


def random_starts(chain: Chain, seed: int, count: int) -> NDArray[np.float64]:
    """The first ``count`` seeded random in-range poses ``(count, n)`` of ``chain``
    (``chain.random_q`` from ``default_rng(seed)``), drawn once per robot state and kept
    in its workspace: making the generator and drawing a pose cost 8 and 9 us, as much
    as an ``lm`` start, and every solve would draw the same ones."""
    key = ("random_starts", tuple(chain.joint_ids.tolist()), seed, count)

    def draw() -> NDArray[np.float64]:
        rng = np.random.default_rng(seed)
        return np.array([chain.random_q(rng) for _ in range(count)]).reshape(count, chain.n)

    return chain.robot.workspace(key, draw)
