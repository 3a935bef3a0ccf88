"""Type stub of the compiled ``_lm_kernel`` module (``_lm_kernel.c``)."""

import numpy as np
from numpy.typing import NDArray

MUJOCO_VERSION: int
"""``mjVERSION_HEADER`` of the MuJoCo headers the module was built against."""

class Kernel:
    """lm's iteration loop on its own copy of a model (the bytes of ``mj_saveModel``)."""

    def __init__(self, model: bytes | NDArray[np.uint8]) -> None: ...
    @property
    def nq(self) -> int: ...
    @property
    def nv(self) -> int: ...
    def descend(
        self,
        qpos: NDArray[np.float64],
        qpos_adr: NDArray[np.int64],
        dof_adr: NDArray[np.int64],
        site: bool,
        ee_id: int,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        target_pos: NDArray[np.float64],
        target_quat: NDArray[np.float64] | None,
        options: tuple[float, float, float, float, float, int, int],
        q: NDArray[np.float64],
        /,
    ) -> tuple[bool, int, float, float, float]: ...
    def restart(
        self,
        qpos: NDArray[np.float64],
        qpos_adr: NDArray[np.int64],
        dof_adr: NDArray[np.int64],
        site: bool,
        ee_id: int,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        target_pos: NDArray[np.float64],
        target_quat: NDArray[np.float64] | None,
        options: tuple[float, float, float, float, float, int, int],
        q: NDArray[np.float64],
        target_rot: NDArray[np.float64] | None,
        library: tuple[
            NDArray[np.float64],
            NDArray[np.float64],
            NDArray[np.float64],
            NDArray[np.int64],
            NDArray[np.float64],
            float,
        ]
        | None,
        library_seeds: int,
        randoms: NDArray[np.float64],
        restarts: int,
        best_cost: float,
        /,
    ) -> tuple[bool, int, float, float, float]:
        """lm's restarts of one target after its first start (``LM._solve``)."""
    def measure(
        self,
        qpos: NDArray[np.float64],
        qpos_adr: NDArray[np.int64],
        dof_adr: NDArray[np.int64],
        site: bool,
        ee_id: int,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        positions: NDArray[np.float64],
        quats: NDArray[np.float64],
        options: tuple[float, float, float, float, float, int, int],
        scratch: NDArray[np.float64],
        qs: NDArray[np.float64],
        out_info: NDArray[np.float64],
        /,
    ) -> None:
        """The kernel's measure of many joint vectors (``Subproblem.solve_many``)."""
    def set_mocap(
        self, mocap_pos: NDArray[np.float64], mocap_quat: NDArray[np.float64], /
    ) -> None: ...
    def solve(
        self,
        qpos: NDArray[np.float64],
        qpos_adr: NDArray[np.int64],
        dof_adr: NDArray[np.int64],
        site: bool,
        ee_id: int,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        positions: NDArray[np.float64],
        quats: NDArray[np.float64],
        options: tuple[float, float, float, float, float, int, int],
        q0: NDArray[np.float64],
        rotations: NDArray[np.float64],
        library: tuple[
            NDArray[np.float64],
            NDArray[np.float64],
            NDArray[np.float64],
            NDArray[np.int64],
            NDArray[np.float64],
            float,
        ]
        | None,
        library_seeds: int,
        randoms: NDArray[np.float64],
        restarts: int,
        out_q: NDArray[np.float64],
        out_info: NDArray[np.float64],
        /,
    ) -> None:
        """lm's whole solve of many targets (``LM.solve_many``)."""

def seed_nearest(
    positions: NDArray[np.float64],
    rotations: NDArray[np.float64],
    grid: NDArray[np.float64],
    cells: NDArray[np.int64],
    target_pos: NDArray[np.float64],
    target_rot: NDArray[np.float64] | None,
    length: float,
    out: NDArray[np.int64],
    /,
) -> int:
    """The indices of the seed library's poses nearest a target into ``out``, nearest
    first; returns how many (``seeds.SeedLibrary.nearest``)."""
