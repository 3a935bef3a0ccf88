"""Build hook: the repository's top-level ``models/``, ``scenes/`` and ``sweeps/`` folders
are copied into the package as ``humanoid_ik/_bundled/<folder>/`` when a wheel is built
(from the checkout or from the sdist, which carries them through ``MANIFEST.in``), so an
installed package reads them with ``importlib.resources`` (``core/models.py``). An
editable install reads the checkout's folders themselves.

The iteration loop of the ``lm`` solver is compiled from
``src/humanoid_ik/solvers/jacobian/_lm_loop.c`` (plain C, no MuJoCo or Python header;
``solvers/jacobian/lm_loop.py`` loads it with ctypes). The extension is optional: without
a C compiler the install succeeds and ``lm`` runs its Python loop. Everything else is
declared in ``pyproject.toml``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_py import build_py

BUNDLED = ("models", "scenes", "sweeps")
"""Top-level folders shipped inside the package, under ``humanoid_ik/_bundled/``."""


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


LM_LOOP = Extension(
    "humanoid_ik.solvers.jacobian._lm_loop",
    sources=["src/humanoid_ik/solvers/jacobian/_lm_loop.c"],
    # no fused multiply-add: the loop rounds as the Python loop does, bit for bit
    extra_compile_args=["-O2", "-ffp-contract=off"],
    optional=True,
)

setup(cmdclass={"build_py": BuildPyWithBundled}, ext_modules=[LM_LOOP])
