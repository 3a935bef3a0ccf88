"""The values a scene file describes: the :class:`Scene` and its solver, effector and
render specifications, and the bounds of a run's sizes. :mod:`humanoid_ik.config.scene`
reads them from a file (through the typed models of ``config/scene_schema.py``) and
:mod:`humanoid_ik.config.scene_check` checks them against the model. This module does
not import pydantic."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.toml import display_path
from humanoid_ik.core.checks import check_vector
from humanoid_ik.core.models import bundled_model_path
from humanoid_ik.errors import MotionError, SceneError, show_value
from humanoid_ik.motion import TargetTrack
from humanoid_ik.solvers import SOLVERS, make_solver
from humanoid_ik.solvers.options import SolverOptions

__all__ = [
    "MAX_CONTACT_SHEET",
    "MAX_FPS",
    "MAX_FRAMES",
    "MAX_IMAGE_SIZE",
    "MAX_JOBS",
    "MAX_SNAPSHOTS",
    "MAX_TRAIL",
    "MIN_FPS",
    "MIN_IMAGE_SIZE",
    "POLE",
    "SIZE",
    "TASKS",
    "EffectorSpec",
    "RenderSpec",
    "Scene",
    "SolverSpec",
    "duration_problem",
    "frame_size_ok",
    "moves_several",
    "takes_collision_pairs",
]

POLE = (
    "[x, y, z] (a world point), another target's name or { limb = NAME, at = [forward, left, up] }"
)
"""What an effector's elbow ``pole`` may be, as messages say it."""
TASKS = ("reach", "look_at")
"""Effector tasks: ``reach`` puts the site on the target (and in its orientation for a
pose target); ``look_at`` aims the site's x axis at the target."""

# The bounds of a run's sizes (``docs/limits.md``), checked by
# :func:`humanoid_ik.config.scene.check_scene`, the scene file reader and the CLI.
MIN_FPS = 0.01
"""Lowest frame rate [1/s]: a frame every 100 s (a preview of a long scene in a few
frames); the video encoder fails on rates near zero."""
MAX_FPS = 1000.0
"""Highest frame rate [1/s]."""
MAX_FRAMES = 100_000
"""Most frames in one run: ``duration x fps``, ``--frames``, a sweep's ``frames``."""
MIN_IMAGE_SIZE = 16
"""Smallest frame width or height [px] (and both must be even)."""
MAX_IMAGE_SIZE = 4096
"""Largest frame width or height [px] (the model's off-screen buffer may allow less)."""
MAX_TRAIL = 60.0
"""Longest end-effector trail drawn [s]."""
MAX_CONTACT_SHEET = 100
"""Most thumbnails in a contact sheet."""
MAX_SNAPSHOTS = 100
"""Most snapshot times in ``render.snapshots``."""
MAX_JOBS = 100_000
"""Most jobs in one sweep (sets x solver configurations x seeds)."""
SIZE = f"an even integer >= {MIN_IMAGE_SIZE} and <= {MAX_IMAGE_SIZE} (pixels)"
"""What a frame width or height must be, as messages say it."""


def duration_problem(duration: float, fps: float) -> str | None:
    """What ``duration`` [s] must be at ``fps`` when ``duration x fps`` is over
    :data:`MAX_FRAMES` frames, else ``None``."""
    frames = duration * fps  # inf for duration = 1e308: over the bound, not an error
    if math.isfinite(frames) and max(1, round(frames)) <= MAX_FRAMES:
        return None
    return f"a number > 0 and <= {MAX_FRAMES / fps:g} (at most {MAX_FRAMES} frames at {fps:g} fps)"


def frame_size_ok(v: object) -> bool:
    """An even integer frame width or height within :data:`MIN_IMAGE_SIZE` and
    :data:`MAX_IMAGE_SIZE`."""
    if isinstance(v, bool) or not isinstance(v, int):
        return False
    return MIN_IMAGE_SIZE <= v <= MAX_IMAGE_SIZE and v % 2 == 0


@dataclass(frozen=True)
class SolverSpec:
    """A solver by name with its options as given (labels, sweep job ids) and, from
    them, its typed options object :attr:`typed`."""

    name: str
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    @cached_property
    def typed(self) -> SolverOptions:
        """The solver's options object (``Options.parse`` of its class: the one place
        their defaults, bounds and messages are written).

        Raises:
            SolverError: an unknown option or a bad value.
        """
        return SOLVERS[self.name].Options.parse(self.name, self.options)

    def make(self):
        """A fresh solver object (:func:`humanoid_ik.solvers.make_solver`)."""
        return make_solver(self.name, **dict(self.options))

    def label(self) -> str:
        """``name`` or ``name(key=value, ...)``; a list of more than three items is shown
        by its length (``collision_pairs=<13 items>``)."""
        if not self.options:
            return self.name

        def show(v: Any) -> str:
            if isinstance(v, (list, tuple)) and len(v) > 3:
                return f"<{len(v)} items>"
            return show_value(v)

        opts = ", ".join(f"{k}={show(v)}" for k, v in self.options.items())
        return f"{self.name}({opts})"


@dataclass(frozen=True)
class EffectorSpec:
    """An end effector (a site, a body or a limb, and the joints that move it) and the
    target it tracks.

    Attributes:
        site: the end-effector site, e.g. ``right_palm_site`` (``None`` when ``body`` or
            ``limb`` names the end effector).
        target: the name of the target it tracks.
        task: ``reach`` or ``look_at`` (aim the site's x axis at the target).
        joints: the chain's joints, or ``None`` for every hinge from the end effector to
            the root (or, with ``limb``, the limb's).
        solver: this effector's own solver, or ``None`` for the scene's solver (a
            ``look_at`` effector then uses ``look_at``).
        body: the end-effector body, e.g. ``tool_link`` of a URDF, instead of a site.
        limb: a limb found from the model (``right_arm``, ``left_arm``, ``head``, ``arm``;
            ``docs/limbs.md``) instead of a site or body. A scene read from a file has it
            placed on its model: ``site`` or ``body`` and ``joints`` then hold the limb's
            end frame and joints, and ``limb`` says where they came from.
        torso: with ``limb``: the torso's joints come first (they help the reach).
        pole: the elbow's pole (``Target.pole``, ``docs/solvers.md``): a world point
            ``(x, y, z)`` [m], or the name of another target of the scene, whose position
            each frame is the pole; ``None`` for none. A file's ``{ limb, at }`` pole is
            a :class:`~humanoid_ik.config.placement.LimbPoint` until the scene is placed
            on its model, then a world point.
    """

    site: str | None
    target: str
    task: str = "reach"
    joints: tuple[str, ...] | None = None
    solver: SolverSpec | None = None
    body: str | None = None
    limb: str | None = None
    torso: bool = False
    pole: Any = None

    def __post_init__(self) -> None:
        if (self.site is not None and self.body is not None) or (
            self.site is None and self.body is None and self.limb is None
        ):
            raise SceneError(
                "<effector>",
                "site",
                f"expected a site, a body or a limb, got site {show_value(self.site)} and "
                f"body {show_value(self.body)}",
            )
        if self.task not in TASKS:
            raise SceneError(
                "<effector>",
                "task",
                f"expected one of {', '.join(map(repr, TASKS))}, got {show_value(self.task)}",
            )
        if self.torso and self.limb is None:
            raise SceneError("<effector>", "torso", "expected a limb with torso = true")
        if self.joints is not None:
            object.__setattr__(self, "joints", tuple(self.joints))
        if isinstance(self.pole, (list, tuple, np.ndarray)):  # a world point
            try:
                p = check_vector("pole", self.pole)
            except MotionError as exc:
                raise SceneError(
                    "<effector>", "pole", f"expected {exc.expected}, got {show_value(exc.got)}"
                ) from None
            object.__setattr__(self, "pole", tuple(p.tolist()))

    @property
    def name(self) -> str:
        """The end effector's name: its site, else its body, else its limb."""
        name = self.site if self.site is not None else self.body
        return name if name is not None else str(self.limb)

    @property
    def kind(self) -> str:
        """``site``, ``body`` or (not yet placed on a model) ``limb``."""
        if self.site is not None:
            return "site"
        return "body" if self.body is not None else "limb"


@dataclass(frozen=True)
class RenderSpec:
    """How a run is filmed.

    Attributes:
        width, height: frame size [px], even, :data:`MIN_IMAGE_SIZE` to
            :data:`MAX_IMAGE_SIZE`.
        camera: a named camera of the model.
        trail: how much of each end effector's recent path is drawn [s] (0: none; at
            most :data:`MAX_TRAIL`).
        gif: also write an animated GIF.
        snapshots: times [s] of the frames saved as PNG (empty: four spread evenly; at
            most :data:`MAX_SNAPSHOTS`).
        contact_sheet: thumbnails in the contact sheet (0: no sheet; at most
            :data:`MAX_CONTACT_SHEET`).
    """

    width: int = 640
    height: int = 480
    camera: str = "front"
    trail: float = 1.5
    gif: bool = False
    snapshots: tuple[float, ...] = ()
    contact_sheet: int = 12


@dataclass(frozen=True)
class Scene:
    """A validated scene. Build one with :func:`load_scene`, or directly and then
    :func:`check_scene`.

    Attributes:
        name: the scene's name (also its output folder).
        duration: [s]; ``duration x fps`` is at most :data:`MAX_FRAMES` frames.
        fps: frames per second [1/s], :data:`MIN_FPS` to :data:`MAX_FPS`.
        solver: the default solver.
        targets: the moving targets.
        effectors: which site tracks which target.
        render: how it is filmed.
        model: the MJCF, URDF or xacro path (the bundled humanoid by default).
        description: one line for ``humanoid-ik scenes``.
        path: the file it came from (for messages), or ``None``.
        packages: ROS package folders ``{NAME: DIR}`` a URDF's ``package://NAME/...``
            paths are looked up in first (the file's ``package_path`` table).
        limbs: a limb profile file (``docs/limbs.md``) naming the model's limbs, instead
            of those found (and of a ``<model>.limbs.toml`` beside the model).
        notes: what placing the scene on its model decided, one line each (a fixed
            head's ``look_at`` effector left out).
    """

    name: str
    duration: float
    fps: float
    solver: SolverSpec
    targets: tuple[TargetTrack, ...]
    effectors: tuple[EffectorSpec, ...]
    render: RenderSpec = field(default_factory=RenderSpec)
    model: Path = field(default_factory=bundled_model_path)
    description: str = ""
    path: Path | None = None
    packages: Mapping[str, Path] = field(default_factory=dict)
    limbs: Path | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "targets", tuple(self.targets))
        object.__setattr__(self, "effectors", tuple(self.effectors))
        object.__setattr__(self, "model", Path(self.model))
        object.__setattr__(self, "packages", {str(k): Path(v) for k, v in self.packages.items()})

    @property
    def n_frames(self) -> int:
        """Frames in a full run: ``max(1, round(duration * fps))``."""
        return max(1, round(self.duration * self.fps))

    def target_points(self, samples: int = 32) -> NDArray[np.float64]:
        """Each target's position at ``samples`` times spread over the run, stacked
        ``(len(targets) * samples, 3)`` [m]: what a stage's cameras frame besides the
        model (:func:`humanoid_ik.outputs.stage.staged_model`)."""
        last = (self.n_frames - 1) / self.fps
        times = np.linspace(0.0, last, max(1, samples))
        pts = [t.motion.position(float(x)) for t in self.targets for x in times]
        return np.asarray(pts, dtype=np.float64).reshape(-1, 3)

    @property
    def source(self) -> str:
        """The scene's file for messages, or ``<scene 'name'>``."""
        return display_path(self.path) if self.path else f"<scene '{self.name}'>"

    def target(self, name: str) -> TargetTrack:
        """The target called ``name``.

        Raises:
            SceneError: no such target (the names are listed).
        """
        for t in self.targets:
            if t.name == name:
                return t
        names = ", ".join(repr(t.name) for t in self.targets)
        raise SceneError(self.source, "targets", f"no target {name!r}; targets: {names}")

    def solver_for(self, effector: EffectorSpec) -> SolverSpec:
        """The solver an effector uses: its own, else the scene's; a ``look_at``
        effector without its own solver uses ``look_at`` unless the scene's solver moves
        several effectors at once."""
        if effector.solver is not None:
            return effector.solver
        if effector.task == "look_at" and not moves_several(self.solver.name):
            return SolverSpec("look_at")
        return self.solver

    def with_overrides(
        self,
        *,
        solver: str | SolverSpec | None = None,
        frames: int | None = None,
        until: float | None = None,
        fps: float | None = None,
        width: int | None = None,
        height: int | None = None,
        camera: str | None = None,
        gif: bool | None = None,
    ) -> Scene:
        """A copy with command-line choices applied (``None`` keeps the scene's value).

        ``solver`` replaces the scene's default solver (its options are dropped unless a
        :class:`SolverSpec` is given); ``until`` cuts the run at that time [s];
        ``frames`` spreads that many frames over the (cut) duration, setting the frame
        rate to ``frames / duration``.
        """
        out = self
        if solver is not None:
            spec = solver if isinstance(solver, SolverSpec) else SolverSpec(solver)
            out = replace(out, solver=spec)
        if fps is not None:
            out = replace(out, fps=float(fps))
        if until is not None:
            out = replace(out, duration=float(until))
        if frames is not None:
            out = replace(out, fps=frames / out.duration)
        r = out.render
        r = replace(
            r,
            width=r.width if width is None else width,
            height=r.height if height is None else height,
            camera=r.camera if camera is None else camera,
            gif=r.gif if gif is None else gif,
        )
        return replace(out, render=r)


def takes_collision_pairs(solver: str) -> bool:
    """Whether solver ``solver`` has a ``collision_pairs`` option (``mink``)."""
    cls = SOLVERS.get(solver)
    return cls is not None and any(
        f.name == "collision_pairs" for f in dataclasses.fields(cls.Options)
    )


def moves_several(solver_name: str) -> bool:
    """True for a registered solver that moves several effectors at once (its class sets
    ``solves_effectors``); such a solver also serves ``look_at`` effectors."""
    cls = SOLVERS.get(solver_name)
    return cls is not None and bool(getattr(cls, "solves_effectors", False))
