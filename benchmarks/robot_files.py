"""Heavy robot files: first and second load, where a load's time goes, and render speed.

For each robot (real URDFs of the ``example-robot-data`` package, and the bundled
humanoid), each figure measured in a fresh process so nothing is shared but the disk:

- **load**: ``load_model`` with an empty cache folder (first), then again (second: the
  converted meshes and the compiled model come from the cache), and without the cache
  and decimation (``HUMANOID_IK_CACHE=""``, ``HUMANOID_IK_VISUAL_FACES=0``: every
  command before the cache existed); split into ``model_spec`` (parse, package paths,
  mesh conversion) and the compile (or the cached model's load), wall and CPU time;
- **compile**: where a compile of the full meshes goes: the whole compile, the compile
  without the collision geoms (no convex hulls), and so the hulls' share;
- **render**: frames per second of ``mujoco.Renderer`` on the staged model (lights with
  shadows, a reflective floor: what a film draws) from its ``front`` camera, with the
  decimated visuals and with the full meshes, and the ratio to the bundled humanoid at
  the same size (goal: >= 0.8). CPU time per frame (all threads, llvmpipe's included)
  beside the wall time: the machine may be shared.

::

    MUJOCO_GL=egl python benchmarks/robot_files.py --robots so101,g1 --width 320 --height 240
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from importlib.metadata import distribution
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

ROBOTS = {
    "so101": "so_arm_description/urdf/so101.urdf",
    "g1": "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "icub": "icub_description/robots/icub.urdf",
    "baxter": "baxter_description/urdf/baxter.urdf",
    "panda": "panda_description/urdf/panda.urdf",
}
"""Robots by short name: their URDFs under example-robot-data's ``robots/``."""
HUMANOID = "humanoid"


def robot_path(name: str) -> Path | None:
    """The URDF of robot ``name``; ``None`` for the bundled humanoid."""
    if name == HUMANOID:
        return None
    share = distribution("example-robot-data").locate_file("cmeel.prefix/share")
    return Path(str(share)) / "example-robot-data" / "robots" / ROBOTS[name]


def _clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def _since(t: tuple[float, float]) -> tuple[float, float]:
    w, c = _clock()
    return w - t[0], c - t[1]


# ----------------------------------------------------------------------------- children
def child_load(name: str) -> dict[str, float]:
    """Wall and CPU [s] of ``model_spec`` and of the compile of robot ``name``."""
    from humanoid_ik.core.models import compile_spec, model_file, model_spec

    path = robot_path(name)
    t = _clock()
    spec = model_spec(path)
    spec_w, spec_c = _since(t)
    t = _clock()
    compile_spec(spec, model_file(path))
    comp_w, comp_c = _since(t)
    return {"spec_w": spec_w, "spec_c": spec_c, "compile_w": comp_w, "compile_c": comp_c}


def child_compile(name: str, collisions: bool) -> dict[str, float]:
    """Wall and CPU [s] of ``spec.compile()`` of robot ``name`` with its full meshes,
    with or without its collision geoms."""

    from humanoid_ik.core.models import model_spec

    spec = model_spec(robot_path(name))
    if not collisions:
        for geom in list(spec.geoms):
            if geom.contype or geom.conaffinity:
                spec.delete(geom)
    t = _clock()
    model = spec.compile()
    w, c = _since(t)
    return {"w": w, "c": c, "faces": float(model.nmeshface), "graph": float(model.nmeshgraph)}


def child_render(names: list[str], width: int, height: int, frames: int) -> dict[str, dict]:
    """Per robot: median wall and CPU [s] per frame of the staged model from its
    ``front`` camera, drawn triangles; rounds alternate between the robots."""
    import mujoco

    from humanoid_ik.outputs.stage import staged_model

    models = {}
    for name in names:
        m = staged_model(robot_path(name))
        drawn = [
            g
            for g in range(m.ngeom)
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH and m.geom_group[g] < 3
        ]
        faces = sum(int(m.mesh_facenum[m.geom_dataid[g]]) for g in drawn)
        models[name] = (m, faces)
    times: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    renderers = {n: mujoco.Renderer(m, height, width) for n, (m, _) in models.items()}
    datas = {}
    for n, (m, _) in models.items():
        datas[n] = mujoco.MjData(m)
        mujoco.mj_forward(m, datas[n])
        renderers[n].update_scene(datas[n], "front")
        renderers[n].render()  # warm-up: uploads the meshes
    for _ in range(3):
        for n in names:
            for _ in range(frames):
                t = _clock()
                renderers[n].update_scene(datas[n], "front")
                renderers[n].render()
                times[n].append(_since(t))
    for r in renderers.values():
        r.close()
    return {
        n: {
            "w": statistics.median(w for w, _ in times[n]),
            "c": statistics.median(c for _, c in times[n]),
            "faces": models[n][1],
        }
        for n in names
    }


# ----------------------------------------------------------------------------- parent
def _run(args: list[str], env: dict[str, str]) -> dict:
    """Run this script as a child with ``args`` in ``env``; its JSON answer."""
    out = subprocess.run(
        [sys.executable, __file__, *args],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        raise SystemExit(f"child {args} failed:\n{out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robots", default="so101,g1", help=f"of {', '.join(ROBOTS)}")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--frames", type=int, default=10, help="frames per round (3 rounds)")
    p.add_argument("--_child", nargs="+", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args._child:
        kind, *rest = args._child
        if kind == "load":
            answer: dict = child_load(rest[0])
        elif kind == "compile":
            answer = child_compile(rest[0], rest[1] == "1")
        else:
            answer = child_render(rest, args.width, args.height, args.frames)
        print(json.dumps(answer))
        return 0
    robots = [r for r in args.robots.split(",") if r]
    unknown = [r for r in robots if r not in ROBOTS]
    if unknown:
        p.error(f"unknown robot {unknown[0]!r}; robots: {', '.join(ROBOTS)}")
    size = ["--width", str(args.width), "--height", str(args.height)]
    size += ["--frames", str(args.frames)]
    bare = {"HUMANOID_IK_CACHE": "", "HUMANOID_IK_VISUAL_FACES": "0"}

    print("load [s] (wall / CPU): model_spec + compile; each in a fresh process")
    print(f"{'robot':<9} {'run':<22} {'spec':>13} {'compile':>13} {'total':>13}")
    with tempfile.TemporaryDirectory() as cache:
        for name in [HUMANOID, *robots]:
            runs = [("no cache, full meshes", bare), ("first (empty cache)", {})]
            runs.append(("second (cached)", {}))
            for label, env in runs:
                r = _run(["--_child", "load", name], {"HUMANOID_IK_CACHE": cache, **env})
                tw, tc = r["spec_w"] + r["compile_w"], r["spec_c"] + r["compile_c"]
                print(
                    f"{name:<9} {label:<22} {r['spec_w']:6.2f}/{r['spec_c']:<6.2f}"
                    f"{r['compile_w']:6.2f}/{r['compile_c']:<6.2f}{tw:6.2f}/{tc:<6.2f}"
                )

        print("\ncompile of the full meshes [s] (wall / CPU): the convex hulls' share")
        print(f"{'robot':<9} {'faces':>8} {'all geoms':>13} {'no collision':>13} {'hulls':>13}")
        for name in robots:
            full = _run(["--_child", "compile", name, "1"], bare)
            visual = _run(["--_child", "compile", name, "0"], bare)
            print(
                f"{name:<9} {int(full['faces']):>8} {full['w']:6.2f}/{full['c']:<6.2f}"
                f"{visual['w']:6.2f}/{visual['c']:<6.2f}"
                f"{full['w'] - visual['w']:6.2f}/{full['c'] - visual['c']:<6.2f}"
            )

        names = [HUMANOID, *robots]
        env = {"HUMANOID_IK_CACHE": cache}
        dec = _run(["--_child", "render", *names, *size], env)
        full = _run(["--_child", "render", *names, *size], {**env, "HUMANOID_IK_VISUAL_FACES": "0"})
    base = dec[HUMANOID]
    print(f"\nrender {args.width}x{args.height}, staged, 'front' camera: median per frame")
    print(f"{'robot':<9} {'meshes':<10} {'triangles':>9} {'ms wall':>8} {'ms CPU':>8} {'fps':>6}")
    for name in names:
        for label, r in (("decimated", dec[name]), ("full", full[name])):
            if name == HUMANOID and label == "full":
                continue
            ratio = f"  x{base['w'] / r['w']:.2f} wall, x{base['c'] / r['c']:.2f} CPU"
            print(
                f"{name:<9} {label:<10} {r['faces']:>9} {r['w'] * 1e3:8.1f} {r['c'] * 1e3:8.1f}"
                f" {1 / r['w']:6.2f}{'' if name == HUMANOID else ratio}"
            )
    print("(xN: the robot's frame rate over the humanoid's; goal >= 0.8)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
