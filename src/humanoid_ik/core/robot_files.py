"""Robot files as ROS ships them: ``package://`` paths, ``file://`` URIs and ``.xacro``.

A URDF names its meshes ``package://NAME/rest`` (also ``package:///NAME/rest`` and
``package:/NAME/rest``): ``rest`` under the folder of the ROS package ``NAME``. A
package is found, in this order, through:

1. the explicit package paths ``{NAME: DIR}`` (``--package-path NAME=DIR``, a scene's
   or a sweep's ``package_path`` table);
2. ``ROS_PACKAGE_PATH``: each folder is the package, or holds it (a folder called
   ``NAME``, or a ``package.xml`` whose ``<name>`` is ``NAME``, up to
   :data:`CRAWL_DEPTH` levels down);
3. ``AMENT_PREFIX_PATH``: ``PREFIX/share/NAME``;
4. the folders above the robot file: the first that is the package (called ``NAME``,
   or its ``package.xml`` names ``NAME``), or holds ``NAME`` or ``share/NAME`` (a
   source workspace, an ament or cmeel install).

When several folders qualify, the first that holds the file wins; failing them all,
``rest`` is looked for beside the robot file and one folder up (a package copied
without its ``package.xml``). ``file://`` URIs
are local paths; any other relative name is relative to the robot file's folder (and
``<compiler meshdir>`` / ``texturedir`` when the file sets them).

``.xacro`` files (``robot.urdf.xacro``) are expanded with the ``xacro`` package; its
``$(find NAME)`` uses the same package search.
"""

from __future__ import annotations

import os
import re
import threading
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlparse

from humanoid_ik.errors import ModelError

__all__ = [
    "CRAWL_DEPTH",
    "ModelWarning",
    "PackageIndex",
    "PackagePaths",
    "ROBOT_SUFFIXES",
    "check_packages",
    "is_robot_file",
    "is_xacro",
    "package_item",
    "package_problem",
    "robot_source",
    "robot_text",
]

PackagePaths = Mapping[str, Path]
"""Explicit ROS package folders by package name: ``{"my_robot_description": Path(...)}``."""

ROBOT_SUFFIXES = (".urdf", ".xacro")
"""The suffixes of the files read as URDF (``.urdf.xacro`` ends in ``.xacro``)."""

CRAWL_DEPTH = 3
"""How many folder levels below a ``ROS_PACKAGE_PATH`` entry a package is looked for."""

PACKAGE_OPTION = "--package-path NAME=DIR"
"""How the error for a package not found tells the user to name its folder."""

_PACKAGE_NAME = re.compile(r"^[A-Za-z0-9_.\-]+$")
"""What a ROS package name may be made of (ROS wants ``[a-z0-9_]``; hyphens and
capitals occur in installed packages such as ``example-robot-data``)."""


class ModelWarning(UserWarning):
    """A model file with a mistake that was fixed or let pass while loading (the message
    says what, and how to fix the file); the command line prints it as
    ``humanoid-ik: note: ...``."""


def is_xacro(path: Path) -> bool:
    """Whether ``path`` is a xacro file (``.xacro``, ``.urdf.xacro``)."""
    return path.suffix.lower() == ".xacro"


def is_robot_file(path: Path) -> bool:
    """Whether ``path`` is read as URDF (:data:`ROBOT_SUFFIXES`), not MJCF."""
    return path.suffix.lower() in ROBOT_SUFFIXES


# ------------------------------------------------------------------- package paths
def package_item(text: str) -> tuple[str, Path]:
    """``NAME=DIR`` as ``(NAME, DIR)`` (the folder is not checked here).

    Raises:
        ModelError: not of that form, or ``NAME`` is not a package name.
    """
    name, sep, folder = text.partition("=")
    name, folder = name.strip(), folder.strip()
    if not sep or not folder:
        raise ModelError(f"package path '{text}' is not NAME=DIR (e.g. my_robot=./my_robot)")
    if not _PACKAGE_NAME.match(name):
        raise ModelError(f"package path '{text}': {_bad_name(name)}")
    return name, Path(folder).expanduser()


def _bad_name(name: str) -> str:
    return f"'{name}' is not a package name (letters, digits, '_', '-', '.')"


def package_problem(name: str, folder: Path) -> str | None:
    """What is wrong with the package path ``name`` -> ``folder``, or ``None``: a name
    that is not a package name, or a folder that does not exist."""
    if not _PACKAGE_NAME.match(name):
        return _bad_name(name)
    if not Path(folder).is_dir():
        return f"folder '{folder}' does not exist"
    return None


def check_packages(packages: PackagePaths | None) -> dict[str, Path]:
    """``packages`` checked: each name a package name and each folder an existing folder.

    Returns:
        A new dict ``{NAME: DIR}`` (empty for ``None``).

    Raises:
        ModelError: a bad name, or a folder that does not exist.
    """
    out: dict[str, Path] = {}
    for name, folder in (packages or {}).items():
        problem = package_problem(str(name), Path(folder))
        if problem is not None:
            raise ModelError(f"package path '{name}={folder}': {problem}")
        out[str(name)] = Path(folder)
    return out


def _package_xml_name(folder: Path) -> str | None:
    """The ``<name>`` of ``folder/package.xml``, else ``None``."""
    try:
        root = ET.parse(folder / "package.xml").getroot()
    except (OSError, ET.ParseError):
        return None
    name = root.findtext("name")
    return name.strip() if name else None


def _is_package(folder: Path, name: str) -> bool:
    """``folder`` is the package ``name``: called so, or its ``package.xml`` says so."""
    return folder.is_dir() and (folder.name == name or _package_xml_name(folder) == name)


def _crawl(entry: Path, name: str, depth: int) -> Iterator[Path]:
    """Folders below ``entry`` (at most ``depth`` levels) that are the package ``name``,
    as ROS crawls a ``ROS_PACKAGE_PATH`` entry (hidden folders skipped)."""
    try:
        children = sorted(p for p in entry.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return
    for child in children:
        if _is_package(child, name):
            yield child
        elif depth > 1 and not (child / "package.xml").is_file():  # no packages in packages
            yield from _crawl(child, name, depth - 1)


class PackageIndex:
    """Where the files a robot file names are: its ``package://`` packages, ``file://``
    URIs and relative names, found by the rules of this module.

    Args:
        robot_file: the URDF or xacro file; relative names and the upward search start
            at its folder.
        packages: explicit package folders, looked in first (checked with
            :func:`check_packages`).
        environ: the environment giving ``ROS_PACKAGE_PATH`` and
            ``AMENT_PREFIX_PATH`` (default: ``os.environ``).

    Raises:
        ModelError: a bad package name or a package folder that does not exist.
    """

    def __init__(
        self,
        robot_file: Path,
        packages: PackagePaths | None = None,
        environ: Mapping[str, str] | None = None,
    ):
        self.robot_file = Path(robot_file)
        self.folder = self.robot_file.resolve().parent
        self.packages = check_packages(packages)
        env = os.environ if environ is None else environ
        self.ros_path = [Path(p) for p in env.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        self.ament = [Path(p) for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
        self._roots: dict[str, list[Path]] = {}

    def roots(self, name: str) -> list[Path]:
        """Every folder that is the package ``name``, in the order of the rules (the
        same folder once)."""
        if name not in self._roots:
            found: list[Path] = []
            if name in self.packages:
                found.append(self.packages[name])
            for entry in self.ros_path:
                if _is_package(entry, name):
                    found.append(entry)
                else:
                    found.extend(_crawl(entry, name, CRAWL_DEPTH))
            found += [p / "share" / name for p in self.ament if (p / "share" / name).is_dir()]
            for folder in (self.folder, *self.folder.parents):
                if _is_package(folder, name):
                    found.append(folder)
                found += [c for c in (folder / name, folder / "share" / name) if c.is_dir()]
            self._roots[name] = list(dict.fromkeys(p.resolve() for p in found))
        return self._roots[name]

    def _places(self, name: str) -> str:
        """Where the package ``name`` was looked for, for an error message."""
        explicit = f"{name}={self.packages[name]}" if name in self.packages else "none"
        ros = os.pathsep.join(map(str, self.ros_path)) or "unset"
        ament = os.pathsep.join(map(str, self.ament)) or "unset"
        roots = ", ".join(map(str, self.roots(name))) or "none found"
        return (
            f"package '{name}' looked for in the package paths ({explicit}), "
            f"ROS_PACKAGE_PATH ({ros}), AMENT_PREFIX_PATH ({ament}) and the folders above "
            f"{self.folder} (a folder named {name} or whose package.xml names it, or "
            f"holding {name} or share/{name}); package folders: {roots}"
        )

    def find(self, name: str) -> Path:
        """The folder of the package ``name`` (``$(find NAME)`` in xacro).

        Raises:
            ModelError: no folder is the package.
        """
        roots = self.roots(name)
        if not roots:
            raise ModelError(
                f"{self.robot_file}: {self._places(name)}; give its folder with "
                f"{PACKAGE_OPTION.replace('NAME', name)}"
            )
        return roots[0]

    def candidates(self, uri: str, base: str = "") -> tuple[list[Path], str | None]:
        """The files ``uri`` may name, in the order they are tried, and the package it
        names (``None`` for a ``file://`` URI or a path).

        Args:
            uri: a ``package://``, ``file://`` URI or a path.
            base: the ``<compiler meshdir>`` / ``texturedir`` a relative path is under
                (relative to the robot file's folder unless absolute).
        """
        if uri.startswith("package:"):
            rest = uri[len("package:") :].lstrip("/")
            name, _, inside = rest.partition("/")
            beside = [self.folder / inside, self.folder.parent / inside]
            return list(dict.fromkeys([r / inside for r in self.roots(name)] + beside)), name
        if uri.startswith("file:"):
            return [Path(unquote(urlparse(uri).path))], None
        path = Path(uri).expanduser()
        if path.is_absolute():
            return [path], None
        return [self.folder / base / path], None

    def locate(self, uri: str, base: str = "") -> Path | None:
        """The file ``uri`` names (absolute), or ``None`` when it is nowhere."""
        found = next((p for p in self.candidates(uri, base)[0] if p.is_file()), None)
        return None if found is None else found.resolve()

    def resolve(self, uri: str, base: str = "", what: str = "mesh") -> Path:
        """The file ``uri`` names (absolute).

        Args:
            uri, base: as :meth:`candidates`.
            what: what the file is, for the message (``mesh``, ``texture``).

        Raises:
            ModelError: the file is nowhere; the message names the URI, every place
                looked in and the ``--package-path`` option.
        """
        found = self.locate(uri, base)
        if found is not None:
            return found
        tried, package = self.candidates(uri, base)
        head = f"model '{self.robot_file}': {what} '{uri}' not found"
        if package is None:
            raise ModelError(f"{head} (looked for {', '.join(map(str, tried))})")
        files = f"; no {', '.join(map(str, tried))}" if tried else ""
        raise ModelError(
            f"{head}: {self._places(package)}{files}; give the package's folder with "
            f"{PACKAGE_OPTION.replace('NAME', package)}"
        )


# ------------------------------------------------------------------- text and xacro
_XACRO_LOCK = threading.Lock()
"""xacro keeps its state in module globals: one expansion at a time."""
_FIND = re.compile(r"\$\(find\s+([^)\s]+)\s*\)")
"""xacro's ``$(find NAME)``: the folder of the package ``NAME``."""


def _expand_xacro(path: Path, index: PackageIndex) -> tuple[str, list[Path]]:
    """The URDF text of the xacro file ``path`` and the files it included.

    ``$(find NAME)`` is answered by ``index``, and so is an include's
    ``package://``/``file://`` name; xacro's warnings become one
    :class:`ModelWarning` each.

    Raises:
        ModelError: xacro fails (a missing include, an undefined property...).
    """
    import xacro
    import xacro.substitution_args as subst

    plain_resolve, plain_include = subst.resolve_args, xacro.abs_filename_spec

    def resolve(text: str | None, context: Any = None, filename: Any = None) -> Any:
        if text:
            text = _FIND.sub(lambda m: str(index.find(m.group(1))), text)
        return plain_resolve(text, context, filename)

    def include(spec: str) -> str:
        if spec.startswith(("package:", "file:")):
            return str(index.resolve(spec, what="xacro include"))
        return str(plain_include(spec))

    said: list[str] = []
    with _XACRO_LOCK:
        saved = xacro.warning, xacro.print_location
        subst.resolve_args, xacro.abs_filename_spec = resolve, include
        xacro.warning = lambda *args, **kw: said.append(" ".join(map(str, args)))
        xacro.print_location = lambda: None
        xacro.all_includes = []
        try:
            doc = xacro.process_file(str(path))
            text = doc.toxml()
            includes = [Path(p).resolve() for p in dict.fromkeys(xacro.all_includes)]
        except ModelError:
            raise
        except Exception as exc:  # xacro raises several types, none of them ours
            msg = " ".join(str(exc).split()) or type(exc).__name__
            raise ModelError(f"xacro file '{path}' does not expand: {msg}") from None
        finally:
            subst.resolve_args, xacro.abs_filename_spec = plain_resolve, plain_include
            xacro.warning, xacro.print_location = saved
    for line in dict.fromkeys(said):
        warnings.warn(f"xacro file '{path}': {' '.join(line.split())}", ModelWarning, 3)
    return text, includes


def robot_source(path: Path, index: PackageIndex) -> tuple[str, list[Path]]:
    """The URDF text MuJoCo parses for ``path``, and the files a xacro file included
    (absolute; ``[]`` for a plain URDF).

    A xacro file is expanded, and ``<mujoco><compiler discardvisual="false"/></mujoco>``
    is added (or the attribute set on the file's own ``<compiler>``, unless it sets
    ``discardvisual`` itself), so MuJoCo keeps the visual geoms next to the collision
    ones.

    Raises:
        ModelError: the file cannot be read, is not XML, or xacro fails.
    """
    includes: list[Path] = []
    try:
        if is_xacro(path):
            text, includes = _expand_xacro(path, index)
        else:
            text = path.read_text()
    except OSError as exc:
        raise ModelError(f"model file '{path}' cannot be read: {exc.strerror}") from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(f"model '{path}' is not XML: {exc}") from None
    if root.tag != "robot":  # MuJoCo will say what it expected
        return text, includes
    extension = root.find("mujoco")
    if extension is None:
        extension = ET.Element("mujoco")
        root.insert(0, extension)
    compiler = extension.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(extension, "compiler")
    if compiler.get("discardvisual") is None:
        compiler.set("discardvisual", "false")
    return ET.tostring(root, encoding="unicode"), includes


def robot_text(path: Path, index: PackageIndex) -> str:
    """The URDF text of :func:`robot_source`.

    Raises:
        ModelError: as :func:`robot_source`.
    """
    return robot_source(path, index)[0]
