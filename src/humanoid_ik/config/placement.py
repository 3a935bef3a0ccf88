"""Where a scene's effectors and targets are on its model.

- **The effector's chain.** :func:`effector_chain` is THE builder of an effector's chain
  (scene files, sweep target sets, the stage's chains of a trajectory): a site or a body
  with its joints (the path rule without), or a limb found from the model
  (:mod:`humanoid_ik.core.limbs`), with the torso's joints first when ``torso`` is set.
- **Placements.** A motion's or an orientation's parameter may be given relative to the
  robot instead of in world coordinates (``docs/scenes.md``, portable scenes):

  ========================================  ==========================================
  ``{ limb = "right_arm", at = [f, l, u] }``  the point ``base + reach (f F + l L + u U)``
                                              (``at = [[...], ...]``: a list of points)
  ``{ limb = "right_arm", reach = s }``       the length ``s x reach``; ``[a, b, c]``:
                                              lengths along F, L, U (a box's half extents)
  ``{ robot = [x, y, z] }``                   the direction ``x F + y L + z U``;
                                              ``[w, x, y, z]``: an orientation
  ========================================  ==========================================

  ``F``, ``L``, ``U`` are the robot's forward, left and up axes (the profile's forward
  direction, :attr:`~humanoid_ik.core.limbs.Profile.forward`; up is +z); a limb's
  ``base`` is an arm's first joint (its shoulder) at home, the head's gaze frame at
  home; its ``reach`` an arm's sampled reach (:meth:`~humanoid_ik.core.chain.Chain.reach`,
  the arm without the torso), for the head the mean of the arms'. The file readers
  keep such a parameter as a :class:`Placed` value (:func:`placement`) and build the
  motion once the model is known (:meth:`RobotFrame.build`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.specs import EffectorSpec
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.checks import check_choice
from humanoid_ik.core.limbs import Profile, find_limbs, limb_chain
from humanoid_ik.core.robot import Robot
from humanoid_ik.core.rotations import mat_to_quat, quat_mul
from humanoid_ik.errors import HumanoidIKError, MotionError
from humanoid_ik.motion import TargetTrack

__all__ = [
    "LIMBS",
    "LimbLength",
    "LimbPoint",
    "Placed",
    "PlacedTrack",
    "RobotFrame",
    "RobotValue",
    "effector_chain",
    "placement",
    "fixed_limb",
    "placed",
]

LIMBS = ("right_arm", "left_arm", "head", "arm")
"""The limbs an effector or a placement may name (those with an end frame)."""
PLACEMENT = (
    "{ limb = NAME, at = [forward, left, up] }, { limb = NAME, reach = FRACTION } or "
    "{ robot = [x, y, z] }"
)
"""The forms of a placement, as messages say them."""


@dataclass(frozen=True)
class LimbPoint:
    """``{ limb, at }``: a point ``(3,)`` or points ``(k, 3)`` in reach fractions along the
    robot's forward, left and up axes from the limb's base."""

    limb: str
    at: NDArray[np.float64]


@dataclass(frozen=True)
class LimbLength:
    """``{ limb, reach }``: a length (a number) or lengths along the robot's axes ``(3,)``,
    in fractions of the limb's reach."""

    limb: str
    reach: float | NDArray[np.float64]


@dataclass(frozen=True)
class RobotValue:
    """``{ robot }``: a direction ``(3,)`` or an orientation ``(4,)`` (wxyz) in the robot's
    forward/left/up frame."""

    value: NDArray[np.float64]


Placement = LimbPoint | LimbLength | RobotValue


def _numbers(value: Any, shapes: tuple[tuple[int, ...], ...]) -> NDArray[np.float64] | None:
    """``value`` as a float array of one of ``shapes`` (``(-1, 3)``: any number of
    triples), else ``None``."""
    if _has_bool(value) or isinstance(value, (str, dict)):
        return None
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        return None
    if not np.all(np.isfinite(arr)):
        return None
    for shape in shapes:
        if arr.ndim == len(shape) and all(
            s in (-1, n) for s, n in zip(shape, arr.shape, strict=True)
        ):
            return arr if arr.size else None
    return None


def _has_bool(value: Any) -> bool:
    """TOML's true and false are not numbers (NumPy would take them as 1 and 0)."""
    if isinstance(value, bool):
        return True
    return isinstance(value, list) and any(_has_bool(v) for v in value)


def placement(value: Any, at: str) -> Placement | None:
    """The placement a parameter's value ``value`` is (a table: see the module), ``None``
    for a plain value.

    Raises:
        MotionError: a table that is not a placement, at key ``at`` (``center.limb``).
    """
    if not isinstance(value, dict):
        return None
    keys = set(value)
    if keys == {"robot"}:
        arr = _numbers(value["robot"], ((3,), (4,)))
        if arr is None or not np.any(arr):
            raise MotionError(
                f"{at}.robot",
                "a direction [x, y, z] or an orientation [w, x, y, z]",
                value["robot"],
            )
        return RobotValue(arr)
    if keys not in ({"limb", "at"}, {"limb", "reach"}):
        raise MotionError(at, PLACEMENT, value)
    limb = check_choice(f"{at}.limb", value["limb"], LIMBS)
    if "at" in keys:
        arr = _numbers(value["at"], ((3,), (-1, 3)))
        if arr is None:
            raise MotionError(
                f"{at}.at",
                "[forward, left, up] or a list of them (fractions of the reach)",
                value["at"],
            )
        return LimbPoint(limb, arr)
    arr = _numbers(value["reach"], ((), (3,)))
    if arr is None or np.any(arr < 0):
        raise MotionError(
            f"{at}.reach", "a number >= 0 or three (fractions of the reach)", value["reach"]
        )
    return LimbLength(limb, float(arr) if arr.ndim == 0 else arr)


@dataclass(frozen=True)
class Placed:
    """A motion or an orientation some of whose parameters are placements: ``cls`` built
    from ``params`` once the model is known (:meth:`RobotFrame.build`)."""

    cls: Any
    params: Mapping[str, Any]

    @property
    def kind(self) -> str:
        """The motion's kind (``orientation`` for an orientation)."""
        return str(getattr(self.cls, "kind", "orientation"))


def placed(cls: Any, params: Mapping[str, Any]) -> Placed | None:
    """``Placed(cls, params)`` with each placement table parsed, or ``None`` when no
    parameter is one.

    Raises:
        MotionError: a bad placement table, at its parameter's key.
    """
    found = {k: placement(v, k) for k, v in params.items()}
    if all(p is None for p in found.values()):
        return None
    return Placed(cls, {k: v if found[k] is None else found[k] for k, v in params.items()})


def _limb_names(profile: Profile) -> str:
    return ", ".join(n for n, lb in profile.limbs.items() if n in LIMBS and lb.frame) or "none"


def _limb(profile: Profile, name: str, at: str) -> Any:
    if name not in profile.limbs or not profile.limbs[name].frame:
        raise MotionError(at, f"a limb of the model ({_limb_names(profile)})", name)
    return profile.limbs[name]


# ----------------------------------------------------------------------------- chains
def effector_chain(robot: Robot, spec: EffectorSpec, profile: Profile | None = None) -> Chain:
    """THE chain of effector ``spec`` on ``robot``: its site or body with its joints (every
    hinge from the end frame to the root when ``joints`` is ``None``), else its limb
    (``docs/limbs.md``; ``profile``, found from the model when ``None``), the torso's
    joints first when ``spec.torso``.

    Raises:
        MotionError: a limb the model lacks, or a fixed head (field ``limb``).
        HumanoidIKError: a site, body or joint the model lacks (from
            :class:`~humanoid_ik.core.chain.Chain`).
    """
    if spec.site is not None or spec.body is not None:
        return Chain(robot, spec.site, spec.joints, body=spec.body)
    assert spec.limb is not None  # EffectorSpec.__post_init__
    prof = find_limbs(robot.model) if profile is None else profile
    _limb(prof, spec.limb, "limb")
    if fixed_limb(spec, prof):
        raise MotionError(
            "limb", f"a limb with joints (the model's {spec.limb} is fixed)", spec.limb
        )
    try:
        return limb_chain(robot, spec.limb, with_torso=spec.torso, profile=prof)
    except HumanoidIKError as exc:
        raise MotionError("limb", f"a limb of the model ({exc})", spec.limb) from None


def fixed_limb(spec: EffectorSpec, profile: Profile) -> bool:
    """Whether ``spec`` names a limb that has no joints on this model (G1's head) and no
    torso to turn it."""
    if spec.limb is None or spec.site is not None or spec.body is not None:
        return False
    limb = profile.limbs.get(spec.limb)
    return limb is not None and not limb.joints and not (spec.torso and "torso" in profile.limbs)


# ----------------------------------------------------------------------------- frame
class RobotFrame:
    """The robot's forward/left/up frame and its limbs' bases and reaches at home, on a
    robot state of its own: what placements are resolved against.

    Args:
        model: the compiled model.
        profile: its limbs.
    """

    def __init__(self, model: mujoco.MjModel, profile: Profile):
        self.robot = Robot(model)
        self.robot.reset()
        self.profile = profile
        f = np.array([profile.forward[0], profile.forward[1], 0.0])
        f = f / np.linalg.norm(f) if np.linalg.norm(f) > 0 else np.array([1.0, 0.0, 0.0])
        up = np.array([0.0, 0.0, 1.0])
        left = np.cross(up, f)
        self.axes = np.column_stack([f, left, up])
        """Columns: the robot's forward, left and up axes in the world ``(3, 3)``."""
        self._cache: dict[str, tuple[NDArray[np.float64], float]] = {}

    def limb(self, name: str, at: str = "limb") -> tuple[NDArray[np.float64], float]:
        """Limb ``name``'s base ``(3,)`` [m] and reach [m] (see the module).

        Raises:
            MotionError: the model has no such limb (at key ``at``).
        """
        if name not in self._cache:
            limb = _limb(self.profile, name, at)
            if name == "head":
                arms = [n for n in ("right_arm", "left_arm", "arm") if n in self.profile.limbs]
                if not arms:
                    raise MotionError(at, "an arm's limb (the head's reach is the arms')", name)
                d = self.robot.data
                if limb.frame == "site":
                    base = d.site_xpos[self.robot.model.site(limb.frame_name).id].copy()
                else:
                    base = d.xpos[self.robot.model.body(limb.frame_name).id].copy()
                reach = float(np.mean([self.limb(a, at)[1] for a in arms]))
            else:
                chain = limb_chain(self.robot, name, profile=self.profile)
                base, reach = chain.reach()
            self._cache[name] = (base, reach)
        return self._cache[name]

    def value(self, p: Placement, at: str) -> NDArray[np.float64] | float:
        """The world value of placement ``p`` (of the parameter at key ``at``)."""
        if isinstance(p, RobotValue):
            if p.value.shape == (4,):
                return quat_mul(mat_to_quat(self.axes), p.value)
            return self.axes @ p.value
        base, reach = self.limb(p.limb, f"{at}.limb")
        if isinstance(p, LimbPoint):
            return base + reach * (p.at @ self.axes.T)
        if isinstance(p.reach, float):
            return p.reach * reach
        return np.abs(self.axes) @ (reach * p.reach)

    def build(self, p: Placed) -> Any:
        """The motion or orientation of ``p`` with its placements in world values.

        Raises:
            MotionError: a limb the model lacks, or the class refusing a parameter (its
                field the parameter's key).
        """
        params = {
            k: self.value(v, k) if isinstance(v, (LimbPoint, LimbLength, RobotValue)) else v
            for k, v in p.params.items()
        }
        return p.cls(**params)


@dataclass(frozen=True)
class PlacedTrack:
    """A target whose motion or orientation is :class:`Placed`: a
    :class:`~humanoid_ik.motion.TargetTrack` once built on a model (:meth:`build`)."""

    name: str
    motion: Any
    orientation: Any = None

    def build(self, frame: RobotFrame, at: str) -> TargetTrack:
        """The target in world values; ``at`` is its key (``targets[0]``).

        Raises:
            MotionError: as :meth:`RobotFrame.build`, its field the key below ``at``
                (``targets[0].motion.center.limb``).
        """
        parts = []
        for part, value in (("motion", self.motion), ("orientation", self.orientation)):
            try:
                parts.append(frame.build(value) if isinstance(value, Placed) else value)
            except MotionError as exc:
                raise MotionError(f"{at}.{part}.{exc.field}", exc.expected, exc.got) from None
        return TargetTrack(self.name, parts[0], parts[1])
