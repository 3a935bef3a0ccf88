"""The compiled iteration loop of ``lm`` (``_lm_loop.c``), loaded through ctypes.

From Python an ``lm`` iteration is about a dozen calls into MuJoCo at 0.3-1 µs each,
3.2-5 times the cost of the FK + Jacobian call it is built on (``benchmarks/floor.py``).
``_lm_loop.c`` runs the same loop in C, calling the same MuJoCo functions in the same
order, so a start costs one call from Python and its iterations cost little more than
MuJoCo's own work; the answers are the Python loop's, bit for bit.

The C file needs no MuJoCo or Python header: the MuJoCo functions are passed as
addresses taken from MuJoCo's own shared library (the one the ``mujoco`` package
loaded), the model and data as opaque pointers, and the arrays it reads and writes as
pointers into ``MjData`` and the solver's buffers. It is compiled when the package is
installed (``setup.py``, an optional extension: without a C compiler the install still
succeeds and ``lm`` runs the Python loop). :data:`AVAILABLE` says which loop ``lm``
runs; the environment variable ``HUMANOID_IK_LM_LOOP=python`` selects the Python loop.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
from pathlib import Path
from typing import Any, NamedTuple

import mujoco
import numpy as np
from numpy.typing import NDArray

__all__ = ["AVAILABLE", "REASON", "Problem", "stale"]

_PTR = ctypes.c_void_p
_API = (
    ("kinematics", "mj_kinematics"),
    ("com_pos", "mj_comPos"),
    ("jac", None),  # mj_jacSite or mj_jacBody, per problem
    ("sub3", "mju_sub3"),
    ("norm3", "mju_norm3"),
    ("scl3", "mju_scl3"),
    ("sub_quat", "mju_subQuat"),
    ("mul_mat_vec3", "mju_mulMatVec3"),
    ("sqr_mat_td", "mju_sqrMatTD"),
    ("add_to_scl", "mju_addToScl"),
    ("mul_mat_t_vec", "mju_mulMatTVec"),
    ("mul_mat_vec", "mju_mulMatVec"),
    ("box_qp", "mju_boxQP"),
)


class _Api(ctypes.Structure):
    _fields_ = [(name, _PTR) for name, _ in _API]


_INTS = ("n", "rows", "nv", "ee_id", "max_iterations", "window")
_ARRAYS = (
    "qadr", "dof", "qpos", "xpos", "body_quat", "body_mat", "target_pos", "target_body",
    "jac", "J", "w", "H", "eye", "g", "Hx", "R", "e", "q_err", "x", "best_q", "history",
    "lower", "upper",
)  # fmt: skip
_FLOATS = ("tol", "rot_tol", "wr", "damp_e", "damp_0")


class _Problem(ctypes.Structure):
    _fields_ = (
        [("m", _PTR), ("d", _PTR)]
        + [(k, ctypes.c_int) for k in _INTS]
        + [(k, _PTR) for k in _ARRAYS]
        + [(k, ctypes.c_double) for k in _FLOATS]
    )


def stale(source: Path, compiled: Path) -> bool:
    """Whether ``compiled`` was built before ``source`` last changed (in a checkout,
    after an edit of the C file and before the next ``pip install -e .``; a wheel has no
    source beside it)."""
    return source.exists() and source.stat().st_mtime > compiled.stat().st_mtime


class _Loaded(NamedTuple):
    descend: Any  # lm_descend from the compiled file
    api: _Api  # MuJoCo's functions, ``jac`` unset
    jac_site: int  # mj_jacSite and mj_jacBody: one of them per problem
    jac_body: int


def _load() -> tuple[_Loaded | None, str]:
    """The compiled loop bound to MuJoCo's library, or ``None`` and why not."""
    if os.environ.get("HUMANOID_IK_LM_LOOP", "").strip().lower() == "python":
        return None, "HUMANOID_IK_LM_LOOP=python"
    spec = importlib.util.find_spec(f"{__package__}._lm_loop")
    if spec is None or not spec.origin:
        return None, "not compiled (no C compiler when the package was installed)"
    if stale(Path(__file__).with_name("_lm_loop.c"), Path(spec.origin)):
        return None, "compiled before the last change to _lm_loop.c; pip install -e ."
    libs = sorted(Path(mujoco.__file__).parent.glob("libmujoco*"))
    if not libs:
        return None, "MuJoCo's shared library was not found in the mujoco package"
    try:
        lib = ctypes.CDLL(spec.origin)
        mj = ctypes.CDLL(str(libs[0]))
        names = [c for _, c in _API if c] + ["mj_jacSite", "mj_jacBody"]
        addr = {c: int(ctypes.cast(getattr(mj, c), _PTR).value or 0) for c in names}
        fn = lib.lm_descend
    except (OSError, AttributeError) as exc:
        return None, f"could not be loaded: {exc}"
    fn.restype = ctypes.c_int
    fn.argtypes = [_PTR, _PTR, _PTR, _PTR]
    api = _Api(**{name: addr[c] for name, c in _API if c})
    return _Loaded(fn, api, addr["mj_jacSite"], addr["mj_jacBody"]), ""


_LOADED, REASON = _load()
AVAILABLE: bool = _LOADED is not None
"""Whether ``lm`` runs the compiled loop (:data:`REASON` says why not)."""


def _address(a: NDArray[Any]) -> int:
    return int(a.__array_interface__["data"][0])


class Problem:
    """The compiled loop's view of one ``lm`` work buffer set: pointers to the chain's
    data and the buffers, set once; :meth:`descend` runs one start.

    Args:
        arrays: name -> array of every pointer field (``_ARRAYS``), each C-contiguous
            float64 (``qadr`` and ``dof`` int64), alive as long as this object.
        ints, floats: the integer and float fields.
        site: whether the end effector is a site (``mj_jacSite``) or a body.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        arrays: dict[str, NDArray[Any]],
        ints: dict[str, int],
        floats: dict[str, float],
        site: bool,
    ):
        if _LOADED is None:
            raise RuntimeError(f"the compiled lm loop is not available: {REASON}")
        self._fn = _LOADED.descend
        self._keep = dict(arrays)  # the buffers must outlive the pointers
        for name, a in arrays.items():
            want = np.int64 if name in ("qadr", "dof") else np.float64
            if a.dtype != want or not a.flags.c_contiguous:
                raise ValueError(f"lm loop buffer {name!r} must be C-contiguous {want.__name__}")
        self._p = _Problem(
            m=model._address,
            d=data._address,
            **{k: _address(a) for k, a in arrays.items()},
            **ints,
            **floats,
        )
        self._api = _Api.from_buffer_copy(_LOADED.api)
        self._api.jac = _LOADED.jac_site if site else _LOADED.jac_body
        self._out = np.empty(4)
        self._q = np.empty(ints["n"])  # the start and the answer pass through here
        self._ptrs = (ctypes.addressof(self._api), ctypes.addressof(self._p))
        self._out_ptr, self._q_ptr = _address(self._out), _address(self._q)

    def set_array(self, name: str, a: NDArray[np.float64]) -> None:
        """Point field ``name`` at ``a`` (kept alive here), e.g. re-read joint ranges."""
        self._keep[name] = a
        setattr(self._p, name, _address(a))

    def descend(self, q: NDArray[np.float64]) -> tuple[bool, int, float, float, float]:
        """One start from ``q`` (``(n,)``, written with the answer), as
        ``LM._descend``: ``(converged, iterations, cost, position error, orientation
        error)``."""
        self._q[:] = q
        ok = self._fn(self._ptrs[0], self._ptrs[1], self._q_ptr, self._out_ptr)
        q[:] = self._q
        out = self._out.tolist()
        return bool(ok), int(out[0]), out[1], out[2], out[3]
