"""The limbs part of ``inspect``: each limb found (``core/limbs.py``) with its joints,
its end frame, which solver ``auto`` runs on it for pose and position targets and why,
and the exact solvers listed as applying only where they reach every target the limb
reaches (``two_link`` holding a wrist that moves the hand is not); then the
collision pairs the mink solver derives from them (``collision_pairs = "limbs"``,
``solvers/mink/pairs.py``), by geom name."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from humanoid_ik.core.limbs import Profile, limb_chain
from humanoid_ik.errors import HumanoidIKError
from humanoid_ik.solvers.analytic.closed_form import ClosedForm
from humanoid_ik.solvers.analytic.subproblem import Subproblem
from humanoid_ik.solvers.analytic.two_link import TwoLink
from humanoid_ik.solvers.analytic.two_link.geometry import limb_cache
from humanoid_ik.solvers.auto import Auto
from humanoid_ik.solvers.mink.pairs import limb_collision_pairs
from humanoid_ik.solvers.registry import SOLVERS

__all__ = ["POSE_EXACT", "LimbInfo", "limb_infos", "limb_lines", "limb_pairs", "pair_lines"]

POSE_EXACT = ("closed_form", "subproblem")
"""The exact solvers ``inspect`` lists for pose targets (``two_link``: position)."""


@dataclass(frozen=True)
class LimbInfo:
    """One limb as ``inspect`` reports it.

    Attributes:
        name: the limb's name (``left_arm``, ``head`` ...).
        joints: its joints, root first (empty: fixed).
        end: the end frame, ``"site NAME"`` or ``"body NAME"`` (``""`` for the torso and
            legs).
        auto: the solver ``auto`` runs first on the limb for pose targets (``""`` where
            the limb is not reached with).
        auto_position: the same for position targets.
        why: why ``auto`` runs those, ``{"pose": ..., "position": ...}``.
        exact: per exact solver (:data:`POSE_EXACT` for pose targets, ``two_link``
            for position targets), ``None`` where it applies and reaches every target
            the limb reaches, else why not.
        source: how it was found (``names``, ``geometry``, ``tree``, ``profile``).
    """

    name: str
    joints: tuple[str, ...]
    end: str
    auto: str
    auto_position: str
    why: dict[str, str]
    exact: dict[str, str | None]
    source: str


def limb_infos(model: mujoco.MjModel, profile: Profile) -> tuple[LimbInfo, ...]:
    """What ``inspect`` says of each limb of ``profile`` on ``model``."""
    out = []
    auto = Auto()
    for limb in profile.limbs.values():
        end = f"{limb.frame} {limb.frame_name}" if limb.frame else ""
        chosen, why, exact = ["", ""], dict[str, str](), dict[str, str | None]()
        if limb.frame and limb.joints and limb.name != "head":
            try:
                chain = limb_chain(model, limb.name, profile=profile)
            except HumanoidIKError as exc:
                exact = {"chain": str(exc)}
            else:
                for i, task in enumerate(("pose", "position")):
                    chosen[i] = auto.choice(chain, i == 0).name
                    why[task] = auto.reason(chain, i == 0)
                exact = {
                    "closed_form": ClosedForm().applicable(chain, True),
                    "subproblem": Subproblem().applicable(chain, True),
                    "two_link": TwoLink().applicable(chain, False) or limb_cache(chain).held,
                }
        out.append(
            LimbInfo(limb.name, limb.joints, end, chosen[0], chosen[1], why, exact, limb.source)
        )
    return tuple(out)


_POLE = (
    "honoured by "
    + ", ".join(n for n, c in SOLVERS.items() if c.honours_pole and n != "auto")
    + " (auto: by the solver it runs; the others ignore it; docs/solvers.md)"
)
"""What the report says of an arm's elbow pole (``Target.pole``)."""


def limb_lines(limbs: tuple[LimbInfo, ...], notes: tuple[str, ...] = ()) -> list[str]:
    """The limbs section of the text report."""
    if not limbs:
        return ["limbs: none found (docs/limbs.md: name them in a <model>.limbs.toml)"]
    out = [f"limbs ({len(limbs)}; --arm left|right, --limb NAME; docs/limbs.md):"]
    width = max(len(lb.name) for lb in limbs)
    for lb in limbs:
        joints = (
            "fixed"
            if not lb.joints
            else f"{len(lb.joints)} joint(s) {lb.joints[0]} .. {lb.joints[-1]}"
            if len(lb.joints) > 2
            else f"{len(lb.joints)} joint(s) " + ", ".join(lb.joints)
        )
        end = f" -> {lb.end}" if lb.end else ""
        out.append(f"  {lb.name:<{width}}  {joints}{end}")
        if lb.auto:
            out.append(f"  {'':<{width}}  pose targets: auto runs {lb.auto} ({lb.why['pose']})")
            out.append(
                f"  {'':<{width}}  position targets: auto runs {lb.auto_position} "
                f"({lb.why['position']})"
            )
            for solver, why in lb.exact.items():
                task = "pose" if solver in POSE_EXACT else "position"
                state = f"applies (exact, {task} targets)" if why is None else f"no: {why}"
                out.append(f"  {'':<{width}}  {solver}: {state}")
            if "arm" in lb.name:
                out.append(f"  {'':<{width}}  elbow pole: {_POLE}")
    out += [f"  note: {n}" for n in notes]
    return out


def limb_pairs(model: mujoco.MjModel, profile: Profile) -> tuple[tuple[tuple[str, ...], ...], ...]:
    """The geom groups ``collision_pairs = "limbs"`` keeps apart on ``model``, each geom
    by name (``#<id>`` for an unnamed MJCF geom)."""
    return tuple(
        tuple(tuple(g if isinstance(g, str) else f"#{g}" for g in group) for group in pair)
        for pair in limb_collision_pairs(model, profile)
    )


def pair_lines(pairs: tuple[tuple[tuple[str, ...], ...], ...]) -> list[str]:
    """The collision pairs section of the text report (nothing without pairs)."""
    if not pairs:
        return []

    def group(names: tuple[str, ...]) -> str:
        shown = ", ".join(names) if len(names) <= 2 else f"{names[0]} .. {names[-1]}"
        return f"{shown} ({len(names)} geom{'s' if len(names) > 1 else ''})"

    out = [f'collision pairs of the limbs ({len(pairs)}; mink: collision_pairs = "limbs"):']
    out += [f"  {group(a)} vs {group(b)}" for a, b in pairs]
    return out
