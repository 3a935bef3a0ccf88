"""The typed model of a trajectory file's header (pydantic, as the scene files have:
``config/schema.py``) and what a header implies: every array a file of that header
holds follows from it (``outputs/trajectory_layout.py``).

The header's values are checked with the bounds the scene files use, never a copy: the
frame rate and frame count with :data:`~humanoid_ik.config.specs.MIN_FPS`,
:data:`~humanoid_ik.config.specs.MAX_FPS` and
:data:`~humanoid_ik.config.specs.MAX_FRAMES`, the ``render`` block by the scene files'
own ``[render]`` table, the scene's name by the one name rule
(:data:`~humanoid_ik.core.names.NAME`: it becomes ``<scene>.mp4`` and
``renders/<scene>_replay``). ``outputs/trajectory.py`` reads the files through this
module, imported when a file is first read (as the scene files' models, it loads
pydantic); ``docs/formats.md`` lists the rules.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, ValidationError, model_validator

from humanoid_ik.config.scene_schema import RenderTable
from humanoid_ik.config.schema import Table, checked, error_line, expected, refused, rule, text
from humanoid_ik.config.specs import MAX_FPS, MAX_FRAMES, MIN_FPS, TASKS
from humanoid_ik.core.checks import check_bool, check_choice, check_int, check_number
from humanoid_ik.core.names import NAME, name_ok
from humanoid_ik.core.types import MAX_COORDINATE
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.trajectory import TRAJECTORY_FORMAT, TRAJECTORY_VERSION

__all__ = ["EffectorHeader", "Header", "parse_header"]

_HEX = re.compile(r"[0-9a-f]{16}")


def _strings(what: str, unique: bool = False) -> Any:
    """A list of non-empty strings (``unique``: no two equal)."""

    def ok(v: Any) -> bool:
        if not isinstance(v, list) or not all(isinstance(s, str) and s for s in v):
            return False
        return not unique or len(set(v)) == len(v)

    return rule(what, ok)


def _points(value: Any) -> Any:
    """``stage_points``: a list of ``[x, y, z]`` within :data:`MAX_COORDINATE` m."""
    if not isinstance(value, list):
        raise expected("a list of points [x, y, z]", value)
    for i, p in enumerate(value):
        ok = isinstance(p, list) and len(p) == 3
        ok = ok and all(type(c) in (int, float) and abs(c) <= MAX_COORDINATE for c in p)
        if not ok:
            raise expected(
                f"a point [x, y, z] of finite numbers within {MAX_COORDINATE:g} m", p, f"[{i}]"
            )
    return value


class EffectorHeader(Table):
    """One effector of the header's ``effectors`` list."""

    site: Annotated[str, text("a site name")] | None = None
    body: Annotated[str, text("a body name")] | None = None
    target: Annotated[str, text("a target name")] = Field(description="a target name")
    task: Annotated[str, checked(check_choice, valid=TASKS)] = Field(description="reach or look_at")
    solver: Annotated[str, text("a solver label")] = Field(description="a solver label")
    joints: Annotated[list[str], _strings("a list of joint names", unique=True)] = Field(
        description="a list of joint names"
    )
    pose_target: Annotated[bool, checked(check_bool)] = Field(description="true or false")

    @model_validator(mode="after")
    def _one_end(self) -> EffectorHeader:
        if (self.site is None) == (self.body is None):
            raise refused("expected a site or a body (one of them)", "site")
        return self

    @property
    def kind(self) -> str:
        """``site`` or ``body``: what :attr:`name` names."""
        return "site" if self.body is None else "body"

    @property
    def name(self) -> str:
        return str(self.site if self.body is None else self.body)


class Header(Table):
    """A trajectory file's header (``docs/formats.md``)."""

    format: Literal["humanoid-ik trajectory"] = Field(description=repr(TRAJECTORY_FORMAT))
    version: Literal[1] = Field(description=str(TRAJECTORY_VERSION))
    scene: Annotated[str, rule(NAME, name_ok)] = Field(description=NAME)
    scene_file: Annotated[str, rule("a string", lambda v: isinstance(v, str))] = Field(
        description="a path or ''"
    )
    model_file: Annotated[str, text("a model file's path")] = Field(
        description="a model file's path"
    )
    model_sha256: Annotated[
        str, rule("16 hex digits", lambda v: isinstance(v, str) and bool(_HEX.fullmatch(v)))
    ] = Field(description="16 hex digits")
    fps: Annotated[float, checked(check_number, low=MIN_FPS, high=MAX_FPS)] = Field(
        description=f"a number >= {MIN_FPS:g} and <= {MAX_FPS:g} (frames per second)"
    )
    frames: Annotated[int, checked(check_int, low=1, high=MAX_FRAMES)] = Field(
        description=f"an integer >= 1 and <= {MAX_FRAMES} (frames)"
    )
    interrupted: Annotated[bool, checked(check_bool)] = Field(description="true or false")
    qpos_names: Annotated[list[str], _strings("a list of distinct names", unique=True)] = Field(
        description="a list of names"
    )
    joint_names: Annotated[list[str], _strings("a list of joint names")] = Field(
        description="a list of joint names"
    )
    render: RenderTable = Field(description="a table")
    stage_points: Annotated[list[Any], AfterValidator(_points)] = Field(
        description="a list of points"
    )
    effectors: list[EffectorHeader] = Field(description="a list of effectors")

    @model_validator(mode="after")
    def _joints(self) -> Header:
        for k, e in enumerate(self.effectors):
            for j, name in enumerate(e.joints):
                if name not in self.qpos_names:
                    raise expected("one of qpos_names", name, f"effectors[{k}].joints[{j}]")
        return self


def parse_header(doc: Any, source: str) -> Header:
    """The header ``doc`` (parsed JSON) validated, or one :class:`TrajectoryFileError`
    naming ``source``, the key, the value and the rule. A foreign file and another
    version are said as such first."""
    if not isinstance(doc, dict) or doc.get("format") != TRAJECTORY_FORMAT:
        raise TrajectoryFileError(f"'{source}' is not a humanoid-ik trajectory file")
    if doc.get("version") != TRAJECTORY_VERSION:
        raise TrajectoryFileError(
            f"'{source}' is a trajectory of version {doc.get('version')!r}; this humanoid-ik "
            f"reads version {TRAJECTORY_VERSION}"
        )
    try:
        return Header.model_validate(doc)
    except ValidationError as exc:
        key, message = error_line(exc, doc)
        raise TrajectoryFileError(f"trajectory '{source}': {key}: {message}") from None
