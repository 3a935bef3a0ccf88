"""What the typed models of scene and sweep files (pydantic v2) share, and the one
formatter that turns a :class:`pydantic.ValidationError` into the package's one-line
error: ``scenes/x.toml: targets[0].motion.radius: expected a number > 0, got 'big'``.

A file's tables are :class:`Table` models: an unknown key is refused with the valid
ones listed, and a missing key names what it expects (its field's ``description``),
before any value is looked at. Values are checked by the package's own checks, never a
second copy of a bound: :func:`checked` runs a check of :mod:`humanoid_ik.core.checks`,
motions and orientations check their parameters in their classes, a solver's options
are validated into the solver's typed options object by its options class
(:func:`typed_options`). A failed check raises :func:`refused`, a
``PydanticCustomError`` whose context holds the message and the key path below the
validated value; :func:`error_line` joins the error's location with that path.

Only the file readers import this module, when they first parse a file: neither
``import humanoid_ik`` nor ``humanoid-ik --help`` loads pydantic.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainValidator,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    model_validator,
)
from pydantic_core import PydanticCustomError

from humanoid_ik.config.specs import SolverSpec, takes_collision_pairs
from humanoid_ik.config.toml import NAME, ErrorType, join_key, name_ok, quote_key
from humanoid_ik.core.robot_files import package_problem
from humanoid_ik.errors import MotionError, SolverError, show_value
from humanoid_ik.solvers import SOLVERS
from humanoid_ik.solvers.mink.options import collision_pairs_problem
from humanoid_ik.solvers.options import SolverOptions

__all__ = [
    "Name",
    "Packages",
    "SolverTable",
    "String",
    "Table",
    "checked",
    "error_line",
    "expected",
    "integer",
    "refused",
    "rule",
    "tables",
    "text",
    "typed_options",
    "validate",
]

M = TypeVar("M", bound=BaseModel)


def refused(message: str, at: str = "") -> PydanticCustomError:
    """The error a validator raises: ``message`` (on one line) for the value at key path
    ``at`` below the validated one (``radius``, ``[2]``, ``effectors[1].site``)."""
    message = message.replace("\r", "\\r").replace("\n", "\\n")
    return PydanticCustomError("humanoid_ik", "{message}", {"message": message, "at": at})


def expected(what: str, got: Any, at: str = "") -> PydanticCustomError:
    """:func:`refused` with ``expected <what>, got <got>``."""
    return refused(f"expected {what}, got {show_value(got)}", at)


def error_line(exc: ValidationError, doc: Any) -> tuple[str, str]:
    """The key path and message of ``exc``'s first error in the document ``doc``.

    The location is written as TOML keys (``targets[0].motion.radius``); a part that is
    not a key of ``doc`` but the tag of a union member (the motion ``kind``) is left
    out. An error of pydantic's own reads ``expected <its message>, got <input>``.
    """
    err = exc.errors(include_url=False)[0]
    key, node = "", doc
    for part in err["loc"]:
        if isinstance(part, int):
            key += f"[{part}]"
            node = node[part] if isinstance(node, list) and part < len(node) else None
        elif not (isinstance(node, dict) and part not in node and node.get("kind") == part):
            key = join_key(key, quote_key(part))
            node = node.get(part) if isinstance(node, dict) else None
    ctx = err.get("ctx") or {}
    if "message" not in ctx:
        return key, f"expected {err['msg'].lower()}, got {show_value(err['input'])}"
    at = ctx["at"]
    return (key + at if at.startswith("[") or not at else join_key(key, at)), ctx["message"]


def validate(model: type[M], doc: Any, source: str, error: ErrorType, **context: Any) -> M:
    """``model`` validated from ``doc`` (``context`` for its validators), or
    ``error(source, key, message)`` raised for the first mistake."""
    try:
        return model.model_validate(doc, context=context)
    except ValidationError as exc:
        raise error(source, *error_line(exc, doc)) from None


def rule(what: str, ok: Callable[[Any], bool]) -> BeforeValidator:
    """A field that takes a value when ``ok(value)``, else ``expected <what>``."""

    def check(value: Any) -> Any:
        if not ok(value):
            raise expected(what, value)
        return value

    return BeforeValidator(check)


def checked(fn: Callable[..., Any], **kw: Any) -> PlainValidator:
    """A field checked (and converted) by a check of :mod:`humanoid_ik.core.checks`
    (``check_number``, ``check_int``, ...) with bounds ``kw``: bound and message are
    the check's."""

    def check(value: Any) -> Any:
        try:
            return fn("", value, **kw)
        except MotionError as exc:
            raise expected(exc.expected, exc.got, exc.field) from None

    return PlainValidator(check)


def text(what: str) -> BeforeValidator:
    """A non-empty string, else ``expected <what>``."""
    return rule(what, lambda v: isinstance(v, str) and v != "")


def integer(low: int, high: int | None = None) -> BeforeValidator:
    """A TOML integer (not a float) ``>= low`` and ``<= high``."""
    what = f"an integer >= {low}" + ("" if high is None else f" and <= {high}")
    return rule(what, lambda v: type(v) is int and low <= v and (high is None or v <= high))


def tables(what: str, *, nonempty: bool = True) -> BeforeValidator:
    """An array (of tables; non-empty unless ``nonempty`` is false), else ``expected
    <what>``."""
    return rule(what, lambda v: isinstance(v, list) and (bool(v) or not nonempty))


String = Annotated[str, rule("a string", lambda v: isinstance(v, str))]
Name = Annotated[str, rule(NAME, name_ok)]
"""A :data:`~humanoid_ik.config.toml.NAME` (of a sweep, a target set)."""


def _packages(value: Any, info: ValidationInfo) -> dict[str, Path]:
    """A ``package_path`` table ``{ NAME = "DIR" }`` of ROS package folders
    (``core/robot_files.py``), each an existing folder; a relative ``DIR`` is relative
    to the file's folder (the context's ``base``)."""
    if not isinstance(value, dict):
        raise expected("a table", value)
    out: dict[str, Path] = {}
    for name, folder in value.items():
        if not isinstance(folder, str) or not folder:
            raise expected("a package folder (a string)", folder, quote_key(name))
        path = Path(folder).expanduser()
        path = (
            path if path.is_absolute() else ((info.context or {}).get("base") or Path(".")) / path
        )
        problem = package_problem(str(name), path)
        if problem is not None:
            raise refused(problem, quote_key(name))
        out[str(name)] = path
    return out


Packages = Annotated[dict[str, Path], PlainValidator(_packages)]
"""ROS package folders by name (``package_path``)."""


class Table(BaseModel):
    """A TOML table: no unknown key and every required one present (checked first),
    then each value by its field's type and validators. Subclasses may word the two
    messages (:meth:`unknown`, :meth:`missing`)."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    @classmethod
    def unknown(cls) -> str:
        return f"unknown key; expected one of {', '.join(sorted(cls.model_fields))}"

    @classmethod
    def missing(cls, key: str) -> str:
        return f"missing; expected {cls.model_fields[key].description}"

    @model_validator(mode="before")
    @classmethod
    def _keys(cls, value: Any) -> Any:
        if not isinstance(value, dict):
            raise expected("a table", value)
        for k in value:
            if k not in cls.model_fields:
                raise refused(cls.unknown(), quote_key(k))
        for k, f in cls.model_fields.items():
            if f.is_required() and k not in value:
                raise refused(cls.missing(k), k)
        return value


def typed_options(spec: SolverSpec, at: str = "options") -> SolverOptions:
    """``spec``'s typed options object (:attr:`SolverSpec.typed`), its options class's
    message at key ``at``; a ``collision_pairs`` option's shape is named down to the
    element (``options.collision_pairs[0][1]``, ``solvers/mink/options.py``)."""
    pairs = spec.options.get("collision_pairs")
    problem = None if pairs is None else collision_pairs_problem(pairs)
    if problem is not None and takes_collision_pairs(spec.name):
        where, what, got = problem
        raise expected(what, got, f"{at}.collision_pairs{where}")
    try:
        return spec.typed
    except SolverError as exc:
        raise refused(str(exc), at) from None


class SolverTable(Table):
    """A solver table ``{ name = "dls", options = { ... } }`` (or its name alone),
    validated into a :class:`SolverSpec` and its typed options object (:attr:`spec`)."""

    name: Annotated[
        str, rule(f"one of {', '.join(SOLVERS)}", lambda v: isinstance(v, str) and v in SOLVERS)
    ] = Field(description="a solver name")
    options: Annotated[
        dict[str, Any], rule("a table of solver options", lambda v: isinstance(v, dict))
    ] = {}
    _spec: SolverSpec = PrivateAttr()

    @model_validator(mode="before")
    @classmethod
    def _bare(cls, value: Any) -> Any:
        return {"name": value} if isinstance(value, str) else value

    @model_validator(mode="after")
    def _typed(self) -> SolverTable:
        self._spec = SolverSpec(self.name, self.options)
        typed_options(self._spec)
        return self

    @property
    def spec(self) -> SolverSpec:
        """The solver, its options as given and (:attr:`SolverSpec.typed`) typed."""
        return self._spec
