"""What a user needs to start on an unknown robot: the end effectors a model offers, the
joints the default rule picks for each, which solvers apply (and why not), the chain's
reach, and the suspicious things in the model (ranges that look like the wrong angle
unit, joints without a range, a free joint on the path, a home pose outside the ranges).

:func:`inspect_model` builds an :class:`Inspection`; ``humanoid-ik inspect`` prints its
:meth:`~Inspection.text` or :meth:`~Inspection.to_dict` as JSON. :func:`range_hints`
alone serves a failed solve's message; :func:`home_warning` (``core/models.py``, which
says it once when a model is loaded) the report's line on the home pose.

**Which frames are end effectors.** The candidates are every named site, every named
leaf body, and every hand link: a body named as a hand, gripper, tool, palm or flange
(``HAND_WORDS`` of ``core/names.py``) whose children are all fingers, gripper parts or
sensor frames (Talos's ``gripper_left_base_link``, G1's ``left_hand_palm_link``). A
candidate is not an end effector when the words of its name make it a sensor, camera,
finger or helper frame (``core/names.py``: ``frame_role``), a gripper's mechanism (a
hand word with a part word: ``gripper_left_motor_double_link``), or when it lies inside
an offered hand link; nor when no hinge chain leads to it. Those are listed
apart, each with its reason (:attr:`Inspection.others`).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from humanoid_ik.core.chain import REACH_METHOD, Chain
from humanoid_ik.core.limbs import profile_for
from humanoid_ik.core.models import (
    HomeWarning,
    bundled_model_path,
    display_model,
    home_outside_ranges,
    home_warning,
    load_model,
    model_spec,
    needs_stage,
)
from humanoid_ik.core.names import frame_role
from humanoid_ik.core.robot import joint_name, names
from humanoid_ik.errors import HumanoidIKError, NameNotFoundError
from humanoid_ik.experiments.limb_report import (
    LimbInfo,
    limb_infos,
    limb_lines,
    limb_pairs,
    pair_lines,
)
from humanoid_ik.solvers import SOLVERS
from humanoid_ik.solvers.analytic.subproblem import subproblem_cache

__all__ = [
    "EffectorInfo",
    "Inspection",
    "JointInfo",
    "MJCF_DEGREE_LIMIT",
    "OtherFrame",
    "RADIAN_LIMIT",
    "home_outside_ranges",
    "home_warning",
    "inspect_model",
    "range_hints",
]

MJCF_DEGREE_LIMIT = 2 * math.pi
"""A hinge range whose written values all lie within +-2 pi in an MJCF that reads
degrees (``+-6.3 deg``) was most likely written in radians."""
RADIAN_LIMIT = 2 * math.pi + 0.01
"""The largest range end [rad] that is plausible in radians: a hinge that turns up to a
full turn either way (UR arms: +-2 pi, written rounded), so a range up to 4 pi wide.
An end beyond it (90, 180, 360) was written in degrees."""

_ROLE_NAMES = {
    "sensor": "sensor frame",
    "camera": "camera frame",
    "finger": "finger",
    "helper": "visual or helper frame",
    "part": "gripper part",
}

_TYPES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}


@dataclass(frozen=True)
class JointInfo:
    """One joint on an end effector's path.

    Attributes:
        name: the joint's name.
        type: ``hinge``, ``slide``, ``ball`` or ``free``.
        axis: its axis ``(3,)`` in its body's frame.
        range_rad: ``(lower, upper)`` [rad], ``None`` when the joint has no range.
        range_deg: the same in [deg].
        qpos0: its value in the model's ``qpos0`` [rad] (hinges; ``None`` otherwise).
        qpos0_inside: ``qpos0`` lies inside the range (``True`` without a range).
        world_axis: its unit axis ``(3,)`` in the world frame at the home pose (``None``
            where not measured: :func:`range_hints`).
    """

    name: str
    type: str
    axis: tuple[float, float, float]
    range_rad: tuple[float, float] | None
    range_deg: tuple[float, float] | None
    qpos0: float | None
    qpos0_inside: bool
    world_axis: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class EffectorInfo:
    """A site or body that is an end effector.

    Attributes:
        kind: ``site`` or ``body`` (``--site`` or ``--body``).
        name: its name.
        joints: the hinges the default rule picks (or those given), root first.
        solvers: each solver's name -> ``None`` when it applies to position targets,
            else the reason it does not.
        reach: the chain's sampled reach [m] from its first joint
            (:meth:`~humanoid_ik.core.chain.Chain.reach`, :data:`REACH_METHOD`).
        base: the chain's first joint anchor ``(3,)`` [m] at the home pose.
        family: the chain's family for ``subproblem``'s exact pose IK (a spherical
            wrist, three parallel axes: ``docs/subproblem.md``), ``""`` where none applies.
    """

    kind: str
    name: str
    joints: tuple[JointInfo, ...] = ()
    solvers: dict[str, str | None] = field(default_factory=dict)
    reach: float | None = None
    base: tuple[float, float, float] | None = None
    family: str = ""


@dataclass(frozen=True)
class OtherFrame:
    """A site or leaf body that is not an end effector, and why.

    Attributes:
        kind: ``site`` or ``body``.
        name: its name.
        reason: ``sensor frame``, ``camera frame``, ``finger``, ``visual or helper
            frame``, ``gripper part``, ``part of the hand 'NAME'``, ``not moved by every
            joint given``, or why no chain can be built (``no chain: ...``).
    """

    kind: str
    name: str
    reason: str


@dataclass(frozen=True)
class Inspection:
    """What :func:`inspect_model` found.

    Attributes:
        model: the model as reports name it.
        counts: bodies, joints, sites and cameras of the model.
        staged: a render adds a default stage (no light, floor or cameras).
        effectors: the end effectors (see the module: sites, leaf bodies and hand
            links with a hinge chain); any body can still be named with ``--body``.
        others: the sites and leaf bodies that are not end effectors, with the reason.
        warnings: the suspicious things, one line each.
        limbs: the limbs found (``core/limbs.py``), with the solvers that apply exactly.
        limb_notes: what the limb search decided, one line each.
        collision_pairs: the geom groups the mink solver's ``collision_pairs =
            "limbs"`` keeps apart (``solvers/mink/pairs.py``), by geom name.
    """

    model: str
    counts: dict[str, int]
    staged: bool
    effectors: tuple[EffectorInfo, ...]
    warnings: tuple[str, ...]
    others: tuple[OtherFrame, ...] = ()
    limbs: tuple[LimbInfo, ...] = ()
    limb_notes: tuple[str, ...] = ()
    collision_pairs: tuple[tuple[tuple[str, ...], ...], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready document."""
        return asdict(self)

    def text(self) -> str:
        """The report as text: the model, each end effector with its joint table and
        solvers, the frames that are not end effectors, then the warnings."""
        c = self.counts
        stage = "a render adds the default stage" if self.staged else "has its own stage"
        lines = [
            f"model {self.model}: {c['bodies']} bodies, {c['joints']} joints, "
            f"{c['sites']} sites, {c['cameras']} cameras; {stage}",
            f"{len(self.effectors)} end effector(s) (--site NAME or --body NAME; any body "
            "works with --body):",
        ]
        for e in self.effectors:
            lines.append("")
            lines.extend(_effector_lines(e))
        lines.append("")
        if self.others:
            lines.append(f"not end effectors ({len(self.others)}):")
            lines.extend(_other_lines(self.others))
        lines.extend(limb_lines(self.limbs, self.limb_notes))
        lines.extend(pair_lines(self.collision_pairs))
        if self.warnings:
            lines.append(f"warnings ({len(self.warnings)}):")
            lines.extend(f"  {w}" for w in self.warnings)
        else:
            lines.append("warnings: none")
        return "\n".join(lines)


def _fixed(value: float, digits: int) -> str:
    """``value`` with ``digits`` decimals, or in exponent form beyond 1e6 (a range of
    +-1e300 reads ``+1e+300``, not 300 digits)."""
    return f"{value:+.{digits}f}" if abs(value) < 1e6 else f"{value:+.3g}"


def _effector_lines(e: EffectorInfo) -> list[str]:
    assert e.reach is not None and e.base is not None
    base = ", ".join(f"{v:.3f}" for v in e.base)
    head = f"{e.kind} {e.name}: {len(e.joints)} joint(s), reach {e.reach:.3f} m"
    out = [f"{head} ({REACH_METHOD}) from [{base}]"]
    width = max(len(j.name) for j in e.joints)
    out.append(
        f"  {'joint':<{width}}  type   {'axis (world, home)':<18}  {'range [rad]':<16}  "
        f"{'range [deg]':<16}  qpos0"
    )
    for j in e.joints:
        shown = j.axis if j.world_axis is None else j.world_axis
        axis = " ".join(f"{v + 0.0:+.2f}" for v in shown)
        if j.range_rad is None or j.range_deg is None:
            rad, deg = "unlimited", ""
        else:
            rad = f"{_fixed(j.range_rad[0], 3)} .. {_fixed(j.range_rad[1], 3)}"
            deg = f"{_fixed(j.range_deg[0], 1)} .. {_fixed(j.range_deg[1], 1)}"
        q0 = "" if j.qpos0 is None else f"{j.qpos0 + 0.0:+.3f}"
        inside = "" if j.qpos0_inside else " OUTSIDE the range"
        out.append(
            f"  {j.name:<{width}}  {j.type:<5}  {axis:<18}  {rad:<16}  {deg:<16}  {q0}{inside}"
        )
    good = [n for n, why in e.solvers.items() if why is None]
    out.append(f"  solvers: {', '.join(good) or '(none)'}")
    if e.family:
        out.append(f"  exact pose IK (subproblem): {e.family}")
    for n, why in e.solvers.items():
        if why is not None:
            out.append(f"  not {n}: {why}")
    return out


def _other_lines(others: tuple[OtherFrame, ...]) -> list[str]:
    """One line per reason with the frames it applies to; a chain's error, which names
    its frame, one line each."""
    grouped: dict[str, list[str]] = {}
    out = []
    for o in others:
        if o.reason.startswith("no chain: "):
            out.append(f"  {o.kind} {o.name}: {o.reason}")
        else:
            grouped.setdefault(o.reason, []).append(o.name)
    return [f"  {reason}: {', '.join(frames)}" for reason, frames in grouped.items()] + out


def _joint_info(model: mujoco.MjModel, j: int, world_axis: np.ndarray | None = None) -> JointInfo:
    jtype = _TYPES[int(model.jnt_type[j])]
    limited = bool(model.jnt_limited[j]) and jtype in ("hinge", "slide")
    lo, hi = (float(v) for v in model.jnt_range[j])
    rng = (lo, hi) if limited else None
    q0 = float(model.qpos0[model.jnt_qposadr[j]]) if jtype in ("hinge", "slide") else None
    inside = rng is None or q0 is None or lo - 1e-9 <= q0 <= hi + 1e-9
    ax = model.jnt_axis[j]
    world = None
    if world_axis is not None:
        world = (float(world_axis[0]), float(world_axis[1]), float(world_axis[2]))
    return JointInfo(
        name=joint_name(model, j),
        type=jtype,
        axis=(float(ax[0]), float(ax[1]), float(ax[2])),
        range_rad=rng,
        range_deg=None if rng is None else (math.degrees(lo), math.degrees(hi)),
        qpos0=q0,
        qpos0_inside=inside,
        world_axis=world,
    )


def _solvers(chain: Chain) -> dict[str, str | None]:
    out: dict[str, str | None] = {}
    for name, cls in SOLVERS.items():
        try:
            solver = cls()
            if not solver.reaches:
                out[name] = "aims an axis at a point (task look_at); it does not reach"
            else:
                out[name] = solver.applicable(chain, False)
        except HumanoidIKError as exc:
            out[name] = str(exc)
    return out


# ----------------------------------------------------------------------------- frames
def _body_name(model: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or ""


def _candidates(model: mujoco.MjModel) -> tuple[list[tuple[str, str]], list[OtherFrame]]:
    """The end-effector candidates (``(kind, name)``: named sites, then bodies in model
    order) and the sites and leaf bodies the rules of the module leave out."""
    out: list[tuple[str, str]] = []
    others: list[OtherFrame] = []
    for i in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i)
        if name:
            role = frame_role(name)
            if role in _ROLE_NAMES:
                others.append(OtherFrame("site", name, _ROLE_NAMES[role]))
            else:
                out.append(("site", name))
    children: dict[int, list[int]] = {}
    for b in range(1, model.nbody):
        children.setdefault(int(model.body_parentid[b]), []).append(b)
    roles = {b: frame_role(_body_name(model, b)) for b in range(1, model.nbody)}
    attached = ("finger", "part", "sensor", "camera", "helper")
    hands = {
        b
        for b, kids in children.items()
        if b > 0 and roles[b] == "hand" and all(roles[k] in attached for k in kids)
    }
    inside: dict[int, int] = {}  # body -> the offered hand link it belongs to
    for h in hands:
        todo = list(children.get(h, []))
        while todo:
            b = todo.pop()
            inside[b] = h
            todo += children.get(b, [])
    for b in range(1, model.nbody):
        name = _body_name(model, b)
        if not name or (b in children and b not in hands):
            continue
        role = roles[b]
        if role in _ROLE_NAMES:
            others.append(OtherFrame("body", name, _ROLE_NAMES[role]))
        elif b in inside:
            hand = _body_name(model, inside[b])
            others.append(OtherFrame("body", name, f"part of the hand '{hand}'"))
        else:
            out.append(("body", name))
    return out, others


def _chain(model: mujoco.MjModel, kind: str, name: str, joints: Sequence[str] | None) -> Chain:
    if kind == "site":
        return Chain(model, name, joints)
    return Chain(model, joints=joints, body=name)


def _moved_by(model: mujoco.MjModel, kind: str, name: str, joints: Sequence[str]) -> bool:
    """Every joint of ``joints`` lies on the path from the frame to the world."""
    obj = mujoco.mjtObj.mjOBJ_SITE if kind == "site" else mujoco.mjtObj.mjOBJ_BODY
    i = mujoco.mj_name2id(model, obj, name)
    b = int(model.site_bodyid[i]) if kind == "site" else i
    on_path: set[str] = set()
    while b > 0:
        adr, num = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        on_path |= {joint_name(model, j) for j in range(adr, adr + num)}
        b = int(model.body_parentid[b])
    return set(joints) <= on_path


def _effector(
    model: mujoco.MjModel, kind: str, name: str, joints: Sequence[str] | None = None
) -> tuple[EffectorInfo, list[str]]:
    """The end effector's report (its chain the default rule's, or ``joints``), and a
    warning per free joint on its path (where the chain stops).

    Raises:
        HumanoidIKError: no chain can be built to it (the reason).
    """
    chain = _chain(model, kind, name, joints)
    base, reach = chain.reach()
    _, axes = chain.joint_axes_at(chain.q_home)
    infos = tuple(
        _joint_info(model, int(j), axes[i]) for i, j in enumerate(chain.joint_ids.tolist())
    )
    b = (float(base[0]), float(base[1]), float(base[2]))
    warnings = []
    for j in chain.path_joint_ids.tolist():
        if int(model.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE:
            jname = joint_name(model, j)
            warnings.append(
                f"free joint '{jname}' on the path of {kind} '{name}': the chain stops "
                "there; solvers keep the floating base where it is"
            )
    family = subproblem_cache(chain).family
    name_of = "" if family is None else family.name
    return EffectorInfo(kind, name, infos, _solvers(chain), reach, b, name_of), warnings


# ----------------------------------------------------------------------------- warnings
def range_hints(model: mujoco.MjModel, path: str | os.PathLike | None = None) -> list[str]:
    """Suspicious joint ranges of the model's hinges, one line each.

    - a range end beyond +-:data:`RADIAN_LIMIT` (a full turn either way, ``+-2 pi``
      written rounded): probably degrees written where radians are read (URDF, or MJCF
      with ``<compiler angle="radian"/>``). Ranges of up to two turns, as UR arms'
      ``+-2 pi``, are plausible radians; degrees show as ends like 90, 180 or 360;
    - with ``path`` an MJCF that reads degrees (no ``angle="radian"``): ranges whose
      written values all lie within +-:data:`MJCF_DEGREE_LIMIT`, probably radians;
    - a hinge without a range.

    A home pose outside the ranges is :func:`home_warning`'s.
    """
    reads_degrees = False
    if path is not None and Path(path).suffix.lower() not in (".urdf", ".xacro"):
        try:
            reads_degrees = bool(model_spec(path).compiler.degree)
        except HumanoidIKError:
            reads_degrees = False
    out = []
    for j in range(model.njnt):
        if int(model.jnt_type[j]) != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        info = _joint_info(model, j)
        if info.range_rad is None or info.range_deg is None:
            out.append(f"joint '{info.name}' has no range: solvers treat it as unlimited")
            continue
        lo, hi = info.range_rad
        if max(abs(lo), abs(hi)) > RADIAN_LIMIT:
            out.append(
                f"joint '{info.name}' range {lo:+.3g} .. {hi:+.3g} rad goes beyond a full "
                "turn (+-2 pi): probably degrees written where radians are read (URDF "
                'limits and MJCF with angle="radian" are radians)'
            )
        elif (
            reads_degrees
            and hi > lo
            and max(abs(v) for v in info.range_deg) <= (MJCF_DEGREE_LIMIT + 1e-9)
        ):
            d0, d1 = info.range_deg
            out.append(
                f"joint '{info.name}' range {d0:g} .. {d1:g} deg ({lo:+.4f} .. {hi:+.4f} rad): "
                "the MJCF reads angles in degrees; if radians were meant, add "
                '<compiler angle="radian"/>'
            )
    return out


def inspect_model(
    model: str | os.PathLike | None = None,
    joints: Sequence[str] | None = None,
    *,
    packages: Mapping[str, Path] | None = None,
    limbs: str | os.PathLike | None = None,
) -> Inspection:
    """Inspect an MJCF or URDF file (``None``: the bundled humanoid).

    Args:
        model: the model file, or ``None``.
        joints: the chains' joints instead of the default rule (``--joints``): only the
            end effectors every one of them moves are reported.
        packages: ROS package folders ``{NAME: DIR}`` for a URDF's ``package://``
            meshes (:func:`~humanoid_ik.core.models.load_model`).
        limbs: a limb profile overriding what is found (default: ``<model>.limbs.toml``
            beside the model, if there is one; ``docs/limbs.md``).

    Raises:
        ModelError: the file does not exist or does not compile, or a bad profile.
        NameNotFoundError: a joint of ``joints`` is not in the model.
    """
    with warnings.catch_warnings():  # the home pose is among the report's warnings
        warnings.simplefilter("ignore", HomeWarning)
        m = load_model(model, packages=packages)
    for j in joints or ():
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) < 0:
            raise NameNotFoundError("joint", j, names(m, mujoco.mjtObj.mjOBJ_JOINT, m.njnt))
    effectors: list[EffectorInfo] = []
    said = range_hints(m, bundled_model_path() if model is None else model)
    home = home_warning(m)
    if home is not None:
        said.append(home)
    candidates, others = _candidates(m)
    for kind, name in candidates:
        if joints is not None and not _moved_by(m, kind, name, joints):
            others.append(OtherFrame(kind, name, "not moved by every joint given"))
            continue
        try:
            info, on_path = _effector(m, kind, name, joints)
        except HumanoidIKError as exc:
            others.append(OtherFrame(kind, name, f"no chain: {exc}"))
            continue
        effectors.append(info)
        said += [w for w in on_path if w not in said]
    if not effectors:
        said.append(
            "no site or leaf body is an end effector with a hinge on its path: name the "
            "end effector with --body (any body) and the joints with --joints"
        )
    profile = profile_for(m, None if model is None else model, limbs)
    counts = {
        "bodies": int(m.nbody),
        "joints": int(m.njnt),
        "sites": int(m.nsite),
        "cameras": int(m.ncam),
    }
    return Inspection(
        model=display_model(model),
        counts=counts,
        staged=needs_stage(m),
        effectors=tuple(effectors),
        warnings=tuple(said),
        others=tuple(others),
        limbs=limb_infos(m, profile),
        limb_notes=profile.notes,
        collision_pairs=limb_pairs(m, profile),
    )
