"""The on-disk cache of compiled models and converted meshes.

A heavy robot (hundreds of thousands of mesh triangles) takes seconds to compile: MuJoCo
parses every mesh file, builds its bounding-volume tree and the convex hull of each
collision mesh. :func:`compile_cached` keeps the compiled model, so the next command on
the same robot loads it instead (``mj_saveModel`` / ``mj_loadModel``). The key is what
the compile reads: the spec as edited (every element and setting,
:func:`spec_digest`), the bytes of every file it names and of every in-memory asset,
and the MuJoCo version. Any change to one of them is another key; nothing is ever
served stale.

Entries live in :func:`cache_dir` (``HUMANOID_IK_CACHE``, else
``$XDG_CACHE_HOME/humanoid_ik``, else ``~/.cache/humanoid_ik``): ``models/`` holds
compiled models, ``meshes/`` the meshes of ``core/meshes.py``; past
:data:`CACHE_LIMIT_BYTES` the least recently used go. Each entry has a checksum file
(its SHA-256) and is checked before use: a corrupt or truncated entry is rebuilt, never
trusted. Writes are atomic (a temporary file renamed into place), so two processes
filling the same entry never see half a file. A folder that cannot be written only
means no caching (one :class:`ModelWarning` note).
"""

from __future__ import annotations

import hashlib
import os
import threading
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from humanoid_ik.core.robot_files import ModelWarning

__all__ = [
    "CACHE_ENV",
    "CACHE_LIMIT_BYTES",
    "MESHES",
    "MIN_CACHED_BYTES",
    "cache_dir",
    "compile_cached",
    "file_digest",
    "read_entry",
    "spec_digest",
    "spec_files",
    "write_entry",
]

CACHE_ENV = "HUMANOID_IK_CACHE"
"""The environment variable naming the cache folder (an empty value: no caching)."""
MIN_CACHED_BYTES = 1_000_000
"""Mesh, texture and height-field data [bytes] below which a spec is compiled without
the cache: such a compile (the bundled humanoid's: about 35 ms) costs no more than
computing the key and loading the entry."""
CACHE_LIMIT_BYTES = 1_000_000_000
"""Size [bytes] of the cache's entries kept (a heavy robot's compiled model is about
60 MB); past it, after a model is written, the least recently used go."""

_FORMAT = b"humanoid-ik cache 1 sha256 "
"""First bytes of an entry's checksum file (the payload's hex SHA-256 follows)."""
_SUM = ".sha256"
_MODELS = "models"
MESHES = "meshes"
"""The folder of ``core/meshes.py``'s entries."""
_FAILED = b"failed\n"
"""Payload prefix of an entry that records a compile failure (its message follows)."""
_TRANSIENT = ("opening file", "resource not found", "could not open")
"""Words of a compile failure that another try may not repeat (a file that went away
while compiling): not remembered."""
_warned: set[str] = set()
_digests: dict[tuple[str, int, int, int], str] = {}
_lock = threading.Lock()


# ----------------------------------------------------------------------------- folder
def cache_dir() -> Path | None:
    """The cache folder: ``$HUMANOID_IK_CACHE``, else ``$XDG_CACHE_HOME/humanoid_ik``,
    else ``~/.cache/humanoid_ik``; ``None`` (no caching) when ``HUMANOID_IK_CACHE`` is
    set and empty, or no home folder is known. Not created here."""
    env = os.environ.get(CACHE_ENV)
    if env is not None:
        return Path(env).expanduser() if env.strip() else None
    xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
    if xdg:
        return Path(xdg) / "humanoid_ik"
    try:
        return Path.home() / ".cache" / "humanoid_ik"
    except RuntimeError:  # no home folder
        return None


def _verified(kind: str, key: str) -> tuple[Path, bytes] | None:
    """The path and payload of entry ``key`` of the ``kind`` folder when its checksum
    file matches; a corrupt or half-written entry is removed (to be rebuilt) and
    ``None`` returned."""
    root = cache_dir()
    if root is None:
        return None
    path = root / kind / key
    try:
        payload = path.read_bytes()
        expected = (root / kind / f"{key}{_SUM}").read_bytes()
    except OSError:
        return None
    if expected != _FORMAT + hashlib.sha256(payload).hexdigest().encode():
        for stale in (path, root / kind / f"{key}{_SUM}"):
            try:
                stale.unlink()
            except OSError:
                pass
        return None
    try:
        os.utime(path)  # the least recently used go first (_prune)
    except OSError:
        pass
    return path, payload


def read_entry(kind: str, key: str) -> bytes | None:
    """The payload of entry ``key`` in the cache's ``kind`` folder; ``None`` when there
    is none, or it is corrupt or truncated (it is then removed, to be rebuilt)."""
    found = _verified(kind, key)
    return None if found is None else found[1]


def write_entry(kind: str, key: str, payload: bytes) -> None:
    """Store ``payload`` as entry ``key`` of the ``kind`` folder (the file ``key`` and
    its checksum ``key.sha256``), each written atomically: a temporary file in the same
    folder renamed into place. A folder that cannot be written: no entry, and one
    :class:`ModelWarning` per folder and process."""
    root = cache_dir()
    if root is None:
        return
    folder = root / kind
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _write_atomic(folder / key, payload)
        _write_atomic(
            folder / f"{key}{_SUM}", _FORMAT + hashlib.sha256(payload).hexdigest().encode()
        )
    except OSError as exc:
        with _lock:
            first = str(root) not in _warned
            _warned.add(str(root))
        if first:
            why = exc.strerror or type(exc).__name__
            warnings.warn(
                f"cache folder '{root}' cannot be written ({why}); models and converted "
                f"meshes are rebuilt each time (set {CACHE_ENV} to a writable folder)",
                ModelWarning,
                3,
            )


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file beside it, renamed into place.

    Raises:
        OSError: the folder cannot be written (the temporary file is removed).
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def _prune(root: Path, limit: int) -> None:
    """Remove the least recently used entries of the cache at ``root`` (with their
    checksums) until it holds at most ``limit`` bytes."""
    entries = []
    for kind in (_MODELS, MESHES):
        try:
            for e in os.scandir(root / kind):
                if not e.name.endswith(_SUM) and not e.name.startswith("."):
                    st = e.stat()
                    entries.append((st.st_mtime, st.st_size, Path(e.path)))
        except OSError:
            continue
    total = sum(size for _, size, _ in entries)
    for _, size, path in sorted(entries, key=lambda t: t[0]):
        if total <= limit:
            break
        for stale in (path, path.with_name(path.name + _SUM)):
            try:
                stale.unlink()
            except OSError:
                pass
        total -= size


# ----------------------------------------------------------------------------- key
def file_digest(path: str | os.PathLike) -> str:
    """Hex SHA-256 of the file's bytes, remembered per process while the file's size,
    modification time and inode stay the same.

    Raises:
        OSError: the file cannot be read.
    """
    st = os.stat(path)
    stamp = (os.fspath(path), st.st_size, st.st_mtime_ns, st.st_ino)
    with _lock:
        known = _digests.get(stamp)
    if known is not None:
        return known
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    digest = h.hexdigest()
    with _lock:
        _digests[stamp] = digest
    return digest


_ELEMENT_LISTS = (
    "meshes",
    "materials",
    "textures",
    "hfields",
    "skins",
    "flexes",
    "actuators",
    "sensors",
    "tendons",
    "equalities",
    "excludes",
    "pairs",
    "keys",
    "numerics",
    "texts",
    "tuples",
)
"""The spec's top-level element lists (the body tree is walked from ``worldbody``)."""
_SETTINGS = (
    "compiler",
    "option",
    "visual",
    "stat",
    "modelname",
    "meshdir",
    "texturedir",
    "strippath",
    "memory",
    "nconmax",
    "njmax",
    "nstack",
    "nuserdata",
    "nuser_actuator",
    "nuser_body",
    "nuser_cam",
    "nuser_geom",
    "nuser_jnt",
    "nuser_sensor",
    "nuser_site",
    "nuser_tendon",
    "nkey",
)
_SKIPPED = frozenset(
    {"id", "signature", "info", "compiler", "parent", "classname", "childclass", "frame"}
    | {"plugin", "config"}
)
"""Element attributes left out of the key: set by a compile (``id``, ``signature``),
the source location (``info``), the spec's own compiler (hashed once), and references
to other elements: the parent (the walk goes down the tree), the default class (its
values are already the element's), the frame and plugin (a spec with frames or
plugins is not cached). Reading some of the references crashes the bindings."""


def spec_digest(spec: mujoco.MjSpec) -> str:
    """Hex SHA-256 of everything in ``spec`` that its compile depends on, without
    compiling: every element (the body tree from ``worldbody``, then the asset and
    other lists) with all its attributes, the compiler, option, visual and size
    settings, the top default class, and the names and bytes of ``spec.assets``
    (files named by path are not read here: see :func:`spec_files`)."""
    h = hashlib.sha256()
    _fold(h, spec.worldbody, 0)
    for name in _ELEMENT_LISTS:
        h.update(f"\0{name}".encode())
        _fold(h, list(getattr(spec, name)), 0)
    for name in _SETTINGS:
        h.update(f"\0{name}".encode())
        _fold(h, getattr(spec, name), 0)
    _fold(h, spec.default, 0)
    for name in sorted(spec.assets):
        data = spec.assets[name]
        h.update(f"\0asset {name}\0".encode())
        h.update(hashlib.sha256(data if isinstance(data, bytes) else str(data).encode()).digest())
    return h.hexdigest()


def _fold(h: Any, value: Any, depth: int) -> None:
    """Feed ``value`` into the hash ``h``: plain values by ``repr``, arrays by their
    bytes, lists item by item, spec elements and setting structs by their public
    attributes (element lists below them are walked whole; ``depth`` bounds structs
    nested in structs)."""
    if value is None or isinstance(value, (str, int, float, bool, bytes)):
        h.update(repr(value).encode())
    elif isinstance(value, np.ndarray):
        h.update(f"{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, (list, tuple)):
        h.update(f"[{len(value)}".encode())
        for item in value:
            _fold(h, item, depth)
    elif type(value).__name__.startswith("mjt"):  # an enum
        h.update(f"{type(value).__name__}={int(value)}".encode())
    elif type(value).__name__.endswith("Vec"):  # MjDoubleVec, MjIntVec, MjStringVec
        _fold(h, np.asarray(value) if len(value) else b"", depth)
    elif depth < 4:
        h.update(f"<{type(value).__name__}".encode())
        for attr in _attributes(value):
            h.update(f" {attr}=".encode())
            try:
                item = getattr(value, attr)
            except Exception:  # an attribute without a value here
                h.update(b"?")
                continue
            _fold(h, item, depth + 1 if not isinstance(item, list) else depth)
        h.update(b">")
    else:
        h.update(type(value).__name__.encode())


_attr_names: dict[type, list[str]] = {}


def _attributes(value: Any) -> list[str]:
    """The public data attributes of a spec object's type (methods left out)."""
    kind = type(value)
    names = _attr_names.get(kind)
    if names is None:
        names = sorted(
            a
            for a in dir(kind)
            if not a.startswith("_")
            and a not in _SKIPPED
            and isinstance(getattr(kind, a, None), property)
        )
        _attr_names[kind] = names
    return names


def spec_files(spec: mujoco.MjSpec) -> list[Path] | None:
    """The files the compile of ``spec`` reads (meshes, textures, height fields, skins),
    as MuJoCo finds them: an absolute name as is, a relative one under the model's
    folder and the compiler's ``meshdir`` / ``texturedir``; names served from
    ``spec.assets`` left out. ``None`` when one is missing (the compile will say so)."""
    base = Path(spec.modelfiledir or ".")
    out: list[Path] = []
    for name, folder in _named_files(spec):
        if not name or name in spec.assets:
            continue
        path = Path(name)
        if not path.is_absolute():
            path = base / (folder or "") / name
        if not path.is_file():
            return None
        out.append(path)
    return out


def _named_files(spec: mujoco.MjSpec) -> Iterator[tuple[str, str]]:
    """``(file name, the compiler folder it is looked up in)`` of every element that
    names a file."""
    meshdir = spec.compiler.meshdir or spec.meshdir
    texturedir = spec.compiler.texturedir or spec.texturedir
    for mesh in spec.meshes:
        yield mesh.file, meshdir
    for hfield in spec.hfields:
        yield hfield.file, meshdir
    for skin in spec.skins:
        yield skin.file, meshdir
    for texture in spec.textures:
        yield texture.file, texturedir
        for name in texture.cubefiles:
            yield name, texturedir


def _data_bytes(spec: mujoco.MjSpec, files: Iterable[Path]) -> int:
    """Bytes of mesh-like data the compile processes: the files, the in-memory assets
    and meshes given vertex by vertex."""
    total = sum(p.stat().st_size for p in files)
    total += sum(len(v) for v in spec.assets.values())
    total += sum(4 * (len(m.uservert) + len(m.userface)) for m in spec.meshes)
    return total


# ----------------------------------------------------------------------------- compile
def _model_key(spec: mujoco.MjSpec) -> str | None:
    """The cache entry's name for the compile of ``spec``; ``None`` when it is not
    cached (no cache folder, a missing file, too little data, a plugin)."""
    if cache_dir() is None or len(spec.plugins) or len(spec.frames):
        return None
    files = spec_files(spec)
    if files is None or _data_bytes(spec, files) < MIN_CACHED_BYTES:
        return None
    h = hashlib.sha256(f"{_FORMAT!r} mujoco {mujoco.__version__}\0".encode())
    try:
        h.update(spec_digest(spec).encode())
        for f in files:
            h.update(f"\0{file_digest(f)}".encode())
    except OSError:
        return None
    return h.hexdigest() + ".mjb"


def compile_cached(spec: mujoco.MjSpec, path: Path) -> mujoco.MjModel:
    """``spec.compile()``, served from the cache when the same inputs compiled before.

    The model returned is the one ``spec.compile()`` returns (saved and loaded with
    ``mj_saveModel`` / ``mj_loadModel``: every array equal), keyed by
    :func:`spec_digest`, the path and bytes of every file of :func:`spec_files`, and
    the MuJoCo version. A spec with less than :data:`MIN_CACHED_BYTES` of mesh,
    texture and height-field data, or one naming a file that is missing, is compiled
    directly. A compile failure is remembered too (but one opening a file): the same
    inputs raise the same message again without compiling.

    Args:
        spec: the spec to compile (not changed).
        path: the model file the spec was read from (the key is the content alone: the
            spec names its files by path already).

    Returns:
        The compiled model. On a cache hit it is not linked to ``spec``
        (``spec.recompile`` needs a model from ``spec.compile()``).

    Raises:
        ValueError: MuJoCo cannot compile the spec (its message, unchanged).
    """
    key = _model_key(spec)
    if key is None:
        return spec.compile()
    found = _verified(_MODELS, key)
    if found is not None:
        entry, payload = found
        if payload.startswith(_FAILED):
            raise ValueError(payload[len(_FAILED) :].decode(errors="replace"))
        try:  # from the file: MuJoCo loads it faster than from the bytes
            return mujoco.MjModel.from_binary_path(str(entry))
        except ValueError:  # checksum right, model unreadable: compile it again
            pass
    try:
        model = spec.compile()
    except ValueError as exc:
        if not any(word in str(exc).lower() for word in _TRANSIENT):
            write_entry(_MODELS, key, _FAILED + str(exc).encode())
        raise
    buf = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    write_entry(_MODELS, key, buf.tobytes())
    root = cache_dir()
    if root is not None:
        _prune(root, CACHE_LIMIT_BYTES)
    return model
