"""Names the mink solver no longer has, kept for one release with a ``DeprecationWarning``.

- ``humanoid_ik.solvers.mink.DEFAULT_HANDS``, ``DEFAULT_GAZE``,
  ``DEFAULT_COLLISION_PAIRS``: the bundled humanoid's effector and geom names, once the
  defaults of :class:`~humanoid_ik.solvers.mink.upper_body.UpperBodyIK`. Nothing in the
  package uses them: pass ``hands=``, ``gaze=`` and ``collision_pairs=`` with your
  model's names (the bundled humanoid's pairs are in ``scenes/upper_body_mink.toml``).
- ``humanoid_ik.solvers.mink.upper_body.DEFAULTS`` and ``check_options``: the dict
  options beside :class:`~humanoid_ik.solvers.mink.options.MinkOptions`, now built from
  it.

The package's and ``upper_body``'s module ``__getattr__`` call :func:`lookup`. This is
the only module of the solver that holds a robot's names.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

from humanoid_ik.solvers.mink.options import NAME, MinkOptions

__all__ = ["PACKAGE_NAMES", "UPPER_BODY_NAMES", "lookup"]

_BODY = ("torso_collision", "chest_collision", "head_collision")
_BUNDLED: dict[str, Any] = {
    "DEFAULT_HANDS": ("right_palm_site", "left_palm_site"),
    "DEFAULT_GAZE": "gaze_site",
    "DEFAULT_COLLISION_PAIRS": (
        (("right_forearm_collision", "right_hand_collision"), _BODY),
        (("left_forearm_collision", "left_hand_collision"), _BODY),
        (("right_hand_collision",), ("left_hand_collision",)),
    ),
}
_LEGACY_KEYS = (
    "position_cost",
    "orientation_cost",
    "gaze_cost",
    "posture_cost",
    "posture_gain",
    "damping",
    "lm_damping",
    "max_velocity",
    "max_step",
    "range_gain",
    "collision_gain",
    "min_distance",
    "detection_distance",
    "tol",
    "rot_tol",
    "max_iterations",
    "stall_window",
)
"""The numbers the old ``DEFAULTS`` dict held."""

PACKAGE_NAMES = frozenset(_BUNDLED)
"""Deprecated names of ``humanoid_ik.solvers.mink``."""
UPPER_BODY_NAMES = frozenset({*_BUNDLED, "DEFAULTS", "check_options"})
"""Deprecated names of ``humanoid_ik.solvers.mink.upper_body``."""


def _check_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """The old ``check_options``: :class:`MinkOptions` from ``options``, as a dict."""
    o = MinkOptions.parse(NAME, options)
    return {k: getattr(o, k) for k in (*_LEGACY_KEYS, "qp_solver")}


def lookup(module: str, name: str) -> Any:
    """Deprecated ``name`` of ``module``, with a ``DeprecationWarning`` (the caller's
    caller is the line that used it).

    Raises:
        AttributeError: ``name`` is not a deprecated name of ``module``.
    """
    names = UPPER_BODY_NAMES if module.endswith(".upper_body") else PACKAGE_NAMES
    if name not in names:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    if name in _BUNDLED:
        why = (
            "UpperBodyIK and MinkSolver have no robot-specific defaults; pass hands=, "
            "gaze= and collision_pairs= with your model's names (the bundled humanoid's "
            "pairs: scenes/upper_body_mink.toml)"
        )
    else:
        why = "use humanoid_ik.solvers.mink.MinkOptions (its fields and MinkOptions.parse)"
    warnings.warn(f"{module}.{name} is deprecated: {why}", DeprecationWarning, stacklevel=3)
    if name == "DEFAULTS":
        o = MinkOptions()
        return {k: getattr(o, k) for k in _LEGACY_KEYS}
    if name == "check_options":
        return _check_options
    return _BUNDLED[name]
