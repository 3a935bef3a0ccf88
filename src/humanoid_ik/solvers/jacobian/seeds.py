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

__all__ = ["SeedLibrary", "random_starts", "restart_poses", "seed_library"]


class SeedLibrary:
    """Joint vectors ``q (size, n)`` with FK positions ``(size, 3)`` and rotations
    ``(size, 3, 3)``.

    Args:
        chain: the chain (its scratch data is restored to the current pose afterwards).
        size: number of poses.
        seed: generator seed.
    """

    def __init__(self, chain: Chain, size: int = 4000, seed: int = 7):
        rng = np.random.default_rng(seed)
        saved = chain.q
        self.q = np.array([chain.random_q(rng) for _ in range(size)])  # (size, n)
        self.positions = np.empty((size, 3))
        self.rotations = np.empty((size, 3, 3))
        for i, q in enumerate(self.q):
            chain.set_q(q)
            self.positions[i] = chain.position
            self.rotations[i] = chain.rotation
        chain.set_q(saved)
        # |x - p|^2 = |x|^2 - 2 x.p + |p|^2 and trace(R_t' R) = R_t : R as matrix-vector
        # products: a ranking costs about 15 us instead of about 150 us
        self._sq = np.einsum("ij,ij->i", self.positions, self.positions)
        self._rot9 = self.rotations.reshape(size, 9)

    def cost(self, target: Target, length: float = 0.3) -> NDArray[np.float64]:
        """Each pose's distance from ``target``: [m] plus ``length`` [m/rad] times the
        rotation angle for a pose target (``1 - cos`` stands in for the angle)."""
        p = target.position
        sq = self._sq - 2.0 * (self.positions @ p) + p @ p
        cost = np.sqrt(np.maximum(sq, 0.0, out=sq), out=sq)
        if target.rotation is not None:
            cos = (self._rot9 @ target.rotation.reshape(9) - 1.0) * 0.5
            cost += length * (1.0 - cos)
        return cost

    def ranked(self, target: Target, length: float = 0.3) -> Iterator[NDArray[np.float64]]:
        """The poses ``(n,)`` nearest ``target`` first (see :meth:`cost`), found one at a
        time: a solve that needs one restart pays for one search."""
        cost = self.cost(target, length)
        for _ in range(cost.shape[0]):
            i = int(np.argmin(cost))
            cost[i] = np.inf
            yield self.q[i]


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
    near: Iterator[NDArray[np.float64]] | None = None
    used = drawn = 0
    for k in range(restarts):
        if k % 2 == 0 and target is not None and used < library_seeds:
            if near is None:  # ranked only when a restart is needed
                near = seed_library(chain).ranked(target)
            pose = next(near, None)
            if pose is not None:
                used += 1
                yield pose.copy()
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
