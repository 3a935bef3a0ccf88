"""A library of seeded start poses for restarts: the poses whose FK lies nearest a target.

A local solver that stalls from its start (a joint range blocks the way, or a local
minimum) restarts better from a pose whose end effector already lies near the target
than from a uniform random one. The library holds ``size`` seeded random in-range joint
vectors and their FK (from MuJoCo), built once per chain.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.types import Target

__all__ = ["SeedLibrary", "seed_library"]


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

    def nearest(self, target: Target, k: int, length: float = 0.3) -> NDArray[np.float64]:
        """The ``k`` poses ``(k, n)`` nearest ``target``: distance [m] plus ``length`` [m/rad]
        times the rotation angle for a pose target (``1 - cos`` stands in for the angle)."""
        cost = np.linalg.norm(self.positions - target.position, axis=1)
        if target.rotation is not None:
            cos = (np.einsum("ij,nij->n", target.rotation, self.rotations) - 1.0) * 0.5
            cost += length * (1.0 - cos)
        k = min(k, cost.shape[0])
        idx = np.argpartition(cost, k - 1)[:k]
        return self.q[idx[np.argsort(cost[idx])]]


def seed_library(chain: Chain, size: int = 4000, seed: int = 7) -> SeedLibrary:
    """The chain's library of ``size`` poses, built on first use and kept with the chain
    (:meth:`Chain.derived`)."""
    return chain.derived(("seed_library", size, seed), lambda c: SeedLibrary(c, size, seed))
