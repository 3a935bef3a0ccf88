"""IK datasets: many (target pose, joint solution) pairs, on any arm.

Each pair is made from a uniform random in-range joint vector ``q_s``: the target is the
end effector's pose at ``q_s`` (MuJoCo FK), and the stored solution is the solver's answer
for that pose, started from the chain's home posture. The solver is ``closed_form`` where
it fits the chain (a 7-hinge arm: its vectorised
:func:`~humanoid_ik.solvers.analytic.closed_form.solve_batch`, the feasible swivel
closest to home's), else ``auto`` (:func:`~humanoid_ik.solvers.batch.solve_batch`, one
target at a time); ``solver=`` picks another. Where the solver finds no solution (rare:
every target is reachable inside the ranges) ``q_s`` itself is stored and ``ok`` is False
for that row.

Randomness comes in fixed blocks of :data:`BLOCK` samples, block ``k`` drawn from
``numpy.random.default_rng([seed, k])``, and every block is solved as a whole, so a seed
and ``n`` always give the same arrays whatever the chunk size or the order in which
chunks are made. The file is a standard ``.npz`` (``numpy.load`` opens it) with fixed
zip timestamps, so it is byte-for-byte the same too:

=================  ==========  ==========================================================
member             shape       meaning
=================  ==========  ==========================================================
``positions``      ``(N, 3)``  target positions [m], world frame
``quats``          ``(N, 4)``  target orientations, unit wxyz with ``w >= 0``
``q``              ``(N, n)``  joint solutions [rad], in ``meta["joints"]`` order
``ok``             ``(N,)``    True where ``q`` is the solver's converged answer
``meta``           ``()``      JSON text: format, model, site (or body), joints, seed, n, ...
=================  ==========  ==========================================================

Chunks are written as they are made into raw files beside the output and packed into the
``.npz`` at the end, which is then renamed into place
(:func:`~humanoid_ik.outputs.atomic.atomic_path`: never half written); memory stays at a
few chunks whatever ``n`` is. ``n`` is at most :data:`MAX_PAIRS` and ``chunk`` at most
:data:`MAX_CHUNK`, and a dataset that would not fit on the disk (raw chunks and the
file, :func:`bytes_needed`) is refused before it starts.
"""

from __future__ import annotations

import json
import os
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import display_model, load_model
from humanoid_ik.core.robot_files import PackagePaths
from humanoid_ik.core.rotations import mat_to_quat
from humanoid_ik.errors import DatasetError, HumanoidIKError
from humanoid_ik.outputs.atomic import atomic_dir, atomic_path, output_file

__all__ = [
    "BLOCK",
    "FORMAT",
    "MAX_CHUNK",
    "MAX_PAIRS",
    "Dataset",
    "bytes_needed",
    "make_block",
    "read_dataset",
    "write_dataset",
]

BLOCK = 4096
"""Samples per seeded block (fixed: changing it changes every dataset)."""
FORMAT = "humanoid_ik.dataset/2"
"""Format 2 (member ``ok``, any solver); format 1 files (member ``closed_form_ok``) read too."""
_FORMAT_1 = "humanoid_ik.dataset/1"
MAX_PAIRS = 100_000_000
"""Most pairs in one dataset (about 11 GB for a 7-joint arm)."""
MAX_CHUNK = 1 << 20
"""Most pairs made and held in memory per step (about 120 MB for a 7-joint arm)."""
_ARRAYS = ("positions", "quats", "q", "ok")
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


class Dataset(NamedTuple):
    """A dataset read back by :func:`read_dataset`."""

    positions: NDArray[np.float64]
    """Target positions ``(N, 3)`` [m]."""
    quats: NDArray[np.float64]
    """Target orientations ``(N, 4)``, wxyz."""
    q: NDArray[np.float64]
    """Joint solutions ``(N, n)`` [rad]."""
    ok: NDArray[np.bool_]
    """``(N,)``: True where ``q`` is the solver's converged answer."""
    meta: dict[str, Any]
    """Format, model, the end effector's name under ``site`` or ``body``, joint names,
    seed, n, block and solver."""

    @property
    def closed_form_ok(self) -> NDArray[np.bool_]:
        """Deprecated name of :attr:`ok` (format 1's member), for one release."""
        import warnings

        warnings.warn("Dataset.closed_form_ok is now Dataset.ok", DeprecationWarning, 2)
        return self.ok


def make_block(
    chain: Chain, seed: int, block: int, solver: str = "closed_form"
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Block ``block`` of the dataset with seed ``seed``: :data:`BLOCK` pairs, solved by
    ``solver`` from the chain's home posture.

    Returns:
        ``positions (B, 3)``, ``quats (B, 4)``, ``q (B, n)``, ``ok (B,)``.
    """
    from humanoid_ik.solvers.analytic.closed_form import solve_batch as closed_form_batch
    from humanoid_ik.solvers.batch import solve_batch

    rng = np.random.default_rng([seed, block])
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    q_s = rng.uniform(lo, hi, size=(BLOCK, chain.n))  # (B, n)
    positions = np.empty((BLOCK, 3))
    quats = np.empty((BLOCK, 4))
    for i in range(BLOCK):
        p, R = chain.fk(q_s[i])
        positions[i] = p
        quats[i] = mat_to_quat(R)
    chain.reset()
    if solver == "closed_form":
        q, ok = closed_form_batch(chain, positions, quats)
    else:
        results = solve_batch(chain, positions, solver, quats=quats, q0=chain.q_home)
        q, ok = results.q, results.converged
    q = np.where(ok[:, None], q, q_s)
    return positions, quats, q, ok


def write_dataset(
    path: str | os.PathLike,
    n: int,
    seed: int = 0,
    *,
    chunk: int = 65536,
    model: str | os.PathLike | None = None,
    site: str | None = None,
    joints: list[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    packages: PackagePaths | None = None,
    chain: Chain | None = None,
    solver: str | None = None,
) -> Path:
    """Write ``n`` (target pose, joint solution) pairs to ``path`` (``.npz``).

    Args:
        path: the output file.
        n: number of pairs (>= 1).
        seed: seed (>= 0); the same seed and ``n`` give the same file.
        chunk: pairs made and written per step (>= 1); does not change the content.
        model: MJCF path (default: the bundled humanoid).
        site: end-effector site (default: ``right_palm_site``).
        joints: the chain's joints (default: the hinges from the site to the root).
        progress: called ``(done, n)`` after each chunk.
        packages: ROS package folders of a URDF's ``package://`` paths.
        chain: the chain itself (a body's, a limb's: what the command line's ``--body``,
            ``--arm`` and ``--limb`` name), instead of ``site`` and ``joints``; ``model``
            then only names its file in ``meta``.
        solver: the solver of every pair (a name of ``SOLVERS`` that takes pose
            targets); default ``closed_form`` where it fits the chain, else ``auto``.

    Returns:
        ``path``.

    Raises:
        DatasetError: ``n``, ``seed`` or ``chunk`` out of range, a solver that does not
            fit the chain, or an output folder that does not exist.
        SolverError: an unknown solver.
    """
    for name, value, low, high in (
        ("n", n, 1, MAX_PAIRS),
        ("seed", seed, 0, None),
        ("chunk", chunk, 1, MAX_CHUNK),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise DatasetError(f"{name} must be an integer, got {value!r}")
        if value < low or (high is not None and value > high):
            upper = "" if high is None else f" and <= {high}"
            raise DatasetError(f"{name} must be an integer >= {low}{upper}, got {value!r}")
    out = output_file(path)  # a link written through; a device or FIFO refused
    if out.is_dir():
        raise DatasetError(f"cannot write '{out}': it is a folder; expected a .npz file path")
    if not out.parent.is_dir():
        raise DatasetError(f"cannot write '{out}': folder '{out.parent}' does not exist")
    if chain is None:
        chain = Chain(load_model(model, packages=packages), site, joints)
    elif site is not None or joints is not None:
        raise DatasetError("give a chain or its site and joints, not both")
    solver = _dataset_solver(chain, solver)
    need, free = bytes_needed(int(n), chain.n), shutil.disk_usage(out.parent).free
    if need > free:
        raise DatasetError(
            f"{n} pairs need about {need / 1e9:.3g} GB in '{out.parent}' (raw chunks and "
            f"the file); {free / 1e9:.3g} GB free"
        )
    meta = {
        "format": FORMAT,
        "model": display_model(model),
        chain.ee_kind: chain.ee_name,
        "joints": list(chain.joint_names),
        "seed": int(seed),
        "n": int(n),
        "block": BLOCK,
        "solver": solver,
        "target": "FK of uniform random in-range joints",
        "quat": "wxyz, w >= 0",
        "units": {"positions": "m", "q": "rad"},
    }
    n, seed = int(n), int(seed)
    with atomic_dir(out) as tmpdir:
        _write_chunks(chain, n, seed, chunk, tmpdir, progress, solver)
        with atomic_path(out) as tmp_zip:
            _pack(tmpdir, tmp_zip, n, chain.n, meta)
    return out


def _dataset_solver(chain: Chain, solver: str | None) -> str:
    """The solver of a dataset on ``chain``: ``solver`` checked, or the default."""
    from humanoid_ik.solvers import make_solver

    if solver is None:
        return (
            "closed_form" if make_solver("closed_form").applicable(chain, True) is None else "auto"
        )
    reason = make_solver(solver).applicable(chain, True)  # an unknown name: SolverError
    if reason is not None:
        raise DatasetError(f"{solver} does not fit chain {chain.ee_name}: {reason}")
    return solver


def bytes_needed(n: int, n_joints: int) -> int:
    """Disk space [bytes] that writing ``n`` pairs of an ``n_joints`` chain takes at its
    peak: the raw chunks and the ``.npz`` beside them (each row: 3 + 4 + ``n_joints``
    float64 and one bool), plus 1 MB of headers."""
    return 2 * n * (8 * (3 + 4 + n_joints) + 1) + (1 << 20)


def _write_chunks(
    chain: Chain,
    n: int,
    seed: int,
    chunk: int,
    folder: Path,
    progress: Callable[[int, int], None] | None,
    solver: str,
) -> None:
    """Make the first ``n`` pairs of seed ``seed``, ``chunk`` at a time, appending each
    array's bytes to ``folder/<name>.raw`` (memory: a few blocks)."""
    raws = {k: open(folder / f"{k}.raw", "wb") for k in _ARRAYS}  # noqa: SIM115
    try:
        cached: tuple[int, tuple] | None = None
        for a in range(0, n, chunk):
            b = min(a + chunk, n)
            parts: list[list[np.ndarray]] = [[] for _ in _ARRAYS]
            for k in range(a // BLOCK, (b - 1) // BLOCK + 1):
                if cached is None or cached[0] != k:
                    cached = (k, make_block(chain, seed, k, solver))
                lo, hi = max(a, k * BLOCK) - k * BLOCK, min(b, (k + 1) * BLOCK) - k * BLOCK
                for j, arr in enumerate(cached[1]):
                    parts[j].append(arr[lo:hi])
            for key, arrs in zip(_ARRAYS, parts, strict=True):
                raws[key].write(np.ascontiguousarray(np.concatenate(arrs)).tobytes())
            if progress is not None:
                progress(b, n)
    finally:
        for fh in raws.values():
            fh.close()


def _pack(folder: Path, path: Path, n: int, n_joints: int, meta: dict[str, Any]) -> None:
    """Pack the raw arrays in ``folder`` (``n`` rows, ``n_joints`` joints) and ``meta``
    into the ``.npz`` at ``path``, with fixed timestamps (the same content, the same
    bytes)."""
    shapes = {"positions": (n, 3), "quats": (n, 4), "q": (n, n_joints), "ok": (n,)}
    dtypes = {"ok": np.dtype(np.bool_)}
    zf = zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True)
    try:
        _pack_into(zf, folder, shapes, dtypes, meta)
        zf.close()
    except BaseException:
        # a signal mid-member: the file is abandoned (the caller removes it); drop it
        # without ZipFile's close, which refuses an open member and, from __del__,
        # would print a traceback after the one line of a Ctrl-C
        fp, zf.fp = zf.fp, None
        if fp is not None:
            fp.close()
        raise


def _pack_into(
    zf: zipfile.ZipFile,
    folder: Path,
    shapes: dict[str, tuple[int, ...]],
    dtypes: dict[str, np.dtype],
    meta: dict[str, Any],
) -> None:
    """Write the members of :func:`_pack` into ``zf``."""
    for key in _ARRAYS:
        header = {
            "descr": np.lib.format.dtype_to_descr(dtypes.get(key, np.dtype("<f8"))),
            "fortran_order": False,
            "shape": shapes[key],
        }
        with zf.open(_info(f"{key}.npy"), "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_2_0(fh, header)
            with open(folder / f"{key}.raw", "rb") as raw:
                shutil.copyfileobj(raw, fh, 1 << 20)
    with zf.open(_info("meta.npy"), "w") as fh:
        np.lib.format.write_array(fh, np.array(json.dumps(meta, sort_keys=True)))


def _info(name: str) -> zipfile.ZipInfo:
    """A zip member ``name``, stored, with the fixed timestamp and mode 0644."""
    info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
    info.compress_type = zipfile.ZIP_STORED
    info.external_attr = 0o644 << 16
    return info


def read_dataset(path: str | os.PathLike) -> Dataset:
    """Read a dataset written by :func:`write_dataset`.

    Raises:
        DatasetError: the file is missing, not an ``.npz``, or not a humanoid_ik dataset.
    """
    p = Path(path)
    try:
        with np.load(p, allow_pickle=False) as npz:
            old = "closed_form_ok" in npz.files and "ok" not in npz.files  # format 1
            members = {k: "closed_form_ok" if old and k == "ok" else k for k in _ARRAYS}
            missing = [m for m in (*members.values(), "meta") if m not in npz.files]
            if missing:
                raise DatasetError(
                    f"'{p}' is not a humanoid_ik dataset: no {', '.join(missing)} in it"
                )
            arrays = {k: npz[m] for k, m in members.items()}
            meta = json.loads(str(npz["meta"]))
    except HumanoidIKError:
        raise
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise DatasetError(f"cannot read dataset '{p}': {exc}") from None
    if meta.get("format") not in (FORMAT, _FORMAT_1):
        raise DatasetError(
            f"'{p}' has format {meta.get('format')!r}; expected {FORMAT!r} or {_FORMAT_1!r}"
        )
    return Dataset(meta=meta, **arrays)
