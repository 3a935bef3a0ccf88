"""The bundled ``showcase`` scene on real humanoids: every humanoid and dual-arm robot of
``example-robot-data`` (``tests/robots.py``) and an MJCF humanoid written elsewhere
(``tests/models/mjcf_humanoid.xml``; the dm_control suite humanoid too where the
dm_control venv of ``docs/benchmarks.md`` is there). Each run is what
``humanoid-ik run showcase --model X`` runs (``load_scene`` with the model, then the
scene runner); each criterion of the "Done when" of issue 21 is then checked on the
recording:

- **hands**: each reaching effector on target (``ON_TARGET_DISTANCE``) in at least 99 %
  of its reachable frames. A frame is reachable when the run reached it, or when ``lm``
  with :data:`RESTARTS` restarts (from home and from the recorded pose) reaches it; the
  runner's own flag (the target within the arm's sampled reach, a sphere) is shown
  beside it: a sphere holds points no joint vector reaches (below Baxter's shoulder,
  which turns down 60 degrees at most).
- **gaze**: where the head has joints, the gaze (the head limb's forward axis, from the
  recorded joints) within 1 degree in every frame the head can turn to, that is where a
  search over the head's joint ranges (a grid, then a bounded polish) aims it within 1
  degree; elsewhere at most 1 degree worse than that best aim. A fixed head is a note.
- **joints**: no limited joint of the recording out of its range.
- **collisions**: no penetration of the collision pairs ``collision_pairs = "limbs"``
  derives (:func:`~humanoid_ik.solvers.mink.pairs.limb_collision_pairs`: forearm and
  hand against torso and head, hand against hand), by ``mj_geomDistance`` per frame on
  the recorded ``qpos``; pairs that already touch at home are named and not counted.
- **jumps**: the largest joint step between two frames [rad] (a restart far away shows
  as a jump in the film).

::

    MUJOCO_GL=egl .venv/bin/python benchmarks/showcase_robots.py [--frames 180]
        [--robots g1,talos,...] [--solver dls] [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize
from scipy.spatial import ConvexHull

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from humanoid_ik import make_solver  # noqa: E402
from humanoid_ik.config.scene import load_scene  # noqa: E402
from humanoid_ik.config.specs import Scene  # noqa: E402
from humanoid_ik.core.chain import Chain  # noqa: E402
from humanoid_ik.core.limbs import find_limbs  # noqa: E402
from humanoid_ik.core.measures import ON_TARGET_DISTANCE  # noqa: E402
from humanoid_ik.core.models import home_qpos  # noqa: E402
from humanoid_ik.run.recording import Recording  # noqa: E402
from humanoid_ik.run.runner import SceneRunner  # noqa: E402
from humanoid_ik.solvers.mink.pairs import limb_collision_pairs  # noqa: E402
from tests.robots import robot_file  # noqa: E402

MODELS = ROOT / "tests" / "models"
DM_HUMANOID = (
    ROOT
    / "benchmarks"
    / ".venv-dm"
    / "lib"
    / "python3.11"
    / "site-packages"
    / "dm_control"
    / "suite"
    / "humanoid.xml"
)
ROBOTS: dict[str, Path] = {
    **{n: robot_file(n) for n in ("g1", "g1_hands", "talos", "romeo", "icub")},
    **{n: robot_file(n) for n in ("baxter", "pr2", "tiago_dual")},
    "mjcf_humanoid": MODELS / "mjcf_humanoid.xml",
}
"""The robots by short name: example-robot-data's humanoids and dual-arm robots, and the
MJCF humanoid of ``tests/models``."""
HAND_SHARE = 0.99
"""Share of its reachable frames a hand must be on target in."""
GAZE_TOL = math.radians(1.0)
"""The gaze's largest angle off its target where the head can turn to it [rad]."""
RESTARTS = 60
"""Restarts of the ``lm`` solve that tells whether a missed frame was reachable."""
PENETRATION = 1e-3
"""A collision pair closer than ``-PENETRATION`` [m] is a self-collision."""


@dataclass
class Hand:
    """One reaching effector of a run."""

    name: str
    frames: int
    in_sphere: int  # the runner's reachable flag
    reachable: int  # reached by the run or by lm with restarts
    on_target: int
    worst_reachable_miss: float  # [m], 0 when every reachable frame is on target

    @property
    def share(self) -> float:
        return self.on_target / self.reachable if self.reachable else 1.0


@dataclass
class Gaze:
    """The gaze of a run: ``fixed`` for a fixed head (then nothing else is set)."""

    fixed: bool
    frames: int = 0
    reachable: int = 0
    worst_reachable: float = 0.0  # [rad] over the frames the head can turn to
    worst_excess: float = 0.0  # [rad] achieved minus the best aim, over every frame


@dataclass
class Report:
    """Every criterion of one robot's showcase run."""

    robot: str
    frames: int
    hands: list[Hand]
    gaze: Gaze
    out_of_range: list[str]  # "joint: value outside [lo, hi]"
    collision_frames: int
    worst_penetration: float  # [m], >= 0
    worst_pair: str
    touching_at_home: list[str]
    max_joint_step: float  # [rad]
    notes: tuple[str, ...]
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    failures: list[str] = field(default_factory=list)

    def check(self) -> list[str]:
        """The criteria this run fails, one line each (empty: it passes)."""
        out = []
        for h in self.hands:
            if h.share < HAND_SHARE:
                out.append(
                    f"{h.name}: on target in {h.on_target}/{h.reachable} reachable frames "
                    f"(worst miss {h.worst_reachable_miss * 1e3:.1f} mm)"
                )
        g = self.gaze
        if not g.fixed and g.worst_reachable > GAZE_TOL:
            out.append(f"gaze {math.degrees(g.worst_reachable):.2f} deg off where it can turn")
        if not g.fixed and g.worst_excess > GAZE_TOL:
            out.append(f"gaze {math.degrees(g.worst_excess):.2f} deg worse than it can aim")
        out += [f"out of range: {j}" for j in self.out_of_range]
        if self.collision_frames:
            out.append(
                f"self-collision in {self.collision_frames} frames, "
                f"{self.worst_penetration * 1e3:.1f} mm ({self.worst_pair})"
            )
        self.failures = out
        return out


# ----------------------------------------------------------------------------- running
def showcase(
    model: Path, frames: int | None = None, solver: Any = None, scene: str = "showcase"
) -> tuple[Scene, SceneRunner, Recording]:
    """The bundled scene ``scene`` on ``model`` as ``humanoid-ik run SCENE --model`` runs
    it (the notes it prints are the scene's ``notes``), ``frames`` spread over it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ModelWarning of a URDF's missing parts
        placed = load_scene(scene, model=model)
    placed = placed.with_overrides(frames=frames, solver=solver)
    runner = SceneRunner(placed)
    return placed, runner, runner.run()


def measure(
    robot: str,
    model: Path,
    frames: int | None = None,
    solver: Any = None,
    scene_name: str = "showcase",
) -> Report:
    """Run ``scene_name`` on ``model`` and measure every criterion (see the module)."""
    t0, c0 = time.perf_counter(), time.process_time()
    scene, runner, rec = showcase(model, frames, solver, scene_name)
    q = np.array(rec.qpos)
    m = runner.model
    profile = find_limbs(m)
    hands = [
        _hand(runner.chains[k], rec, k, e.name)
        for k, e in enumerate(scene.effectors)
        if e.task == "reach"
    ]
    heads = [k for k, e in enumerate(scene.effectors) if e.task == "look_at"]
    if heads:
        axis = profile.limbs["head"].axis if "head" in profile.limbs else None
        gaze = _gaze(runner.chains[heads[0]], rec, heads[0], np.asarray(axis or (1.0, 0.0, 0.0)))
    else:
        gaze = Gaze(fixed=True)
    collision = _collisions(m, q, profile)
    steps = np.abs(np.diff(q, axis=0)).max() if len(q) > 1 else 0.0
    report = Report(
        robot,
        len(q),
        hands,
        gaze,
        _out_of_range(m, q),
        *collision,
        float(steps),
        scene.notes,
        time.perf_counter() - t0,
        time.process_time() - c0,
    )
    report.check()
    return report


def _hand(chain: Chain, rec: Recording, k: int, name: str) -> Hand:
    """Effector ``k``'s frames: on target, and each missed frame's reachability by ``lm``
    with :data:`RESTARTS` restarts from home and from the recorded pose."""
    samples = [f.samples[k] for f in rec.frames]
    lm = make_solver("lm", restarts=RESTARTS, library_seeds=16)
    qs = np.array(rec.qpos)[:, chain.qpos_adr]
    reachable, worst = 0, 0.0
    for s, q in zip(samples, qs, strict=True):
        if s.on_target:
            reachable += 1
            continue
        best = min(lm.solve(chain, s.target, q0).position_error for q0 in (chain.q_home, q))
        if best <= ON_TARGET_DISTANCE:
            reachable += 1
            worst = max(worst, float(s.position_error))
    return Hand(
        name,
        len(samples),
        sum(s.reachable for s in samples),
        reachable,
        sum(s.on_target for s in samples),
        worst,
    )


def _gaze(chain: Chain, rec: Recording, k: int, axis: NDArray[np.float64]) -> Gaze:
    """The gaze of effector ``k`` (``axis``: the head limb's forward axis in its end
    frame) from the recorded joints, against the best aim within the ranges."""
    m = chain.model
    d = mujoco.MjData(m)
    targets = [f.samples[k].target for f in rec.frames]
    lo, hi = chain.lower, chain.upper
    n = len(lo)
    per = {1: 181, 2: 61, 3: 25, 4: 13}.get(n, 7)
    grid = np.stack(np.meshgrid(*[np.linspace(a, b, per) for a, b in zip(lo, hi, strict=True)]), -1)
    grid = grid.reshape(-1, n)
    site = chain.ee_kind == "site"

    def aim(qpos: NDArray[np.float64], qh: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        d.qpos[:] = qpos
        d.qpos[chain.qpos_adr] = qh
        mujoco.mj_kinematics(m, d)
        i = chain.ee_id
        p = d.site_xpos[i] if site else d.xpos[i]
        R = (d.site_xmat[i] if site else d.xmat[i]).reshape(3, 3)
        return p.copy(), R @ axis

    def angle(p: NDArray, a: NDArray, t: NDArray) -> NDArray:
        v = t - p
        c = np.sum(a * v, axis=-1) / np.maximum(np.linalg.norm(v, axis=-1), 1e-12)
        return np.arccos(np.clip(c, -1.0, 1.0))

    qpos = np.array(rec.qpos)
    P = A = np.zeros((0, 3))
    reach, worst, excess = 0, 0.0, 0.0
    for qp, t in zip(qpos, targets, strict=True):
        got = float(angle(*aim(qp, qp[chain.qpos_adr]), t))
        if got <= GAZE_TOL:  # aimed: the head can turn to it, and does
            reach += 1
            worst = max(worst, got)
            continue
        if not len(P):  # the grid's aims, once, at the first frame that needs them
            P, A = (np.array(v) for v in zip(*(aim(qpos[0], g) for g in grid), strict=True))
        angles = angle(P, A, t)
        best = float(angles.min())
        for g in grid[np.argsort(angles)[:3]]:
            res = minimize(
                lambda x, qp=qp, t=t: float(angle(*aim(qp, x), t)),
                g,
                method="L-BFGS-B",
                bounds=list(zip(lo, hi, strict=True)),
            )
            best = min(best, float(res.fun))
        if best <= GAZE_TOL:
            reach += 1
            worst = max(worst, got)
        excess = max(excess, got - best)
    return Gaze(False, len(targets), reach, worst, excess)


def _out_of_range(m: mujoco.MjModel, q: NDArray[np.float64]) -> list[str]:
    """Every limited hinge or slide whose recorded value leaves its range, once each."""
    out = []
    for j in range(m.njnt):
        if not m.jnt_limited[j] or m.jnt_type[j] not in (2, 3):  # slide, hinge
            continue
        v = q[:, m.jnt_qposadr[j]]
        lo, hi = m.jnt_range[j]
        bad = v[(v < lo - 1e-9) | (v > hi + 1e-9)]
        if bad.size:
            out.append(f"{m.joint(j).name}: {bad[0]:.4f} outside [{lo:.4f}, {hi:.4f}]")
    return out


def _geom_ids(m: mujoco.MjModel, names: tuple[str | int, ...]) -> list[int]:
    return [g if isinstance(g, int) else m.geom(g).id for g in names]


def _collisions(
    m: mujoco.MjModel, q: NDArray[np.float64], profile: Any
) -> tuple[int, float, str, list[str]]:
    """Frames where a derived collision pair penetrates, the deepest penetration [m] and
    its geoms, and the pairs that already touch at home (not counted)."""
    d = mujoco.MjData(m)
    pairs = [
        (a, b)
        for ga, gb in limb_collision_pairs(m, profile)
        for a in _geom_ids(m, ga)
        for b in _geom_ids(m, gb)
        if a != b
    ]
    if not pairs:
        return 0, 0.0, "", []
    ia, ib = np.array(pairs).T
    rb = m.geom_rbound

    def depths(qpos: NDArray[np.float64]) -> dict[tuple[int, int], float]:
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        near = np.linalg.norm(d.geom_xpos[ia] - d.geom_xpos[ib], axis=1) < rb[ia] + rb[ib]
        out = {}
        for a, b in zip(ia[near], ib[near], strict=True):
            dist = mujoco.mj_geomDistance(m, d, int(a), int(b), 0.01, None)
            if dist < -PENETRATION and mesh_overlap(m, d, int(a), int(b)):
                out[(int(a), int(b))] = -dist
        return out

    home = set(depths(home_qpos(m)))
    frames, worst, worst_pair = 0, 0.0, ""
    for qpos in q:
        hit = {p: v for p, v in depths(qpos).items() if p not in home}
        if hit:
            frames += 1
            p, v = max(hit.items(), key=lambda kv: kv[1])
            if v > worst:
                worst, worst_pair = v, f"{_gname(m, p[0])} / {_gname(m, p[1])}"
    touching = [f"{_gname(m, a)} / {_gname(m, b)}" for a, b in sorted(home)]
    return frames, worst, worst_pair, touching


def world_mesh(m: mujoco.MjModel, d: mujoco.MjData, g: int) -> tuple[NDArray, NDArray] | None:
    """Geom ``g``'s mesh in the world, ``(vertices, faces)``; ``None`` for a primitive."""
    if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
        return None
    k = m.geom_dataid[g]
    v = m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]]
    f = m.mesh_face[m.mesh_faceadr[k] : m.mesh_faceadr[k] + m.mesh_facenum[k]]
    return d.geom_xpos[g] + v @ d.geom_xmat[g].reshape(3, 3).T, f


def inside_mesh(points: NDArray, verts: NDArray, faces: NDArray) -> NDArray[np.bool_]:
    """Which ``points`` lie inside the closed mesh ``(verts, faces)``: the parity of a
    ray's crossings (Moller-Trumbore against every face; a skew ray direction)."""
    ray = np.array([0.5773, 0.5774, 0.5775])
    v0, e1, e2 = (
        verts[faces[:, 0]],
        verts[faces[:, 1]] - verts[faces[:, 0]],
        verts[faces[:, 2]] - verts[faces[:, 0]],
    )
    h = np.cross(ray, e2)
    det = np.sum(e1 * h, axis=1)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = points[:, None, :] - v0[None]
    u = np.sum(s * h, axis=2) * inv
    q = np.cross(s, e1[None])
    v = (q @ ray) * inv
    t = np.sum(e2[None] * q, axis=2) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return (hit.sum(axis=1) % 2) == 1


def mesh_overlap(m: mujoco.MjModel, d: mujoco.MjData, a: int, b: int) -> bool:
    """Whether geoms ``a`` and ``b``, whose convex hulls overlap (MuJoCo collides a mesh
    as its hull), overlap as meshes too: a vertex of one inside the other. PR2's base is
    a low box with a tall column at its back: its hull reaches 0.7 m over the whole
    base, the mesh 0.35 m in front, where the elbows pass. Two convex geoms (or a
    primitive) keep the hulls' answer."""
    ma, mb = world_mesh(m, d, a), world_mesh(m, d, b)
    if ma is None or mb is None:
        return True
    convex = [
        len(ConvexHull(v).vertices) == len(np.unique(v.round(9), axis=0)) for v, _ in (ma, mb)
    ]
    if all(convex):
        return True
    return bool(inside_mesh(ma[0], *mb).any() or inside_mesh(mb[0], *ma).any())


def _gname(m: mujoco.MjModel, g: int) -> str:
    return m.geom(g).name or f"geom {g}"


# ----------------------------------------------------------------------------- table
def table(reports: list[Report]) -> str:
    """The results as a Markdown table."""
    rows = [
        "| robot | frames | right hand | left hand | gaze | out of range | self-collision "
        "| largest step | result |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in reports:
        hands = [f"{h.on_target}/{h.reachable} ({h.in_sphere} in reach sphere)" for h in r.hands]
        hands += ["-"] * (2 - len(hands))
        g = r.gaze
        gaze = (
            "fixed head (said once)"
            if g.fixed
            else f"{g.reachable}/{g.frames} it can turn to, worst "
            f"{math.degrees(g.worst_reachable):.2g} deg"
        )
        coll = (
            "none"
            if not r.collision_frames
            else f"{r.collision_frames} frames, {r.worst_penetration * 1e3:.0f} mm"
        )
        rows.append(
            f"| {r.robot} | {r.frames} | {hands[0]} | {hands[1]} | {gaze} | "
            f"{len(r.out_of_range) or 'none'} | {coll} | {r.max_joint_step:.2f} rad | "
            f"{'pass' if not r.failures else 'FAIL: ' + '; '.join(r.failures)} |"
        )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=None, help="frames (default: the scene's)")
    p.add_argument("--robots", default=None, help="comma-separated names (default: all)")
    p.add_argument("--solver", default=None, help="replace the scene's solver")
    p.add_argument(
        "--scene",
        default="showcase",
        help="a bundled scene of the showcase's effectors "
        "(upper_body_mink: the same motion, solved by the QP with collision avoidance)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = p.parse_args(argv)
    robots = dict(ROBOTS)
    if DM_HUMANOID.is_file():
        robots["dm_control_humanoid"] = DM_HUMANOID
    names = args.robots.split(",") if args.robots else list(robots)
    for n in names:
        if n not in robots:
            p.error(f"--robots: unknown robot '{n}'; robots: {', '.join(robots)}")
    reports = []
    for n in names:
        r = measure(n, robots[n], args.frames, args.solver, args.scene)
        reports.append(r)
        print(
            f"{n}: {r.seconds:.1f} s wall, {r.cpu_seconds:.1f} s CPU"
            + "".join(f"\n  note: {x}" for x in r.notes)
            + "".join(f"\n  touching at home (not counted): {x}" for x in r.touching_at_home),
            file=sys.stderr,
        )
    if args.json:
        print(json.dumps([asdict(r) for r in reports], indent=1))
    else:
        print(table(reports))
    return 1 if any(r.failures for r in reports) else 0


if __name__ == "__main__":
    raise SystemExit(main())
