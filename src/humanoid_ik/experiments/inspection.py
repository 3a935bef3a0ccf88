"""What a user needs to start on an unknown robot: the end effectors a model offers, the
joints the default rule picks for each, which solvers apply (and why not), the chain's
reach, and the suspicious things in the model (ranges that look like the wrong angle
unit, joints without a range, a free joint on the path).

:func:`inspect_model` builds an :class:`Inspection`; ``humanoid-ik inspect`` prints its
:meth:`~Inspection.text` or :meth:`~Inspection.to_dict` as JSON. :func:`range_hints`
alone serves a failed solve's message.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import mujoco

from humanoid_ik.core.chain import Chain
from humanoid_ik.core.models import (
    bundled_model_path,
    display_model,
    load_model,
    model_spec,
    needs_stage,
)
from humanoid_ik.core.robot import joint_name
from humanoid_ik.errors import HumanoidIKError
from humanoid_ik.solvers import SOLVERS

__all__ = [
    "EffectorInfo",
    "Inspection",
    "JointInfo",
    "MJCF_DEGREE_LIMIT",
    "inspect_model",
    "range_hints",
]

MJCF_DEGREE_LIMIT = 2 * math.pi
"""A hinge range whose written values all lie within +-2 pi in an MJCF that reads
degrees (``+-6.3 deg``) was most likely written in radians."""

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
    """

    name: str
    type: str
    axis: tuple[float, float, float]
    range_rad: tuple[float, float] | None
    range_deg: tuple[float, float] | None
    qpos0: float | None
    qpos0_inside: bool


@dataclass(frozen=True)
class EffectorInfo:
    """A site or body that can be an end effector.

    Attributes:
        kind: ``site`` or ``body`` (``--site`` or ``--body``).
        name: its name.
        joints: the hinges the default rule picks, root first.
        solvers: each solver's name -> ``None`` when it applies to position targets,
            else the reason it does not.
        reach: an upper bound of the chain's reach [m] (from its first joint).
        base: the chain's first joint anchor ``(3,)`` [m] at the home pose.
        error: why no chain can be built (then the other fields are empty).
    """

    kind: str
    name: str
    joints: tuple[JointInfo, ...] = ()
    solvers: dict[str, str | None] = field(default_factory=dict)
    reach: float | None = None
    base: tuple[float, float, float] | None = None
    error: str | None = None


@dataclass(frozen=True)
class Inspection:
    """What :func:`inspect_model` found.

    Attributes:
        model: the model as reports name it.
        counts: bodies, joints, sites and cameras of the model.
        staged: a render adds a default stage (no light, floor or cameras).
        effectors: the candidate end effectors: every named site, then every named
            leaf body (any body can be named with ``--body``).
        warnings: the suspicious things, one line each.
    """

    model: str
    counts: dict[str, int]
    staged: bool
    effectors: tuple[EffectorInfo, ...]
    warnings: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready document."""
        return asdict(self)

    def text(self) -> str:
        """The report as text: the model, each end effector with its joint table and
        solvers, then the warnings."""
        c = self.counts
        stage = "a render adds the default stage" if self.staged else "has its own stage"
        lines = [
            f"model {self.model}: {c['bodies']} bodies, {c['joints']} joints, "
            f"{c['sites']} sites, {c['cameras']} cameras; {stage}",
        ]
        ok = [e for e in self.effectors if e.error is None]
        lines.append(
            f"{len(ok)} end effector(s) (--site NAME or --body NAME; any body works with --body):"
        )
        for e in self.effectors:
            lines.append("")
            lines.extend(_effector_lines(e))
        lines.append("")
        if self.warnings:
            lines.append(f"warnings ({len(self.warnings)}):")
            lines.extend(f"  {w}" for w in self.warnings)
        else:
            lines.append("warnings: none")
        return "\n".join(lines)


def _effector_lines(e: EffectorInfo) -> list[str]:
    head = f"{e.kind} {e.name}"
    if e.error is not None:
        return [f"{head}: no chain: {e.error}"]
    assert e.reach is not None and e.base is not None
    base = ", ".join(f"{v:.3f}" for v in e.base)
    out = [f"{head}: {len(e.joints)} joint(s), reach {e.reach:.3f} m from [{base}]"]
    width = max(len(j.name) for j in e.joints)
    out.append(
        f"  {'joint':<{width}}  type   {'axis':<17}  {'range [rad]':<16}  {'range [deg]':<16}"
        "  qpos0"
    )
    for j in e.joints:
        axis = " ".join(f"{v + 0.0:+.2f}" for v in j.axis)
        if j.range_rad is None or j.range_deg is None:
            rad, deg = "unlimited", ""
        else:
            rad = f"{j.range_rad[0]:+.3f} .. {j.range_rad[1]:+.3f}"
            deg = f"{j.range_deg[0]:+.1f} .. {j.range_deg[1]:+.1f}"
        q0 = "" if j.qpos0 is None else f"{j.qpos0 + 0.0:+.3f}"
        inside = "" if j.qpos0_inside else " OUTSIDE the range"
        out.append(
            f"  {j.name:<{width}}  {j.type:<5}  {axis:<17}  {rad:<16}  {deg:<16}  {q0}{inside}"
        )
    good = [n for n, why in e.solvers.items() if why is None]
    out.append(f"  solvers: {', '.join(good) or '(none)'}")
    for n, why in e.solvers.items():
        if why is not None:
            out.append(f"  not {n}: {why}")
    return out


def _joint_info(model: mujoco.MjModel, j: int) -> JointInfo:
    jtype = _TYPES[int(model.jnt_type[j])]
    limited = bool(model.jnt_limited[j]) and jtype in ("hinge", "slide")
    lo, hi = (float(v) for v in model.jnt_range[j])
    rng = (lo, hi) if limited else None
    q0 = float(model.qpos0[model.jnt_qposadr[j]]) if jtype in ("hinge", "slide") else None
    inside = rng is None or q0 is None or lo - 1e-9 <= q0 <= hi + 1e-9
    ax = model.jnt_axis[j]
    return JointInfo(
        name=joint_name(model, j),
        type=jtype,
        axis=(float(ax[0]), float(ax[1]), float(ax[2])),
        range_rad=rng,
        range_deg=None if rng is None else (math.degrees(lo), math.degrees(hi)),
        qpos0=q0,
        qpos0_inside=inside,
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


def _candidates(model: mujoco.MjModel) -> list[tuple[str, str]]:
    """Every named site, then every named body without child bodies (not the world)."""
    out = []
    for i in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i)
        if name:
            out.append(("site", name))
    parents = set(int(p) for p in model.body_parentid[1:])
    for b in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)
        if name and b not in parents:
            out.append(("body", name))
    return out


def _chain(model: mujoco.MjModel, kind: str, name: str) -> Chain:
    if kind == "site":
        return Chain(model, name)
    return Chain(model, body=name)


def _effector(model: mujoco.MjModel, kind: str, name: str) -> tuple[EffectorInfo, list[str]]:
    """The end effector's report, and a warning per free joint on its path (where the
    chain stops)."""
    try:
        chain = _chain(model, kind, name)
    except HumanoidIKError as exc:
        return EffectorInfo(kind, name, error=str(exc)), []
    base, reach = chain.reach()
    joints = tuple(_joint_info(model, int(j)) for j in chain.joint_ids)
    b = (float(base[0]), float(base[1]), float(base[2]))
    warnings = []
    for j in chain.path_joint_ids.tolist():
        if int(model.jnt_type[j]) == mujoco.mjtJoint.mjJNT_FREE:
            jname = joint_name(model, j)
            warnings.append(
                f"free joint '{jname}' on the path of {kind} '{name}': the chain stops "
                "there; solvers keep the floating base where it is"
            )
    return EffectorInfo(kind, name, joints, _solvers(chain), reach, b), warnings


def range_hints(model: mujoco.MjModel, path: str | os.PathLike | None = None) -> list[str]:
    """Suspicious joint ranges and values of the model's hinges, one line each.

    - a range wider than 2 pi: probably degrees written where radians are read (URDF,
      or MJCF with ``<compiler angle="radian"/>``);
    - with ``path`` an MJCF that reads degrees (no ``angle="radian"``): ranges whose
      written values all lie within +-:data:`MJCF_DEGREE_LIMIT`, probably radians;
    - a hinge without a range;
    - ``qpos0`` outside the range.
    """
    reads_degrees = False
    if path is not None and Path(path).suffix.lower() != ".urdf":
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
        if hi - lo > 2 * math.pi + 1e-9:
            out.append(
                f"joint '{info.name}' range {lo:+.3g} .. {hi:+.3g} rad is wider than 2 pi: "
                "probably degrees written where radians are read (URDF limits and MJCF with "
                'angle="radian" are radians)'
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
        if not info.qpos0_inside:
            out.append(f"joint '{info.name}' qpos0 {info.qpos0:+.3f} rad is outside its range")
    return out


def inspect_model(model: str | os.PathLike | None = None) -> Inspection:
    """Inspect an MJCF or URDF file (``None``: the bundled humanoid).

    Raises:
        ModelError: the file does not exist or does not compile.
    """
    m = load_model(model)
    effectors: list[EffectorInfo] = []
    warnings = range_hints(m, bundled_model_path() if model is None else model)
    for kind, name in _candidates(m):
        info, on_path = _effector(m, kind, name)
        effectors.append(info)
        warnings += [w for w in on_path if w not in warnings]
    if not any(e.error is None for e in effectors):
        warnings.append(
            "no site or leaf body has a hinge on its path: name joints with --joints, or a "
            "body with --body"
        )
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
        warnings=tuple(warnings),
    )
