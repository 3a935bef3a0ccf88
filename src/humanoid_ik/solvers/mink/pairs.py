"""Collision pairs derived from a humanoid's limbs, for ``collision_pairs = "limbs"``.

:func:`limb_collision_pairs` reads the limbs found from the model
(:func:`~humanoid_ik.core.limbs.find_limbs`, or a profile) and keeps apart what a reach
can bring together:

- each arm's **forearm and hand** (the bodies the arm's elbow moves: its forearm, wrist,
  hand and fingers) against the **torso and head** (the bodies above the arms, and what
  hangs from them that is no arm or leg: the chest, the pelvis, the head and its
  sensors);
- the left **hand** (the bodies its last arm joint moves) against the right one.

The upper arm is left out: at the shoulder it touches the torso by design. The elbow is
the arm joint with an ``elbow`` word in its name, else the one farthest from both the
shoulder (the arm's first joint) and the wrist (its last) at home. Only geoms that
collide (``contype`` or ``conaffinity`` not 0: a URDF's ``<collision>`` geoms, not its
visuals, ``core/models.py``) are taken. Each geom is named by its name (a URDF's are
named after their link at load, ``<link>_collision``), an MJCF's unnamed geom by its
id.

This module does not import mink.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from humanoid_ik.core.limbs import Profile, find_limbs
from humanoid_ik.core.models import home_qpos
from humanoid_ik.core.names import name_words

__all__ = ["LimbPairs", "limb_collision_pairs"]

LimbPairs = tuple[tuple[tuple[str | int, ...], tuple[str | int, ...]], ...]
"""Pairs of geom groups, each geom by name (or id when it has none)."""

_ARMS = ("left_arm", "right_arm", "arm")
_LEGS = ("left_leg", "right_leg")


def limb_collision_pairs(model: mujoco.MjModel, profile: Profile | None = None) -> LimbPairs:
    """The geom groups to keep apart on ``model``: per arm ``(forearm and hand, torso
    and head)``, then ``(left hand, right hand)`` (see the module's rules).

    Args:
        model: the model.
        profile: its limbs (default: :func:`~humanoid_ik.core.limbs.find_limbs`).

    Returns:
        The pairs, empty when the model has no arm or nothing collides; a group that
        would be empty (no colliding geom there) leaves its pair out.
    """
    prof = find_limbs(model) if profile is None else profile
    arms = [prof.limbs[n] for n in _ARMS if n in prof.limbs and prof.limbs[n].joints]
    if not arms:
        return ()
    data = mujoco.MjData(model)
    data.qpos[:] = home_qpos(model)
    mujoco.mj_kinematics(model, data)
    collide = (model.geom_contype != 0) | (model.geom_conaffinity != 0)

    def group(bodies: set[int]) -> tuple[str | int, ...]:
        ids = np.flatnonzero(collide & np.isin(model.geom_bodyid, sorted(bodies)))
        return tuple(model.geom(int(g)).name or int(g) for g in ids)

    forearms, hands, roots = [], [], []
    for arm in arms:
        jids = [model.joint(j).id for j in arm.joints]
        forearms.append(group(_subtree(model, int(model.jnt_bodyid[_elbow(model, data, jids)]))))
        hands.append(group(_subtree(model, int(model.jnt_bodyid[jids[-1]]))))
        roots.append(int(model.jnt_bodyid[jids[0]]))
    limbs = set().union(*(_subtree(model, b) for b in roots))
    for name in _LEGS:
        if name in prof.limbs and prof.limbs[name].joints:
            bodies = [int(model.jnt_bodyid[model.joint(j).id]) for j in prof.limbs[name].joints]
            limbs |= _subtree(model, min(bodies, key=lambda b: len(_ancestors(model, b))))
    above = set(_ancestors(model, roots[0])[1:])
    for b in roots[1:]:
        above &= set(_ancestors(model, b)[1:])
    above.discard(0)  # the world's geoms (a floor) are no part of the robot
    torso = group(set().union(*(_subtree(model, b) for b in above)) - limbs) if above else ()
    pairs = [(f, torso) for f in forearms if f and torso]
    if len(hands) == 2 and all(hands):
        pairs.append((hands[0], hands[1]))
    return tuple(pairs)


def _elbow(model: mujoco.MjModel, data: mujoco.MjData, jids: Sequence[int]) -> int:
    """The arm's elbow joint (see the module)."""
    for j in jids:
        if "elbow" in name_words(model.joint(j).name):
            return int(j)
    anchors = data.xanchor[list(jids)]
    far = np.minimum(
        np.linalg.norm(anchors - anchors[0], axis=1), np.linalg.norm(anchors - anchors[-1], axis=1)
    )
    return int(jids[int(np.argmax(far))])


def _subtree(model: mujoco.MjModel, body: int) -> set[int]:
    """``body`` and every body below it (a child's id is above its parent's)."""
    out = {body}
    for b in range(body + 1, model.nbody):
        if int(model.body_parentid[b]) in out:
            out.add(b)
    return out


def _ancestors(model: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and its ancestors up to the world, ``body`` first."""
    out = [body]
    while out[-1] != 0:
        out.append(int(model.body_parentid[out[-1]]))
    return out
