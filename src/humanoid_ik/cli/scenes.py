"""The ``scenes`` subcommand of ``humanoid-ik``: the bundled scenes, one line each."""

from __future__ import annotations

import argparse
from typing import Any

from humanoid_ik.errors import RenderError

__all__ = ["register"]


def _cmd_scenes(args: argparse.Namespace) -> int:
    from humanoid_ik.config.scene import bundled_scenes, bundled_scenes_dir, load_scene
    from humanoid_ik.core.models import bundled_override

    paths = bundled_scenes()
    if not paths:
        folder = bundled_scenes_dir()
        raise RenderError(f"no bundled scenes in '{folder}'{bundled_override('scenes')}")
    rows = []
    for p in paths:
        sc = load_scene(p)
        solvers = sorted({sc.solver_for(e).name for e in sc.effectors})
        rows.append(
            (
                sc.name,
                "+".join(solvers),
                f"{sc.duration:g} s",
                sc.render.camera,
                sc.description,
            )
        )
    widths = [max(len(r[k]) for r in rows) for k in range(4)]
    for r in rows:
        print("  ".join(r[k].ljust(widths[k]) for k in range(4)) + "  " + r[4])
    return 0


def register(subparsers: Any) -> None:
    """Add ``scenes`` to the ``humanoid-ik`` subcommands."""
    p = subparsers.add_parser("scenes", help="list the bundled scenes, one line each")
    p.set_defaults(func=_cmd_scenes)
