"""Build hooks: the bundled folders and ``lm``'s compiled kernel. Everything else is
declared in ``pyproject.toml``.

Bundled folders: the repository's top-level ``models/``, ``scenes/`` and ``sweeps/``
folders are copied into the package as ``humanoid_ik/_bundled/<folder>/`` when a wheel is
built (from the checkout or from the sdist, which carries them through ``MANIFEST.in``),
so an installed package reads them with ``importlib.resources`` (``core/models.py``). An
editable install reads the checkout's folders themselves.

The ``lm`` kernel: the iteration loop of the ``lm`` solver, the only one, is the CPython
extension module ``humanoid_ik.solvers.jacobian._lm_kernel``, compiled from
``src/humanoid_ik/solvers/jacobian/_lm_kernel.c`` against the MuJoCo that the ``mujoco``
wheel ships: its headers (``<mujoco/mujoco.h>`` from ``mujoco/include``) and its
library (``libmujoco.so.<version>`` in the ``mujoco`` package folder; ``mujoco>=4.0,<5``
is a build requirement in ``pyproject.toml``, so both are there at build time). The
extension is required, so the wheel is a platform wheel: a build without a working C
compiler (or without Python's headers) stops with one line saying what to install, and
there is no fallback loop.

Finding ``libmujoco`` at run time (Linux and macOS):

- The library is linked by its file, so the extension records its SONAME
  (``libmujoco.so.4.0.0``): it runs only with the MuJoCo release it was built against
  (the module also compares ``mj_version()`` with the headers' version when imported).
- ``lm.py`` imports ``mujoco`` before the kernel, so the ``mujoco`` package has
  already loaded that library and the dynamic loader reuses it (a loaded library
  satisfies a dependency on its SONAME): this is what makes every layout work,
  including an editable install built in an isolated build environment that no longer
  exists.
- For a direct import of the module the rpath names the library's folder too: in an
  installed wheel the extension sits in ``site-packages/humanoid_ik/solvers/jacobian/``
  and MuJoCo in ``site-packages/mujoco/``, so ``$ORIGIN/../../../mujoco``
  (``@loader_path/...`` on macOS); an editable install (the extension in
  ``src/humanoid_ik/solvers/jacobian/``) built without build isolation adds the
  absolute folder of the environment's MuJoCo (``pip install --no-build-isolation -e
  .``); built in pip's temporary build environment it relies on the import above.

The ``subproblem`` module: the exact IK of 6-hinge arms by Paden-Kahan subproblems,
``humanoid_ik.solvers.analytic.subproblem._subproblem``, compiled in the same build from
``src/humanoid_ik/solvers/analytic/subproblem/``: ``_subproblem.c`` (the binding),
``families.c`` and ``subproblems.c`` (the arithmetic, ``subproblems.h``). It needs only
Python's headers and doubles: no MuJoCo headers, library or rpath.

GCC and Clang compile both with ``-O3 -ffp-contract=off`` (no fused multiply-add: the
same rounding on every machine); other compilers (MSVC) keep their own flags.
"""

from __future__ import annotations

import importlib.util
import shutil
import site
import sys
import tempfile
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py
from setuptools.errors import CCompilerError, ExecError, PlatformError

BUNDLED = ("models", "scenes", "sweeps", "motions")
"""Top-level folders shipped inside the package, under ``humanoid_ik/_bundled/``."""

NO_COMPILER = (
    "humanoid_ik: building the lm kernel needs a C compiler and Python's headers "
    "(on Debian/Ubuntu: apt-get install gcc libc6-dev python3-dev; see docs/lm.md)"
)
"""The one line a build without a working C compiler stops with."""


class BuildPyWithBundled(build_py):
    """``build_py`` that also copies the bundled folders into the built package."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return  # an editable install reads the checkout's folders
        root = Path(__file__).resolve().parent
        dest = Path(self.build_lib) / "humanoid_ik" / "_bundled"
        for name in BUNDLED:
            src = root / name
            if not src.is_dir():
                raise SystemExit(f"setup.py: bundled folder '{name}/' is missing")
            target = dest / name
            if target.exists():
                shutil.rmtree(target)
            shutil.copytree(src, target, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))


def mujoco_dir() -> Path:
    """The ``mujoco`` package folder of the build environment (found without importing
    it), checked for the headers and the library the kernel is built on."""
    spec = importlib.util.find_spec("mujoco")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit(
            "humanoid_ik: building the lm kernel needs the mujoco package (pip install "
            "'mujoco>=4.0,<5'), a build requirement in pyproject.toml"
        )
    for folder in spec.submodule_search_locations:
        path = Path(folder)
        if (path / "include" / "mujoco" / "mujoco.h").is_file() and mujoco_library(path):
            return path
    raise SystemExit(
        f"humanoid_ik: the mujoco package in {list(spec.submodule_search_locations)} has "
        "no include/mujoco/mujoco.h or no MuJoCo library to build the lm kernel against"
    )


def mujoco_library(folder: Path) -> Path | None:
    """MuJoCo's shared library (its import library on Windows) in the package folder."""
    patterns = {"win32": ("mujoco.lib",), "darwin": ("libmujoco*.dylib",)}
    for pattern in patterns.get(sys.platform, ("libmujoco.so*",)):
        found = sorted(folder.glob(pattern))
        if found:
            return found[0]
    return None


def lasting(folder: Path) -> bool:
    """Whether ``folder`` is in the building interpreter's own site-packages (a build
    without isolation), not in a temporary build environment that pip removes."""
    sites = [Path(p).resolve() for p in site.getsitepackages()]
    return any(folder.resolve().is_relative_to(p) for p in sites)


class BuildKernel(build_ext):
    """``build_ext`` that points the kernel at MuJoCo's headers and library, sets the
    rpath and the determinism flags, and turns a missing compiler into one line."""

    def build_extension(self, ext: Extension) -> None:
        if ext.name == SUBPROBLEM.name:  # Python's headers only
            self.compile_flags(ext)
            self.build_or_explain(ext)
            return
        mj = mujoco_dir()
        lib = mujoco_library(mj)
        assert lib is not None
        ext.include_dirs = [*ext.include_dirs, str(mj / "include")]
        if sys.platform == "win32":
            ext.library_dirs = [*ext.library_dirs, str(mj)]
            ext.libraries = [*ext.libraries, "mujoco"]
        else:
            ext.extra_objects = [*ext.extra_objects, str(lib)]  # records its SONAME
            origin = "@loader_path" if sys.platform == "darwin" else "$ORIGIN"
            rpaths = [f"{origin}/../../../mujoco"]  # site-packages/mujoco, installed
            if (getattr(self, "editable_mode", False) or self.inplace) and lasting(mj):
                rpaths.append(str(mj))  # the extension stays in src/
            ext.extra_link_args = [*ext.extra_link_args, *(f"-Wl,-rpath,{r}" for r in rpaths)]
        self.compile_flags(ext)
        self.build_or_explain(ext)

    def compile_flags(self, ext: Extension) -> None:
        """The determinism flags on GCC and Clang (see the module docstring)."""
        if self.compiler.compiler_type in ("unix", "mingw32", "cygwin"):
            ext.extra_compile_args = [*ext.extra_compile_args, "-O3", "-ffp-contract=off"]

    def build_or_explain(self, ext: Extension) -> None:
        """Build ``ext``; a compiler that does not work stops the build with one line."""
        try:
            super().build_extension(ext)
        except (CCompilerError, ExecError, PlatformError, OSError) as exc:
            if self.compiler_works():
                raise  # the compiler runs: an error in the kernel itself, shown above
            cc = (getattr(self.compiler, "compiler_so", None) or [self.compiler.compiler_type])[0]
            raise SystemExit(
                f"{NO_COMPILER}; {cc!r} could not compile a file that includes Python.h"
            ) from exc

    def compiler_works(self) -> bool:
        """Whether the compiler builds an empty file that includes ``Python.h``."""
        with tempfile.TemporaryDirectory() as tmp:
            probe = Path(tmp) / "probe.c"
            probe.write_text("#include <Python.h>\nint probe(void) { return 0; }\n")
            try:
                self.compiler.compile([str(probe)], output_dir=tmp, include_dirs=self.include_dirs)
            except (CCompilerError, ExecError, PlatformError, OSError):
                return False
        return True


LM_KERNEL = Extension(
    "humanoid_ik.solvers.jacobian._lm_kernel",
    sources=["src/humanoid_ik/solvers/jacobian/_lm_kernel.c"],
)

SUBPROBLEM_DIR = "src/humanoid_ik/solvers/analytic/subproblem"
SUBPROBLEM = Extension(
    "humanoid_ik.solvers.analytic.subproblem._subproblem",
    sources=[f"{SUBPROBLEM_DIR}/{f}" for f in ("_subproblem.c", "families.c", "subproblems.c")],
    depends=[f"{SUBPROBLEM_DIR}/subproblems.h"],
)

setup(
    cmdclass={"build_py": BuildPyWithBundled, "build_ext": BuildKernel},
    ext_modules=[LM_KERNEL, SUBPROBLEM],
)
