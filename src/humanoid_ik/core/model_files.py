"""The files of a model and their digest: what MuJoCo may read to compile a model file,
and 16 hex digits of SHA-256 over them (sweep job ids, trajectory files and their
replays name a model by it). A URDF's ``package://`` meshes are found as the loader
finds them (:mod:`humanoid_ik.core.robot_files`)."""

from __future__ import annotations

import hashlib
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path

from humanoid_ik.core.robot_files import PackageIndex, PackagePaths, is_robot_file, robot_source
from humanoid_ik.errors import ModelError

__all__ = ["model_digest", "model_files"]

_COMPILER_DIRS = ("assetdir", "meshdir", "texturedir")
"""``<compiler>`` attributes naming folders that asset files are looked up in."""


def _existing(ref: str, bases: Iterable[Path]) -> list[Path]:
    """``ref`` under each of ``bases`` where that file exists (absolute ``ref`` as is)."""
    out: list[Path] = []
    for b in bases:
        p = (b / ref).resolve()
        if p.is_file() and p not in out:
            out.append(p)
    return out


def model_files(path: str | os.PathLike, *, packages: PackagePaths | None = None) -> list[Path]:
    """The files MuJoCo may read to compile the model file at ``path``.

    For an MJCF file: the file itself, every ``<include>`` (recursively) and every file
    an element names in its ``file`` attribute (meshes, textures, height fields, skins,
    sub-models, recursively). A name is looked up where MuJoCo may take it from: the
    main file's folder, the including file's folder, and the ``<compiler>``
    ``assetdir``, ``meshdir`` and ``texturedir`` under either; every existing match is
    listed (a file listed that MuJoCo does not read only makes a job rerun when it
    changes, never the reverse).

    For a URDF or xacro file: the file, the files a xacro file includes, and every mesh
    and texture it names, found as :func:`~humanoid_ik.core.models.model_spec` finds
    them (``package://`` through ``packages``, ``ROS_PACKAGE_PATH``,
    ``AMENT_PREFIX_PATH`` and the folders above the file); a file not found is left out
    (loading the model says where it was looked for).

    Returns absolute paths, in discovery order.
    """
    found: list[Path] = []
    main = Path(path).resolve()
    if is_robot_file(main):
        _collect_urdf(main, packages, found)
    else:
        _collect(main, found)
    return found


def _collect_urdf(main: Path, packages: PackagePaths | None, found: list[Path]) -> None:
    """Append to ``found`` the files of the URDF or xacro file ``main`` (see
    :func:`model_files`)."""
    found.append(main)
    try:
        index = PackageIndex(main, packages)
        text, includes = robot_source(main, index)
        root = ET.fromstring(text)
    except (ModelError, ET.ParseError):  # loading the model will say why
        return
    found += [p for p in includes if p not in found]
    compiler = root.find("mujoco/compiler")
    for el in root.iter():
        ref = el.get("filename")
        if ref is None or el.tag not in ("mesh", "texture"):
            continue
        folder = "" if compiler is None else compiler.get(f"{el.tag}dir", "")
        p = index.locate(ref, folder)
        if p is not None and p not in found:
            found.append(p)


def _collect(main: Path, found: list[Path]) -> None:
    """Append to ``found`` the files of the model ``main`` not in it yet (see
    :func:`model_files`)."""
    todo, dirs = [main], {""}
    refs: list[tuple[Path, str, bool]] = []  # (file it is in, name, names a sub-model)
    while todo:
        f = todo.pop(0)
        if f in found:
            continue
        found.append(f)
        try:
            root = ET.parse(f).getroot()
        except (OSError, ET.ParseError):  # MuJoCo will say why it does not compile
            continue
        for el in root.iter():
            if el.tag == "compiler":
                dirs.update(v for k in _COMPILER_DIRS if (v := el.get(k)))
            ref = el.get("file") or (el.get("filename") if el.tag == "mesh" else None)
            if ref is None:  # (a URDF mesh names its file in filename)
                continue
            if el.tag == "include":
                todo.extend(_existing(ref, (main.parent, f.parent)))
            else:
                refs.append((f, ref, el.tag == "model"))
    for f, ref, sub_model in refs:
        bases = [b / d for b in dict.fromkeys((main.parent, f.parent)) for d in sorted(dirs)]
        for p in _existing(ref, bases):
            if sub_model:
                _collect(p, found)
            elif p not in found:
                found.append(p)


def model_digest(path: str | os.PathLike, *, packages: PackagePaths | None = None) -> str:
    """16 hex digits of the SHA-256 of every file of :func:`model_files` (each named by its
    path relative to the model's folder, then its bytes), part of a job's id: editing
    the model, a file it includes or an asset it loads (a URDF's ``package://`` mesh
    too, found through ``packages``) changes it; moving the whole tree does not."""
    main = Path(path).resolve()
    h = hashlib.sha256()
    for f in model_files(main, packages=packages):
        try:
            data = f.read_bytes()
        except OSError:
            data = b""
        name = os.path.relpath(f, main.parent)
        h.update(f"{name}\0{len(data)}\0".encode())
        h.update(data)
    return h.hexdigest()[:16]
