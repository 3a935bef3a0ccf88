"""The typed model of a scene file, :class:`SceneFile` (pydantic): its keys, defaults
and bounds, validated into the values of :mod:`humanoid_ik.config.specs`.

The bounds are the package's own: sizes from ``config/specs.py``, numbers by
:mod:`humanoid_ik.core.checks`, a motion's parameters by its class (``motion.kind``
picks the member of a tagged union built from :data:`~humanoid_ik.motion.MOTIONS`), an
orientation's by :class:`~humanoid_ik.motion.Orientation`, a solver's options by its
options class. What needs the model (sites, joints, geoms, cameras) is checked by
``config/scene_check.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal, Union

from pydantic import (
    AfterValidator,
    BeforeValidator,
    Field,
    ValidationInfo,
    create_model,
    model_validator,
)

from humanoid_ik.config.placement import LIMBS, LimbPoint, Placed, PlacedTrack, placed, placement
from humanoid_ik.config.schema import (
    Packages,
    SolverTable,
    String,
    Table,
    checked,
    expected,
    refused,
    rule,
    tables,
    text,
)
from humanoid_ik.config.specs import (
    MAX_CONTACT_SHEET,
    MAX_FPS,
    MAX_SNAPSHOTS,
    MAX_TRAIL,
    MIN_FPS,
    POLE,
    SIZE,
    TASKS,
    EffectorSpec,
    RenderSpec,
    SolverSpec,
    duration_problem,
    frame_size_ok,
)
from humanoid_ik.config.toml import NAME, name_ok
from humanoid_ik.core.checks import (
    check_bool,
    check_choice,
    check_int,
    check_number,
    check_vector,
)
from humanoid_ik.core.models import bundled_model_path
from humanoid_ik.errors import MotionError
from humanoid_ik.motion import MOTIONS, Motion, Orientation, TargetTrack

__all__ = ["SceneFile"]


def _build(cls: Any, table: Table) -> Any:
    """``cls(**the parameters given)``, a motion or an orientation, which checks them;
    its :class:`~humanoid_ik.errors.MotionError` is the error at the parameter's key. A
    parameter placed relative to the robot (``{ limb = ..., at = ... }``,
    ``config/placement.py``) makes it a :class:`~humanoid_ik.config.placement.Placed`,
    built once the model is known."""
    params = table.model_dump(exclude_unset=True, exclude={"kind"})
    try:
        later = placed(cls, params)
        return cls(**params) if later is None else later
    except MotionError as exc:
        raise expected(exc.expected, exc.got, exc.field) from None


def _parameters(cls: Any, base: type[Table], required: list[str], **fields: Any) -> Any:
    """A table of ``cls``'s parameters (``Any``: :func:`_build` has ``cls`` check
    them), the ``required`` ones without a default."""
    params = {p: (Any, ... if p in required else None) for p in cls.parameters()}
    return create_model(f"{cls.__name__}Table", __base__=base, **(params | fields))


class MotionTable(Table):
    """A ``motion`` table of one kind: ``kind`` and that kind's parameters."""

    motion: ClassVar[type[Motion]]

    @classmethod
    def unknown(cls) -> str:
        keys = ", ".join(sorted(["kind", *cls.motion.parameters()]))
        return f"unknown key for motion '{cls.motion.kind}'; expected one of {keys}"

    @classmethod
    def missing(cls, key: str) -> str:
        return f"missing; motion '{cls.motion.kind}' needs {', '.join(cls.motion.required())}"


def _motion_table(cls: type[Motion]) -> type[MotionTable]:
    table = _parameters(cls, MotionTable, cls.required(), kind=(Literal[cls.kind], ...))
    table.motion = cls
    return table


def _kind(value: Any) -> Any:
    """A table whose ``kind`` is a registered motion (the union's tag)."""
    if not isinstance(value, dict):
        raise expected("a table", value)
    kinds = ", ".join(MOTIONS)
    if "kind" not in value:
        raise refused(f"missing; expected one of {kinds}", "kind")
    if not isinstance(value["kind"], str) or value["kind"] not in MOTIONS:
        raise expected(f"one of {kinds}", value["kind"], "kind")
    return value


# pydantic validates the tables; mypy sees the values they are validated into
if TYPE_CHECKING:
    SolverField = SolverSpec
    MotionField = Motion
    OrientationField = Orientation
else:
    SolverField = Annotated[SolverTable, AfterValidator(lambda t: t.spec)]
    MotionField = Annotated[
        Union[tuple(_motion_table(c) for c in MOTIONS.values())],  # noqa: UP007
        Field(discriminator="kind"),
        BeforeValidator(_kind),
        AfterValidator(lambda t: _build(t.motion, t)),
    ]
    _QUAT = Field(description="a unit quaternion [w, x, y, z]")
    OrientationField = Annotated[
        _parameters(Orientation, Table, [], quat=(Any, _QUAT)),
        AfterValidator(lambda t: _build(Orientation, t)),
    ]


class TargetTable(Table):
    """A ``[[targets]]`` entry."""

    name: Annotated[str, text("a target name")] = Field(description="a target name")
    motion: MotionField = Field(description="a table with kind")
    orientation: OrientationField | None = None

    @property
    def track(self) -> TargetTrack | PlacedTrack:
        if isinstance(self.motion, Placed) or isinstance(self.orientation, Placed):
            return PlacedTrack(self.name, self.motion, self.orientation)
        return TargetTrack(self.name, self.motion, self.orientation)


def _names(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(j, str) for j in v)


def _pole(value: Any) -> Any:
    """``pole``: a target's name (checked against the targets with the model,
    ``config/scene_check.py``), a world point ``(x, y, z)``, or a point placed relative
    to a limb (a :class:`~humanoid_ik.config.placement.LimbPoint`, placed with the
    scene)."""
    if isinstance(value, str) and value:
        return value
    if isinstance(value, dict) and set(value) == {"limb", "at"}:
        try:
            p = placement(value, "")
        except MotionError as exc:
            raise expected(exc.expected, exc.got, exc.field.lstrip(".")) from None
        if isinstance(p, LimbPoint) and p.at.shape == (3,):
            return p
        raise expected("[forward, left, up] (fractions of the reach)", value["at"], "at")
    try:
        return tuple(check_vector("pole", value).tolist())
    except MotionError:
        raise expected(POLE, value) from None


class EffectorTable(Table):
    """An ``[[effectors]]`` entry (its target is checked by :class:`SceneFile`)."""

    site: Annotated[str, text("a site name")] | None = None
    body: Annotated[str, text("a body name")] | None = None
    limb: Annotated[str, checked(check_choice, valid=LIMBS)] | None = None
    target: Any = Field(description="a target name")
    task: Annotated[str, checked(check_choice, valid=TASKS)] = "reach"
    joints: Annotated[tuple[str, ...], rule("a list of joint names", _names)] | None = None
    torso: Annotated[bool, checked(check_bool)] = False
    solver: SolverField | None = None
    pole: Annotated[Any, BeforeValidator(_pole)] = None

    @model_validator(mode="after")
    def _one_end(self) -> EffectorTable:
        given = [k for k in ("site", "body", "limb") if k in self.model_fields_set]
        if len(given) != 1:
            got = ", ".join(given) if given else "none"
            raise refused(f"expected one of site, body or limb, got {got}", (given or ["site"])[0])
        if self.limb is not None and self.joints is not None:
            raise refused(
                "expected no joints with limb (the limb's joints are found from the model; "
                "name a site or body to list joints)",
                "joints",
            )
        if self.torso and self.limb is None:
            raise refused("expected torso = true only with limb", "torso")
        return self

    @property
    def spec(self) -> EffectorSpec:
        return EffectorSpec(
            self.site,
            self.target,
            self.task,
            self.joints,
            self.solver,
            self.body,
            self.limb,
            self.torso,
            self.pole,
        )


Size = Annotated[int, rule(SIZE, frame_size_ok)]


def _times(value: Any) -> Any:
    if not isinstance(value, list):
        raise expected(f"a list of at most {MAX_SNAPSHOTS} times >= 0 (seconds)", value)
    if len(value) > MAX_SNAPSHOTS:
        raise expected(f"at most {MAX_SNAPSHOTS} times", len(value))
    return value


class RenderTable(Table):
    """The ``[render]`` table: every key optional, the defaults :class:`RenderSpec`'s."""

    width: Size = RenderSpec.width
    height: Size = RenderSpec.height
    camera: Annotated[str, text("a camera name")] = RenderSpec.camera
    trail: Annotated[float, checked(check_number, low=0.0, high=MAX_TRAIL)] = RenderSpec.trail
    gif: Annotated[bool, checked(check_bool)] = RenderSpec.gif
    snapshots: Annotated[
        tuple[Annotated[float, checked(check_number, low=0.0)], ...], BeforeValidator(_times)
    ] = RenderSpec.snapshots
    contact_sheet: Annotated[int, checked(check_int, low=0, high=MAX_CONTACT_SHEET)] = (
        RenderSpec.contact_sheet
    )

    @property
    def spec(self) -> RenderSpec:
        return RenderSpec(**self.model_dump())


def _model_path(value: Any, info: ValidationInfo) -> Path:
    """``model``: an existing file, relative to the scene file's folder (``base``)."""
    if not isinstance(value, str) or not value:
        raise expected("an MJCF, URDF or xacro path (relative to the scene file)", value)
    path = Path(value)
    path = path if path.is_absolute() else ((info.context or {}).get("base") or Path(".")) / path
    if not path.is_file():
        raise refused(f"expected an MJCF or URDF file, got {value!r} (not found)")
    return path


def _limbs_path(value: Any, info: ValidationInfo) -> Path:
    """``limbs``: an existing limb profile file, relative to the scene file's folder."""
    if not isinstance(value, str) or not value:
        raise expected("a limb profile file (TOML, relative to the scene file)", value)
    path = Path(value)
    path = path if path.is_absolute() else ((info.context or {}).get("base") or Path(".")) / path
    if not path.is_file():
        raise refused(f"expected a limb profile file (TOML), got {value!r} (not found)")
    return path


TARGETS = "an array of tables [[targets]] with name and motion"
EFFECTORS = "an array of tables [[effectors]] with site (or body, or limb) and target"


class SceneFile(Table):
    """A scene file (``docs/scenes.md``, ``config/scene.py``)."""

    name: Annotated[str, rule(NAME, lambda v: name_ok(v, first_alphanumeric=True))]
    description: String = ""
    model: Annotated[Path, BeforeValidator(_model_path)] = Field(default_factory=bundled_model_path)
    package_path: Packages = {}
    limbs: Annotated[Path, BeforeValidator(_limbs_path)] | None = None
    duration: Annotated[float, checked(check_number, low=0.0, strict=True)] = Field(
        description="a number > 0 (seconds)"
    )
    fps: Annotated[float, checked(check_number, low=MIN_FPS, high=MAX_FPS)] = 30.0
    solver: SolverField = Field(default_factory=lambda: SolverSpec("auto"))
    render: RenderTable = RenderTable()
    targets: Annotated[tuple[TargetTable, ...], tables(TARGETS)] = Field(description=TARGETS)
    effectors: Annotated[tuple[EffectorTable, ...], tables(EFFECTORS)] = Field(
        description=EFFECTORS
    )

    @model_validator(mode="after")
    def _consistent(self) -> SceneFile:
        """At most :data:`MAX_FRAMES` frames; distinct target names and end effectors;
        each effector tracks one of the targets, a ``look_at`` effector a point."""
        too_long = duration_problem(self.duration, self.fps)
        if too_long is not None:
            raise expected(too_long, self.duration, "duration")
        names = [t.name for t in self.targets]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise refused(
                    f"expected a name not used by another target, got {name!r}",
                    f"targets[{i}].name",
                )
        for i, e in enumerate(self.effectors):
            for kind in ("site", "body", "limb"):
                end = getattr(e, kind)
                if end is not None and any(getattr(o, kind) == end for o in self.effectors[:i]):
                    raise refused(
                        f"expected a {kind} no other effector uses, got {end!r}",
                        f"effectors[{i}].{kind}",
                    )
            if e.target not in names:
                raise expected(
                    f"one of {', '.join(map(repr, names))}", e.target, f"effectors[{i}].target"
                )
            if e.task == "look_at" and self.targets[names.index(e.target)].orientation is not None:
                raise refused(
                    f"expected 'reach' for pose target {e.target!r} (look_at aims at a point)",
                    f"effectors[{i}].task",
                )
        return self
