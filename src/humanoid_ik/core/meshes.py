"""Meshes as MuJoCo needs them: formats it cannot read converted, heavy visuals decimated.

MuJoCo reads ``.stl``, ``.obj`` and ``.msh`` mesh files; a robot from ROS often names
Collada (``.dae``), glTF (``.gltf``, ``.glb``) or ``.ply`` meshes. :func:`convert_meshes`
reads those with ``trimesh`` (``pycollada`` for Collada) and hands MuJoCo the triangles
as an in-memory binary STL (``spec.assets``), no temporary file. The file's own frame
is kept as ROS tools see it:

- the Collada ``<unit meter=...>`` scales the vertices to metres;
- the Collada ``<up_axis>`` (``Y_UP``, ``X_UP``) is turned to ``Z_UP``, except in a file
  written by MeshLab (``<authoring_tool>`` VCGLib / MeshLab), which writes ``Y_UP``
  whatever the data: its vertices are taken as they are. glTF is Y-up by definition
  and turned the same way;
- the URDF's ``<mesh scale>`` is not applied here: it is the mesh's ``scale``, which
  MuJoCo applies.

Colours come along: a file whose triangles have several material colours gives one mesh
per colour, each drawn by its own geom (same body, pose, group and contact bits as the
geom that named the file), coloured by the material when that geom has no ``rgba`` or
material of its own; a one-colour file just colours such a geom. A mesh that a
colliding geom uses stays one mesh, so its convex hull is the file's.

Heavy visual meshes are decimated: when the drawn (non-colliding) geoms of a model
would draw more than :func:`visual_face_budget` triangles, each of their meshes is
drawn from a copy reduced in proportion (vertex clustering), which keeps a software
renderer's frame rate near that of a model of primitives. Colliding geoms keep the full
mesh, and so its convex hull.

Converted and decimated meshes are cached by the SHA-256 of the source file and the
converter's version (``core/model_cache.py``): the next load reads them back.
"""

from __future__ import annotations

import hashlib
import io
import os
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.core.model_cache import MESHES, file_digest, read_entry, write_entry
from humanoid_ik.errors import ModelError

__all__ = [
    "CONVERTED_SUFFIXES",
    "MIN_DECIMATED_FACES",
    "VISUAL_FACES",
    "VISUAL_FACES_ENV",
    "MeshPart",
    "convert_meshes",
    "decimate",
    "read_mesh",
    "visual_face_budget",
]

CONVERTED_SUFFIXES = (".dae", ".gltf", ".glb", ".ply")
"""Mesh file suffixes (any case) MuJoCo 4.0 has no decoder for, converted here (it
reads ``.stl``, ``.obj`` and ``.msh`` itself)."""
VISUAL_FACES = 40_000
"""Triangles the drawn geoms of a model may draw before their meshes are decimated:
about what a software renderer (Mesa llvmpipe) draws at 0.8x the frame rate of the
bundled humanoid (``benchmarks/robot_files.py``)."""
VISUAL_FACES_ENV = "HUMANOID_IK_VISUAL_FACES"
"""The environment variable overriding :data:`VISUAL_FACES` (``0``: never decimate)."""
MIN_DECIMATED_FACES = 300
"""Fewest triangles a mesh is decimated to, however heavy the model."""

_VERSION = "meshes 1"
"""Part of every cache key: a change to the conversion or the decimation changes it."""
_KIND = MESHES
_UP_TO_Z = {
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "X_UP": np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
    "Z_UP": np.eye(3),
}
"""Rotation taking a Collada up axis to Z up, applied as ``R @ p``: ``Y_UP`` maps
``(x, y, z)`` to ``(x, -z, y)``; ``X_UP`` (right is -Y) to ``(-y, -z, x)``."""
_MESHLAB = ("meshlab", "vcglib")
_MESH = mujoco.mjtGeom.mjGEOM_MESH
_COPIED = tuple(
    "pos quat group contype conaffinity condim priority friction solmix"
    " solref solimp margin gap density mass typeinertia material rgba".split()
)
"""The geom attributes a geom drawing another part of the same file copies."""
_MESH_COPIED = ("scale", "refpos", "refquat", "inertia", "maxhullvert", "smoothnormal")


@dataclass(frozen=True)
class MeshPart:
    """The triangles of one colour of a mesh file, in the file's frame [m], Z up.

    Attributes:
        vertices: ``(n, 3)`` float32 vertex positions [m].
        faces: ``(m, 3)`` int32 vertex indices of each triangle.
        rgba: ``(4,)`` colour in [0, 1] of the material, ``None`` when the file has none.
    """

    vertices: NDArray[np.float32]
    faces: NDArray[np.int32]
    rgba: NDArray[np.float64] | None


# ----------------------------------------------------------------------------- reading
def read_mesh(path: str | os.PathLike) -> list[MeshPart]:
    """The triangles of the mesh file at ``path`` by colour (one part for a file without
    colours), unit and up axis applied (module docstring); cached by the file's bytes.

    Raises:
        ModelError: the file cannot be read, or holds no triangles.
    """
    path = Path(path)
    try:
        source = file_digest(path)
    except OSError as exc:
        raise ModelError(f"mesh file '{path}' cannot be read: {exc.strerror or exc}") from exc
    key = _key("read", source, path.suffix.lower())
    parts = _load_parts(read_entry(_KIND, key))
    if parts is None:
        parts = _convert(path)
        write_entry(_KIND, key, _dump_parts(parts))
    return parts


def _convert(path: Path) -> list[MeshPart]:
    """Read ``path`` with trimesh: every triangle of the scene in the file's frame,
    grouped by material colour, unit and up axis applied.

    Raises:
        ModelError: trimesh cannot read it, or it holds no triangles.
    """
    import trimesh  # heavy; only needed for a file MuJoCo cannot read

    suffix = path.suffix.lower()
    try:
        scene: Any = trimesh.load(str(path), force="scene", process=False)
        turn, unit = _frame(path, suffix)
        groups: dict[tuple[float, ...] | None, list[tuple[NDArray, NDArray]]] = {}
        for node in scene.graph.nodes_geometry:
            transform, name = scene.graph[node]
            geom = scene.geometry[name]
            faces = np.asarray(getattr(geom, "faces", ()), dtype=np.int64).reshape(-1, 3)
            if not len(faces):
                continue  # points or lines
            v = np.asarray(geom.vertices, dtype=np.float64)
            v = v @ transform[:3, :3].T + transform[:3, 3]
            colour = _colour(geom)
            groups.setdefault(colour, []).append((v, faces))
    except ModelError:
        raise
    except Exception as exc:  # trimesh and pycollada raise many types
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise ModelError(f"mesh file '{path}' cannot be converted: {msg}") from exc
    parts = []
    for colour, pieces in groups.items():
        v, f = _concatenate(pieces)
        v = (v @ turn.T) * unit
        rgba = None if colour is None else np.array(colour, dtype=np.float64)
        part = _clean(v, f, rgba)
        if part is not None:
            parts.append(part)
    if not parts:
        raise ModelError(f"mesh file '{path}' cannot be converted: it holds no triangles")
    return parts


def _frame(path: Path, suffix: str) -> tuple[NDArray[np.float64], float]:
    """``(rotation to Z up, metres per file unit)`` of a mesh file."""
    if suffix in (".gltf", ".glb"):
        return _UP_TO_Z["Y_UP"], 1.0
    if suffix != ".dae":
        return _UP_TO_Z["Z_UP"], 1.0
    up, unit, tool = "Y_UP", 1.0, ""  # Collada's defaults
    for _, el in ET.iterparse(str(path), events=("end",)):
        tag = el.tag.rsplit("}", 1)[-1]
        if tag == "up_axis" and el.text:
            up = el.text.strip().upper()
        elif tag == "unit":
            unit = float(el.get("meter", "1") or 1.0)
        elif tag == "authoring_tool" and el.text:
            tool = el.text.lower()
        elif tag == "asset":
            break
    if any(name in tool for name in _MESHLAB):
        up = "Z_UP"  # MeshLab writes Y_UP without turning its data
    return _UP_TO_Z.get(up, _UP_TO_Z["Z_UP"]), unit


def _colour(geom: object) -> tuple[float, ...] | None:
    """The material colour of a trimesh mesh in [0, 1] (rounded to 1/255), ``None``
    when it has none."""
    visual = getattr(geom, "visual", None)
    if visual is None or not getattr(visual, "defined", False):
        return None
    material = getattr(visual, "material", None)
    main = getattr(material, "main_color", None) if material is not None else None
    if main is None:
        main = getattr(visual, "main_color", None)
    if main is None:
        return None
    return tuple(round(float(c) / 255.0, 4) for c in np.asarray(main).ravel()[:4])


def _concatenate(pieces: Sequence[tuple[NDArray, NDArray]]) -> tuple[NDArray, NDArray]:
    """One vertex and face array from ``(vertices, faces)`` pieces."""
    offsets = np.cumsum([0] + [len(v) for v, _ in pieces[:-1]])
    v = np.concatenate([v for v, _ in pieces])
    f = np.concatenate([f + o for (_, f), o in zip(pieces, offsets, strict=True)])
    return v, f


def _clean(v: NDArray, f: NDArray, rgba: NDArray | None) -> MeshPart | None:
    """A part without degenerate triangles and unused vertices; ``None`` when nothing
    with an area is left (MuJoCo wants at least 4 vertices)."""
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    used, f = np.unique(f, return_inverse=True)
    f = f.reshape(-1, 3)
    v = v[used]
    if len(v) < 4 or not len(f):
        return None
    return MeshPart(v.astype(np.float32), f.astype(np.int32), rgba)


# ----------------------------------------------------------------------------- cache
def _key(*parts: object) -> str:
    return hashlib.sha256("\0".join(map(str, (_VERSION, *parts))).encode()).hexdigest() + ".npz"


def _dump_parts(parts: Sequence[MeshPart]) -> bytes:
    arrays: dict[str, Any] = {}
    for i, p in enumerate(parts):
        arrays[f"v{i}"], arrays[f"f{i}"] = p.vertices, p.faces
        arrays[f"c{i}"] = np.full(4, np.nan) if p.rgba is None else p.rgba
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _load_parts(payload: bytes | None) -> list[MeshPart] | None:
    """The parts of a cache entry; ``None`` when there is none or it does not read."""
    if payload is None:
        return None
    try:
        with np.load(io.BytesIO(payload)) as z:
            parts = []
            for i in range(len(z.files) // 3):
                c = z[f"c{i}"]
                v, f = z[f"v{i}"], z[f"f{i}"]
                if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
                    return None
                parts.append(MeshPart(v, f, None if np.isnan(c).any() else c))
    except (OSError, ValueError, KeyError, EOFError):
        return None
    return parts or None


# ----------------------------------------------------------------------------- decimation
def visual_face_budget() -> int:
    """Triangles the drawn geoms of a model may draw: ``$HUMANOID_IK_VISUAL_FACES``,
    else :data:`VISUAL_FACES`; ``0`` never decimates.

    Raises:
        ModelError: the variable is not a whole number >= 0.
    """
    text = os.environ.get(VISUAL_FACES_ENV, "").strip()
    if not text:
        return VISUAL_FACES
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise ModelError(
            f"{VISUAL_FACES_ENV}={text!r} is not a face count; valid: a whole number >= 0 "
            "(0: never decimate)"
        )
    return value


def decimate(
    vertices: NDArray, faces: NDArray, target: int
) -> tuple[NDArray[np.float32], NDArray[np.int32]]:
    """The mesh ``(vertices (n, 3), faces (m, 3))`` reduced to at most about ``target``
    triangles by vertex clustering: vertices in one cell of a grid merge into their
    mean, collapsed and repeated triangles go; the cell size is searched (from the
    grid that would give ``target`` triangles on the surface's area, then on the
    triangles ~ cell^-2 law within a bracket) for 90-100% of ``target`` triangles. A
    mesh already small enough, or one that would lose all its triangles, is returned as
    it is."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) <= target or len(v) < 4:
        return v.astype(np.float32), f.astype(np.int32)
    lo = v.min(axis=0)
    size = float(np.max(v.max(axis=0) - lo)) or 1.0
    area = 0.5 * float(
        np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    )
    cell = float(np.sqrt(2.0 * area / target)) or size / 100  # a grid's 2 triangles per cell
    fine, coarse = 0.0, np.inf  # faces(fine) > target >= faces(coarse)
    best = None
    for _ in range(30):
        labels, count, kept = _cluster(v, f, lo, cell)
        if len(kept) > target:
            fine = cell
        else:
            coarse, best = cell, (labels, count, kept)
            if len(kept) >= 0.9 * target:
                break
        if coarse / max(fine, 1e-12) < 1.01:
            break
        guess = cell * float(np.sqrt(max(len(kept), 1) / (0.95 * target)))  # faces ~ cell^-2
        if not fine < guess < coarse:
            guess = float(np.sqrt(fine * coarse)) if np.isfinite(coarse) and fine else guess
        cell = min(max(guess, size * 1e-6), size * 2)
    if best is None or len(best[2]) == 0:
        return v.astype(np.float32), f.astype(np.int32)
    labels, count, kept = best
    n = np.bincount(labels, minlength=count).astype(np.float64)
    sums = [np.bincount(labels, v[:, k], minlength=count) for k in range(3)]
    merged = np.stack(sums, axis=1).astype(np.float64) / n[:, None]
    used, kept = np.unique(kept, return_inverse=True)
    return merged[used].astype(np.float32), kept.reshape(-1, 3).astype(np.int32)


def _cluster(
    v: NDArray, f: NDArray, lo: NDArray, cell: float
) -> tuple[NDArray[np.int64], int, NDArray[np.int64]]:
    """``(cluster of each vertex, number of clusters, triangles between three distinct
    clusters, each once)`` for a grid of cell size ``cell`` [m] from ``lo``."""
    q = np.floor((v - lo) / cell).astype(np.int64)
    dims = q.max(axis=0) + 1
    cells = (q[:, 0] * dims[1] + q[:, 1]) * dims[2] + q[:, 2]
    uniq, labels = np.unique(cells, return_inverse=True)
    labels = labels.ravel()
    tri = labels[f]
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
    n = len(uniq)
    s = np.sort(tri, axis=1)
    _, first = np.unique((s[:, 0] * n + s[:, 1]) * n + s[:, 2], return_index=True)
    return labels, n, tri[np.sort(first)]


def _decimated(part: MeshPart, source: str, index: int, target: int) -> MeshPart:
    """``part`` (number ``index`` of the file with digest ``source``) decimated to
    ``target`` triangles; cached."""
    if len(part.faces) <= target:
        return part
    key = _key("decimate", source, index, target)
    cached = _load_parts(read_entry(_KIND, key))
    if cached is not None:
        return MeshPart(cached[0].vertices, cached[0].faces, part.rgba)
    v, f = decimate(part.vertices, part.faces, target)
    out = MeshPart(v, f, part.rgba)
    write_entry(_KIND, key, _dump_parts([out]))
    return out


def _stl_faces(path: Path) -> int | None:
    """Triangles of a binary STL file by its header; ``None`` for another file."""
    if path.suffix.lower() != ".stl":
        return None
    try:
        with open(path, "rb") as f:
            head = f.read(84)
        n = int.from_bytes(head[80:84], "little") if len(head) == 84 else -1
        return n if n >= 0 and path.stat().st_size == 84 + 50 * n else None
    except OSError:
        return None


# ----------------------------------------------------------------------------- the spec
@dataclass
class _Plan:
    """One mesh of the spec to convert or decimate, and the geoms that use it."""

    mesh: mujoco.MjsMesh
    path: Path
    convert: bool
    colliding: list[mujoco.MjsGeom]
    drawn: list[mujoco.MjsGeom]
    faces: int = 0
    parts: list[MeshPart] | None = None
    """The file's parts, once read."""

    def read(self) -> list[MeshPart]:
        if self.parts is None:
            self.parts = read_mesh(self.path)
        return self.parts

    def count(self) -> int:
        """The file's triangles (a binary STL's by its header, without reading it)."""
        n = _stl_faces(self.path)
        return sum(len(p.faces) for p in self.read()) if n is None else n


def convert_meshes(spec: mujoco.MjSpec) -> None:
    """Replace every mesh of ``spec`` in a format MuJoCo cannot read
    (:data:`CONVERTED_SUFFIXES`) by its triangles, and draw heavy visual meshes from
    decimated copies (module docstring); ``spec`` is edited in place.

    Each mesh's data goes to ``spec.assets`` as a binary STL named after the mesh and
    its content (``mesh.file`` names it). A drawn geom (one that collides with nothing:
    ``contype`` and ``conaffinity`` 0) without a colour of its own draws a file of
    several colours as one mesh and one geom per colour (the geom draws the first, new
    geoms ``NAME_1``, ``NAME_2``... the others); a colliding geom draws the whole file.
    The mesh keeps its name for the first data it holds; further meshes made from it
    are ``NAME_1``, ``NAME_2``... A mesh only massless geoms use gets
    ``inertia="shell"`` (an open or flat visual part then compiles).

    Args:
        spec: a spec whose mesh files are absolute paths (a relative one is looked up
            under the spec's folder and ``meshdir``); edited in place.

    Raises:
        ModelError: a mesh file cannot be read or converted (the file and why, in one
            line), or :data:`VISUAL_FACES_ENV` is not a face count.
    """
    budget = visual_face_budget()
    uses: dict[str, list[mujoco.MjsGeom]] = {}
    for geom in spec.geoms:
        if geom.type == _MESH and geom.meshname:
            uses.setdefault(geom.meshname, []).append(geom)
    plans = []
    for mesh in list(spec.meshes):
        path = _mesh_path(spec, mesh)
        if path is None:
            continue
        geoms = uses.get(mesh.name, [])
        drawn = [g for g in geoms if g.contype == 0 and g.conaffinity == 0]
        colliding = [g for g in geoms if not (g.contype == 0 and g.conaffinity == 0)]
        convert = path.suffix.lower() in CONVERTED_SUFFIXES
        if convert or (drawn and budget):
            plans.append(_Plan(mesh, path, convert, colliding, drawn))
    drawn_faces = 0
    for plan in plans:
        if plan.drawn and budget:
            plan.faces = plan.count()
            drawn_faces += plan.faces * len(plan.drawn)
    share = budget / drawn_faces if budget and drawn_faces > budget else None
    for plan in plans:
        target = None
        if share is not None and plan.drawn:
            target = max(MIN_DECIMATED_FACES, int(plan.faces * share))
            if target >= plan.faces:
                target = None
        if plan.convert or target is not None:
            _apply(spec, plan, target)


def _mesh_path(spec: mujoco.MjSpec, mesh: mujoco.MjsMesh) -> Path | None:
    """The file a mesh names, as MuJoCo finds it; ``None`` for a mesh without a file,
    one served from ``spec.assets`` or one not found (the compile says so)."""
    if not mesh.file or mesh.file in spec.assets:
        return None
    path = Path(mesh.file)
    if not path.is_absolute():
        meshdir = spec.compiler.meshdir or spec.meshdir or ""
        path = Path(spec.modelfiledir or ".") / meshdir / path
    return path if path.is_file() else None


def _apply(spec: mujoco.MjSpec, plan: _Plan, target: int | None) -> None:
    """Give the geoms of ``plan`` their meshes: the full data for colliding geoms, for
    drawn ones the data decimated to ``target`` triangles (``None``: not decimated),
    split by colour when the file has several and the geom no colour of its own."""
    parts = plan.read()
    source = file_digest(plan.path)
    if not plan.convert:
        parts = [_merged(parts)]
    whole = _merged(parts) if len(parts) > 1 else parts[0]
    claimed: list[bool] = [False]
    made: dict[object, str] = {}

    def mesh_for(variant: object, part: MeshPart, massless: bool) -> str:
        """The name of the spec mesh holding ``part`` (made on first use)."""
        if variant in made:
            return made[variant]
        if not plan.convert and variant == "full":
            made[variant] = plan.mesh.name  # the file MuJoCo reads, as it was
            claimed[0] = True
            return plan.mesh.name
        if not claimed[0]:
            mesh, claimed[0] = plan.mesh, True
        else:
            mesh = spec.add_mesh(name=_free_name(spec, plan.mesh.name))
            for attr in _MESH_COPIED:
                setattr(mesh, attr, getattr(plan.mesh, attr))
        name = f"{plan.mesh.name}-{_key(variant, source, len(part.faces))[:16]}.stl"
        spec.assets[name] = _stl(part)
        mesh.file = name
        if massless:
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        made[variant] = mesh.name
        return mesh.name

    if plan.colliding:
        name = mesh_for("full", whole, False)
        for geom in plan.colliding:
            geom.meshname = name
    default_rgba = np.asarray(spec.default.geom.rgba)
    for geom in plan.drawn:
        own = bool(geom.material) or not np.allclose(geom.rgba, default_rgba)
        massless = _massless(spec, geom)
        if len(parts) > 1 and not own:
            body = geom.parent
            for i, part in enumerate(parts):
                shown = part if target is None else _share(part, i, source, target, whole)
                name = mesh_for(("part", i, massless), shown, massless)
                g = geom if i == 0 else _sibling(body, geom, i)
                g.meshname = name
                if part.rgba is not None:
                    g.rgba = part.rgba
            continue
        if target is None and (plan.colliding or not plan.convert):
            variant: object = "full"
        else:
            variant = ("whole", massless)
        shown = whole if target is None else _decimated(whole, source, -1, target)
        geom.meshname = mesh_for(variant, shown, massless and variant != "full")
        if not own and len(parts) == 1 and parts[0].rgba is not None:
            geom.rgba = parts[0].rgba


def _free_name(spec: mujoco.MjSpec, base: str) -> str:
    """``base_1``, ``base_2``...: the first that no mesh of ``spec`` has."""
    taken = {m.name for m in spec.meshes}
    i = 1
    while f"{base}_{i}" in taken:
        i += 1
    return f"{base}_{i}"


def _share(part: MeshPart, index: int, source: str, target: int, whole: MeshPart) -> MeshPart:
    """Part ``index`` decimated to its share of ``target`` (by its triangles)."""
    n = max(MIN_DECIMATED_FACES, int(target * len(part.faces) / len(whole.faces)))
    return _decimated(part, source, index, n)


def _merged(parts: Sequence[MeshPart]) -> MeshPart:
    """All ``parts`` as one part without colour."""
    if len(parts) == 1:
        return MeshPart(parts[0].vertices, parts[0].faces, None)
    v, f = _concatenate([(p.vertices, p.faces) for p in parts])
    return MeshPart(v, f.astype(np.int32), None)


def _massless(spec: mujoco.MjSpec, geom: mujoco.MjsGeom) -> bool:
    """Whether ``geom`` gives its body no mass: density 0 and no explicit mass, or a
    group outside the compiler's ``inertiagrouprange``."""
    lo, hi = spec.compiler.inertiagrouprange
    return (geom.density == 0 and geom.mass <= 0) or not lo <= geom.group <= hi


def _sibling(body: mujoco.MjsBody, geom: mujoco.MjsGeom, index: int) -> mujoco.MjsGeom:
    """A geom of ``body`` with the pose, group, contact bits and material of ``geom``
    (named ``NAME_index`` when ``geom`` has a name)."""
    new = body.add_geom()
    new.type = _MESH
    for attr in _COPIED:
        setattr(new, attr, getattr(geom, attr))
    for attr in ("type", "axisangle", "euler", "xyaxes", "zaxis"):  # an orientation
        setattr(new.alt, attr, getattr(geom.alt, attr))  # not given as a quaternion
    if geom.name:
        new.name = f"{geom.name}_{index}"
    return new


def _stl(part: MeshPart) -> bytes:
    """``part`` as a binary STL (normals left 0: MuJoCo computes its own)."""
    tri = part.vertices[part.faces]
    rec = np.zeros(len(tri), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = tri
    return bytes(80) + len(tri).to_bytes(4, "little") + rec.tobytes()
