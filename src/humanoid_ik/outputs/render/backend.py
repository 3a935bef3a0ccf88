"""The OpenGL backend of off-screen rendering, and the one place that changes process state
for it.

Which backend: when the user set ``MUJOCO_GL`` (``egl``, ``osmesa``, ``glfw``...) that
backend is used. Otherwise EGL is tried (Mesa's EGL renders on the CPU without a GPU or
a display), in a short child process first because a failed EGL attempt would spoil
OSMesa in this process; when EGL does not work, OSMesa is used with a note, and when
neither works :class:`~humanoid_ik.errors.RenderError` says what to install.

What choosing it changes in this process (only :func:`select_backend` does this, once;
the changes are listed on the returned :attr:`Backend.changes`):

- ``os.environ["MUJOCO_GL"]`` is set to the chosen backend when the user had not set it,
  so that MuJoCo modules imported later and child processes make the same choice;
- ``os.environ["PYOPENGL_PLATFORM"]`` is set to ``osmesa`` for OSMesa unless the user set
  it: PyOpenGL reads it once, when first imported (``mujoco.egl`` does the same for EGL);
- ``mujoco.rendering.classic.gl_context.GLContext``, the class ``mujoco.Renderer``
  instantiates, is replaced by the chosen backend's class when MuJoCo picked another one:
  MuJoCo reads ``MUJOCO_GL`` once, when imported, and without it picks GLFW, which needs
  a display.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from dataclasses import dataclass
from typing import Any

import mujoco

from humanoid_ik.errors import RenderError

__all__ = ["GL_BACKENDS", "INSTALL_HINT", "Backend", "open_renderer", "select_backend"]

GL_BACKENDS = ("egl", "osmesa", "glfw", "glx")
"""The values of ``MUJOCO_GL`` that render (``disable``, ``off``... turn rendering off)."""

INSTALL_HINT = (
    "install Mesa's EGL (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 "
    "libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6), or set MUJOCO_GL to a "
    "backend that works here"
)
"""What to install when no backend works (the end of every backend error)."""


@dataclass(frozen=True)
class Backend:
    """The OpenGL backend in use.

    Attributes:
        name: ``egl``, ``osmesa``, ``glfw``...
        chosen_by: ``MUJOCO_GL`` (the user's choice) or ``default``.
        note: why a fallback was taken, or ``""``.
        changes: what choosing it changed in this process, one line each (e.g.
            ``os.environ['MUJOCO_GL'] = 'egl'``); empty when nothing had to change.
    """

    name: str
    chosen_by: str
    note: str = ""
    changes: tuple[str, ...] = ()


_BACKEND: Backend | None = None
"""The backend chosen by the first successful :func:`select_backend` (process-wide)."""
_DISABLED = ("disable", "disabled", "off", "false", "0")
_EGL_PROBE = """
import mujoco
from mujoco.egl import GLContext
c = GLContext(16, 16)
c.make_current()
ctx = mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"), 150)
print("ok")
"""


def _gl_module() -> Any:
    """The module whose ``GLContext`` attribute ``mujoco.Renderer`` instantiates
    (``mujoco.rendering.classic.gl_context`` in MuJoCo 3.3 and later)."""
    mod = sys.modules[mujoco.Renderer.__module__]
    return getattr(mod, "gl_context", mod)


def _context_class(name: str) -> Any:
    """Import the ``GLContext`` class of backend ``name``."""
    if name == "egl":
        from mujoco.egl import GLContext
    elif name == "osmesa":
        from mujoco.osmesa import GLContext
    elif name in ("glfw", "glx", "enable", "enabled", "on", "true", "1", ""):
        from mujoco.glfw import GLContext
    else:
        raise RenderError(
            f"MUJOCO_GL={os.environ.get('MUJOCO_GL', name)!r} is not an OpenGL backend; "
            f"expected one of {', '.join(GL_BACKENDS)} (or unset it: EGL, else OSMesa)"
        )
    return GLContext


def _probe_egl() -> str | None:
    """``None`` when EGL renders in a fresh process, else the reason it does not."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYOPENGL_PLATFORM",)}
    env["MUJOCO_GL"] = "egl"
    try:
        proc = subprocess.run(
            [sys.executable, "-c", _EGL_PROBE],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"the EGL check could not run ({exc})"
    if proc.returncode == 0 and "ok" in proc.stdout:
        return None
    lines = [ln for ln in proc.stderr.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else f"exit status {proc.returncode}"


def _choose() -> tuple[str, str, str]:
    """``(name, chosen_by, note)``: the user's ``MUJOCO_GL``, else EGL when it works, else
    OSMesa. Changes nothing.

    Raises:
        RenderError: ``MUJOCO_GL`` turns rendering off.
    """
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen in _DISABLED:
        raise RenderError(
            f"MUJOCO_GL={os.environ['MUJOCO_GL']!r} turns rendering off; unset it or set "
            "MUJOCO_GL=egl"
        )
    if chosen:
        return chosen, "MUJOCO_GL", ""
    why = _probe_egl()
    if why is None:
        return "egl", "default", ""
    return "osmesa", "default", f"EGL does not work here ({why}); rendering with OSMesa"


def select_backend() -> Backend:
    """Choose the OpenGL backend for this process (once) and install it for
    ``mujoco.Renderer``.

    ``MUJOCO_GL`` set by the user wins. Otherwise EGL when it works (checked in a child
    process), else OSMesa with a note. The first successful call decides for the life
    of the process; later calls return the same :class:`Backend`.

    What it changes in the process, and why (listed on :attr:`Backend.changes`):
    ``os.environ["MUJOCO_GL"]`` is set to the choice when the user had not set it, so
    that MuJoCo modules imported later and child processes agree with it;
    ``os.environ["PYOPENGL_PLATFORM"]`` is set to ``osmesa`` for OSMesa unless already
    set, because PyOpenGL reads it when first imported; and MuJoCo's
    ``gl_context.GLContext`` is replaced by the chosen backend's class when MuJoCo
    picked another at import time (it reads ``MUJOCO_GL`` only then, and defaults to
    GLFW, which needs a display).

    Raises:
        RenderError: ``MUJOCO_GL`` turns rendering off or names no backend, or the
            backend's bindings cannot be loaded.
    """
    global _BACKEND
    if _BACKEND is not None:
        return _BACKEND
    name, chosen_by, note = _choose()
    changes: list[str] = []
    if chosen_by == "default":
        os.environ["MUJOCO_GL"] = name
        changes.append(f"os.environ['MUJOCO_GL'] = {name!r}")
    gl = _gl_module()
    if getattr(gl, "_MUJOCO_GL", None) != name or not hasattr(gl, "GLContext"):
        try:
            if name == "osmesa" and "PYOPENGL_PLATFORM" not in os.environ:
                os.environ["PYOPENGL_PLATFORM"] = "osmesa"
                changes.append("os.environ['PYOPENGL_PLATFORM'] = 'osmesa'")
            cls = _context_class(name)
        except RenderError:
            raise
        except Exception as exc:  # ImportError, OSError... from the GL bindings
            raise RenderError(
                f"OpenGL backend '{name}' cannot be loaded ({exc}); {INSTALL_HINT}"
            ) from exc
        gl.GLContext = cls
        changes.append(f"{gl.__name__}.GLContext = {cls.__module__}.{cls.__qualname__}")
    _BACKEND = Backend(name, chosen_by, note, tuple(changes))
    return _BACKEND


def open_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` of ``width`` x ``height`` [px] on the selected backend.

    Raises:
        RenderError: no OpenGL context can be created (the backend and what to install
            are named).
    """
    backend = select_backend()
    try:
        with warnings.catch_warnings():  # glfw warns before it raises; the error says it all
            warnings.simplefilter("ignore")
            return mujoco.Renderer(model, height, width)
    except Exception as exc:  # the GL bindings raise many types
        note = f" ({backend.note})" if backend.note else ""
        raise RenderError(
            f"cannot create an off-screen OpenGL context with MUJOCO_GL={backend.name}{note}: "
            f"{type(exc).__name__}: {' '.join(str(exc).split())}; {INSTALL_HINT}"
        ) from exc
