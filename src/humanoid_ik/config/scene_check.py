"""A parsed scene checked against its model: the model it runs on, its chains (one robot
state for all effectors, each built by ``config/placement.py``'s ``effector_chain``), the
solvers fit them, the camera and frame size, the sizes and the collision pairs; and
(:func:`place_scene`) a scene's limb effectors and limb-relative targets placed on the
model, in world values. ``config/scene.py`` validates the file (``config/scene_schema.py``)
and calls :func:`check_scene` on the values; a scene built in code is checked the same
way, its sizes too.

Every mistake raises :class:`~humanoid_ik.errors.SceneError` naming the file, the key
and what was expected.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from humanoid_ik.config.placement import (
    LimbPoint,
    PlacedTrack,
    RobotFrame,
    effector_chain,
    fixed_limb,
)
from humanoid_ik.config.specs import (
    MAX_CONTACT_SHEET,
    MAX_FPS,
    MAX_IMAGE_SIZE,
    MAX_SNAPSHOTS,
    MAX_TRAIL,
    MIN_FPS,
    MIN_IMAGE_SIZE,
    POLE,
    SIZE,
    EffectorSpec,
    Scene,
    SolverSpec,
    duration_problem,
    frame_size_ok,
    moves_several,
)
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.checks import check_int, check_number
from humanoid_ik.core.limbs import Profile, profile_for
from humanoid_ik.core.models import load_model, staged_cameras
from humanoid_ik.core.names import check_name
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import axis_name
from humanoid_ik.core.types import MAX_COORDINATE
from humanoid_ik.errors import HumanoidIKError, MotionError, SceneError, show_value
from humanoid_ik.motion import MAX_KNOTS, RandomWalk, TargetTrack
from humanoid_ik.solvers.mink.options import collision_pairs_problem

__all__ = ["check_collision_pairs", "check_scene", "place_scene", "scene_model", "scene_profile"]


class _Messages:
    """The errors of one scene: ``scene.source: key: message``."""

    def __init__(self, scene: Scene):
        self.source = scene.source

    def fail(self, key: str, message: str) -> SceneError:
        return SceneError(self.source, key, message)

    def expect(self, key: str, what: str, got: Any) -> SceneError:
        return self.fail(key, f"expected {what}, got {show_value(got)}")

    def call(self, prefix: str, fn: Callable[..., Any], name: str, *args: Any, **kw: Any) -> Any:
        """``fn(name, *args, **kw)`` (a ``check_*``), its MotionError at ``prefix.name``."""
        try:
            return fn(name, *args, **kw)
        except MotionError as exc:
            key = f"{prefix}.{exc.field}" if prefix else exc.field
            raise self.expect(key, exc.expected, exc.got) from None


def _solver_specs(scene: Scene) -> list[tuple[str, SolverSpec]]:
    """Every solver table of ``scene`` with its key: ``solver``, then each effector's own."""
    specs = [("solver", scene.solver)]
    specs += [
        (f"effectors[{i}].solver", e.solver)
        for i, e in enumerate(scene.effectors)
        if e.solver is not None
    ]
    return specs


def check_collision_pairs(scene: Scene, model: mujoco.MjModel) -> None:
    """Every geom named in a solver's ``collision_pairs`` (``[solver] options`` or an
    effector's ``solver``) is a geom of ``model``.

    Raises:
        SceneError: one line naming the key
            (``solver.options.collision_pairs[0][1][2]``), the name and the model's geoms.
    """
    r = _Messages(scene)
    geom = mujoco.mjtObj.mjOBJ_GEOM
    for key, spec in _solver_specs(scene):
        pairs = spec.options.get("collision_pairs")
        if not pairs or isinstance(pairs, str) or collision_pairs_problem(pairs) is not None:
            continue  # none, "limbs" (derived), or a shape the solver refuses itself
        for i, pair in enumerate(pairs):
            for k, group in enumerate(pair):
                one = isinstance(group, str)
                for n, name in enumerate([group] if one else group):
                    if mujoco.mj_name2id(model, geom, name) >= 0:
                        continue
                    found = [mujoco.mj_id2name(model, geom, g) for g in range(model.ngeom)]
                    valid = ", ".join(sorted(g for g in found if g)) or "none"
                    path = f"{key}.options.collision_pairs[{i}][{k}]" + ("" if one else f"[{n}]")
                    raise r.expect(path, f"a geom of the model ({valid})", name)


def _solved_together(scene: Scene, spec: SolverSpec, other: int) -> bool:
    """An effector solved by ``spec`` and effector ``other`` may share joints: one
    solver that moves several effectors (mink) solves both in one problem (both arms
    with the torso, ``torso = true``)."""
    return moves_several(spec.name) and scene.solver_for(scene.effectors[other]) == spec


def _check_effector(
    r: _Messages,
    scene: Scene,
    robot: Robot,
    i: int,
    owner: dict[str, int],
    profile: Callable[[], Profile],
) -> Chain:
    """Effector ``i``'s chain once its site (body, limb), joints and solver fit; ``owner``
    (joint -> effector index) gains its joints; ``profile`` gives the model's limbs."""
    model = robot.model
    eff = scene.effectors[i]
    key = f"effectors[{i}]"
    if eff.kind != "limb":
        objtype, count = {
            "site": (mujoco.mjtObj.mjOBJ_SITE, model.nsite),
            "body": (mujoco.mjtObj.mjOBJ_BODY, model.nbody),
        }[eff.kind]
        if mujoco.mj_name2id(model, objtype, eff.name) < 0:
            found = [mujoco.mj_id2name(model, objtype, k) for k in range(count)]
            valid = ", ".join(sorted(s for s in found if s)) or "none"
            raise r.expect(f"{key}.{eff.kind}", f"a {eff.kind} of the model ({valid})", eff.name)
    try:
        chain = effector_chain(robot, eff, profile() if eff.kind == "limb" else None)
    except MotionError as exc:
        raise r.expect(f"{key}.{exc.field}", exc.expected, exc.got) from None
    except HumanoidIKError as exc:
        raise r.fail(f"{key}.joints", str(exc)) from None
    spec = scene.solver_for(eff)
    for j in chain.joint_names:
        if j in owner and not _solved_together(scene, spec, owner[j]):
            raise r.fail(
                f"{key}.joints",
                f"joint '{j}' is already moved by effectors[{owner[j]}]; expected "
                "effectors with separate joints (set joints = [...]), or one solver that "
                "moves several effectors (mink) for both",
            )
        owner.setdefault(j, i)
    target = scene.target(eff.target)
    where = f"{key}.solver.name" if eff.solver is not None else "solver.name"
    if eff.task == "reach" and spec.name == "look_at":
        raise r.fail(
            where,
            f"solver 'look_at' aims a site at a point; {key} ({eff.name}) reaches "
            "(task = 'reach'); expected a reaching solver or task = 'look_at'",
        )
    solver = spec.make()
    several = moves_several(spec.name)
    if eff.task == "look_at" and solver.reaches and not several:
        raise r.fail(
            where,
            f"solver '{spec.name}' moves a site onto a point; {key} ({eff.name}) aims "
            "(task = 'look_at'); expected 'look_at' or 'mink'",
        )
    reason = None if several else solver.applicable(chain, target.is_pose)
    if reason is not None:
        raise r.fail(where, f"solver '{spec.name}' cannot drive {key} ({eff.name}): {reason}")
    _check_pole(r, scene, i)
    return chain


def _check_pole(r: _Messages, scene: Scene, i: int) -> None:
    """Effector ``i``'s elbow pole, if any: on a reaching effector, a world point within
    :data:`~humanoid_ik.core.types.MAX_COORDINATE` or another target of the scene."""
    eff = scene.effectors[i]
    pole, key = eff.pole, f"effectors[{i}].pole"
    if pole is None:
        return
    if eff.task == "look_at":
        why = "no pole on a look_at effector (a pole places a reaching arm's elbow)"
        raise r.expect(key, why, pole)
    if isinstance(pole, str):
        names = [t.name for t in scene.targets if t.name != eff.target]
        if pole not in names:
            valid = f"targets: {', '.join(map(repr, names))}" if names else "no other target"
            raise r.expect(key, f"a target other than its own {eff.target!r} ({valid})", pole)
        return
    if isinstance(pole, LimbPoint):
        why = "a world point: a { limb, at } pole is placed when a scene file is read"
        raise r.expect(key, why, pole)
    if not (isinstance(pole, tuple) and len(pole) == 3):
        raise r.expect(key, POLE, pole)
    if max(map(abs, pole)) > MAX_COORDINATE:
        raise r.expect(key, f"coordinates within {MAX_COORDINATE:g} m", list(pole))


def _check_render(r: _Messages, scene: Scene, model: mujoco.MjModel) -> None:
    """The camera exists (the model's or the default stage's) and the frame fits the
    model's off-screen buffer."""
    cams = staged_cameras(model)
    if scene.render.camera not in cams:
        raise r.expect(
            "render.camera", f"one of {', '.join(cams) or '(no cameras)'}", scene.render.camera
        )
    offw, offh = int(model.vis.global_.offwidth), int(model.vis.global_.offheight)
    for k, v, lim in (("width", scene.render.width, offw), ("height", scene.render.height, offh)):
        if MIN_IMAGE_SIZE <= v <= MAX_IMAGE_SIZE and v > lim:
            raise r.expect(
                f"render.{k}", f"at most {lim} (the model's off-screen buffer, visual/global)", v
            )
        if not frame_size_ok(v):
            raise r.expect(f"render.{k}", SIZE, v)


def _check_sizes(r: _Messages, scene: Scene) -> None:
    """Every size-like value within its bound (for a scene built in code; a scene file's
    values are checked as they are read): frame rate, frames, trail, contact sheet,
    snapshots, and each motion reaching the last frame."""
    fps = r.call("", check_number, "fps", scene.fps, low=MIN_FPS, high=MAX_FPS)
    duration = r.call("", check_number, "duration", scene.duration, low=0.0, strict=True)
    too_long = duration_problem(duration, fps)
    if too_long is not None:
        raise r.expect("duration", too_long, duration)
    rs = scene.render
    r.call("render", check_number, "trail", rs.trail, low=0.0, high=MAX_TRAIL)
    r.call("render", check_int, "contact_sheet", rs.contact_sheet, low=0, high=MAX_CONTACT_SHEET)
    if len(rs.snapshots) > MAX_SNAPSHOTS:
        raise r.expect("render.snapshots", f"at most {MAX_SNAPSHOTS} times", len(rs.snapshots))
    last = (scene.n_frames - 1) / fps
    for i, track in enumerate(scene.targets):
        m = track.motion
        if last > m.horizon and isinstance(m, RandomWalk):
            raise r.expect(
                f"targets[{i}].motion.interval",
                f"a number >= {last / (MAX_KNOTS - 3):.3g} (a random_walk draws at most "
                f"{MAX_KNOTS} knots, and this one runs {last:g} s)",
                m.interval,
            )
        if last > m.horizon:
            raise r.fail(
                f"targets[{i}].motion", f"reaches {m.horizon:g} s; the scene runs {last:g} s"
            )


def scene_model(scene: Scene) -> mujoco.MjModel:
    """The model a scene runs on: its MJCF or URDF file as the user wrote it (a film of
    it adds the default stage in the rendering layer, ``outputs/stage.py``).

    Raises:
        SceneError: the model file does not compile (``model`` key).
    """
    return _model(scene.source, scene.model, scene.packages)


def _model(source: str, path: Path, packages: Mapping[str, Path]) -> mujoco.MjModel:
    try:
        return load_model(path, packages=packages)
    except HumanoidIKError as exc:
        raise SceneError(source, "model", str(exc)) from None


def scene_profile(
    source: str,
    model: mujoco.MjModel,
    model_path: str | os.PathLike | None,
    limbs: str | os.PathLike | None,
) -> Profile:
    """The limbs of a scene's model (:func:`~humanoid_ik.core.limbs.profile_for`: the
    profile file ``limbs``, else a ``<model>.limbs.toml`` beside the model, over what is
    found).

    Raises:
        SceneError: the profile file does not fit the model (``limbs`` key).
    """
    try:
        return profile_for(model, model_path, limbs)
    except HumanoidIKError as exc:
        raise SceneError(source, "limbs", str(exc)) from None


def place_scene(
    source: str,
    model_path: Path,
    packages: Mapping[str, Path],
    limbs: Path | None,
    targets: Sequence[TargetTrack | PlacedTrack],
    effectors: Sequence[EffectorSpec],
    solver: SolverSpec | None = None,
) -> tuple[tuple[TargetTrack, ...], tuple[EffectorSpec, ...], tuple[str, ...]]:
    """A scene's targets and effectors placed on its model: every placement in world
    values (``config/placement.py``; an effector's ``{ limb, at }`` pole too), every limb
    effector given its end frame and joints (a ``look_at`` of a fixed head, as on G1,
    left out with a note; a head whose gaze frame looks along another axis than +x, as
    iCub's, aimed along that axis: :func:`_gaze_axis`; ``solver`` is the scene's).
    Returns the targets, the effectors and the notes.

    Raises:
        SceneError: the model or the profile does not load, a limb the model lacks, a
            value the motion refuses once placed (naming the key).
    """
    if not any(isinstance(t, PlacedTrack) for t in targets) and all(
        e.kind != "limb" and not isinstance(e.pole, LimbPoint) for e in effectors
    ):
        return tuple(targets), tuple(effectors), ()  # type: ignore[arg-type]
    model = _model(source, model_path, packages)
    profile = scene_profile(source, model, model_path, limbs)
    frame = RobotFrame(model, profile)
    placed: list[TargetTrack] = []
    for i, t in enumerate(targets):
        try:
            placed.append(t.build(frame, f"targets[{i}]") if isinstance(t, PlacedTrack) else t)
        except MotionError as exc:
            raise SceneError(
                source, exc.field, f"expected {exc.expected}, got {show_value(exc.got)}"
            ) from None
    out: list[EffectorSpec] = []
    notes: list[str] = []
    for i, e in enumerate(effectors):
        if isinstance(e.pole, LimbPoint):  # the elbow's pole: a point in the world
            try:
                pole = frame.value(e.pole, f"effectors[{i}].pole")
            except MotionError as exc:
                raise SceneError(
                    source, exc.field, f"expected {exc.expected}, got {show_value(exc.got)}"
                ) from None
            e = replace(e, pole=tuple(np.asarray(pole).tolist()))
        if e.kind != "limb":
            out.append(e)
            continue
        if fixed_limb(e, profile) and e.task == "look_at":
            notes.append(
                f"effectors[{i}]: the model's {e.limb} is fixed (no joints to turn it): its "
                f"look_at of '{e.target}' is left out"
            )
            continue
        try:
            chain = effector_chain(frame.robot, e, profile)
        except MotionError as exc:
            raise SceneError(
                source,
                f"effectors[{i}].{exc.field}",
                f"expected {exc.expected}, got {show_value(exc.got)}",
            ) from None
        site = chain.ee_name if chain.ee_kind == "site" else None
        body = chain.ee_name if chain.ee_kind == "body" else None
        e = replace(e, site=site, body=body, joints=tuple(chain.joint_names))
        if e.task == "look_at":
            e, note = _gaze_axis(e, profile, solver, i)
            notes.extend([note] if note else [])
        out.append(e)
    if not out and notes:
        raise SceneError(source, "effectors", f"expected an effector that can move; {notes[0]}")
    return tuple(placed), tuple(out), tuple(f"{source}: {n}" for n in notes)


def _gaze_axis(
    e: EffectorSpec, profile: Profile, solver: SolverSpec | None, i: int
) -> tuple[EffectorSpec, str | None]:
    """A limb's ``look_at`` aims its gaze frame's own forward axis (the profile's
    ``axis``; iCub's head frame looks along -x): the effector gets ``look_at`` with that
    ``forward_axis`` unless it names its own solver; a scene solver that moves several
    effectors (mink) aims its own ``forward_axis``, which a note names. Returns the
    effector and the note, if any."""
    axis = profile.limb(e.limb).axis if e.limb is not None else None
    name = "x" if axis is None else axis_name(axis)
    where = f"effectors[{i}]: the {e.limb}'s gaze axis"
    if name is None:
        return e, f"{where} {list(axis or ())} is not along a frame axis: +x is aimed"
    if name == "x" or e.solver is not None:
        return e, None
    if solver is not None and moves_several(solver.name):
        return e, f"{where} is {name}: give {solver.name} forward_axis = '{name}'"
    return replace(e, solver=SolverSpec("look_at", {"forward_axis": name})), None


def check_scene(scene: Scene, model: mujoco.MjModel | None = None) -> list[Chain]:
    """Check a scene against its model and return one chain per effector.

    Checks the name is a :data:`~humanoid_ik.core.names.NAME` (it names the output
    folder and files), every size-like value is within its bound (``docs/limits.md``),
    the sites and joints exist, no two effectors share a joint, the camera exists, the
    frame fits MuJoCo's off-screen buffer, each effector's solver can solve its chain
    and task, and each elbow pole is a world point or another target of the scene, on a
    reaching effector.

    Args:
        scene: the scene.
        model: its compiled model (:func:`scene_model` when ``None``).

    Returns:
        The chains, in effector order, all on one robot state over ``model``.

    Raises:
        SceneError: naming the scene file, the key and what was expected.
    """
    r = _Messages(scene)
    r.call("", check_name, "name", scene.name)  # it becomes the output folder's name
    _check_sizes(r, scene)
    if model is None:
        model = scene_model(scene)
    robot = Robot(model)
    owner: dict[str, int] = {}
    found: list[Profile] = []

    def profile() -> Profile:  # the limbs, found once and only for a limb effector
        if not found:
            found.append(scene_profile(scene.source, model, scene.model, scene.limbs))
        return found[0]

    chains = [
        _check_effector(r, scene, robot, i, owner, profile) for i in range(len(scene.effectors))
    ]
    if not chains:
        raise r.fail("effectors", "expected at least one effector")
    check_collision_pairs(scene, model)
    _check_render(r, scene, model)
    return chains
