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

__all__ = ["ROTATION_LENGTH", "SeedLibrary", "random_starts", "restart_poses", "seed_library"]

ROTATION_LENGTH = 0.3
"""What one radian of rotation weighs in the library's ranking [m/rad]."""


class SeedLibrary:
    """Joint vectors ``q (size, n)`` with FK positions ``(size, 3)`` and rotations
    ``(size, 3, 3)``, in the order of the positions' x.

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
        # in the order of x: a ranking visits the poses outward from the target's x
        order = np.argsort(positions[:, 0], kind="stable")
        self.q, self.positions, self.rotations = q[order], positions[order], rotations[order]
        self._flat = self.positions.reshape(-1), self.rotations.reshape(-1)
        # the library as the compiled loop takes it (_lm_kernel.Kernel.solve)
        self.packed = (*self._flat, self.q.reshape(-1), ROTATION_LENGTH)

    def nearest(
        self, target: Target, count: int, length: float = ROTATION_LENGTH
    ) -> NDArray[np.float64]:
        """The ``count`` poses ``(count, n)`` nearest ``target``, nearest first, by the
        distance [m] plus ``length`` [m/rad] times ``1 - cos`` of the rotation angle for
        a pose target; equal costs in library order. In C (``_lm_kernel.seed_nearest``),
        outward from the target's x until the x gap alone exceeds the ``count``-th cost:
        a few us for 4,000 poses, where ranking them with numpy took 40-60 us, as much
        as the ``lm`` start it is for."""
        index = np.empty(min(count, self.q.shape[0]), dtype=np.int64)
        rot = None if target.rotation is None else target.rotation.reshape(9)
        found = _lm_kernel.seed_nearest(*self._flat, target.position, rot, length, index)
        return self.q[index[:found]]


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
