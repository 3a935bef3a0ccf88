"""The typed model of a sweep file, :class:`SweepFile` (pydantic): its keys, defaults
and bounds, each ``solvers`` entry expanded into its configurations, every one validated
into the solver's typed options object. Loading the scenes and models it names is
``config/sweep_file.py``'s."""

from __future__ import annotations

import itertools
import math
from typing import Annotated, Any

from pydantic import BeforeValidator, Field, PrivateAttr, model_validator
from pydantic_core import PydanticCustomError

from humanoid_ik.config.placement import LIMBS
from humanoid_ik.config.schema import (
    Name,
    Packages,
    SolverTable,
    String,
    Table,
    checked,
    expected,
    integer,
    refused,
    rule,
    tables,
    text,
    typed_options,
)
from humanoid_ik.config.specs import MAX_JOBS, SolverSpec
from humanoid_ik.config.toml import NAME
from humanoid_ik.core.checks import MAX_TARGETS, check_bool, check_choice
from humanoid_ik.core.types import TARGET_KINDS

__all__ = ["SweepFile"]


def _grid(value: Any) -> Any:
    if not isinstance(value, dict):
        raise expected("a table of option name -> non-empty list of values", value)
    for opt, values in value.items():
        if not isinstance(values, list) or not values:
            raise expected("a non-empty list of values", values, str(opt))
    return value


class SweepSolver(SolverTable):
    """A ``solvers`` entry: fixed ``options`` and an option ``grid``, one configuration
    per combination of the grid's values (:attr:`configs`)."""

    grid: Annotated[dict[str, list[Any]], BeforeValidator(_grid)] = {}
    _configs: list[SolverSpec] = PrivateAttr()

    @model_validator(mode="after")
    def _expand(self) -> SweepSolver:
        for opt in self.grid:
            if opt in self.options:
                raise refused("also given in options; give it in one place", f"grid.{opt}")
        if math.prod(len(v) for v in self.grid.values()) > MAX_JOBS:
            raise refused(f"expected at most {MAX_JOBS} configurations (one job each)", "grid")
        self._configs = []
        for combo in itertools.product(*[[(k, v) for v in vs] for k, vs in self.grid.items()]):
            spec = SolverSpec(self.name, {**self.options, **dict(combo)})
            try:
                typed_options(spec)
            except PydanticCustomError as exc:  # at the grid key the message names
                message = (exc.context or {})["message"]
                bad = next((k for k, _ in combo if f"'{k}'" in message), None)
                if bad is None:
                    raise
                raise refused(message, f"grid.{bad}") from None
            self._configs.append(spec)
        return self

    @property
    def configs(self) -> list[SolverSpec]:
        return self._configs


class SceneEntry(Table):
    """A ``[[scenes]]`` entry (or the scene alone)."""

    scene: Annotated[str, text("a bundled scene's name or a scene file")] = Field(
        description="a bundled scene's name or a scene file"
    )
    frames: Any = None  # an integer up to the scene's own limit (config/sweep_file.py)

    @model_validator(mode="before")
    @classmethod
    def _bare(cls, value: Any) -> Any:
        return {"scene": value} if isinstance(value, str) else value


def _names(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(j, str) and j for j in v)


class TargetSetEntry(Table):
    """A ``[[targets]]`` entry: a seeded target set on one chain."""

    name: Name = Field(description=NAME)
    task: Annotated[str, checked(check_choice, valid=TARGET_KINDS)] = "pose"
    n: Annotated[int, integer(1, MAX_TARGETS)] = Field(description="an integer >= 1")
    site: Annotated[str, text("a site name")] | None = None
    body: Annotated[str, text("a body name (instead of site)")] | None = None
    limb: Annotated[str, checked(check_choice, valid=LIMBS)] | None = None
    torso: Annotated[bool, checked(check_bool)] = False
    model: Annotated[str, text("an MJCF or URDF path (relative to the sweep file)")] | None = None
    joints: Annotated[list[str], rule("a list of joint names", _names)] | None = None

    @model_validator(mode="after")
    def _one_end(self) -> TargetSetEntry:
        given = [k for k in ("site", "body", "limb") if getattr(self, k) is not None]
        if len(given) > 1:
            raise refused(f"expected one of site, body or limb, got {', '.join(given)}", given[-1])
        if self.limb is not None and self.joints is not None:
            raise refused(
                "expected no joints with limb (the limb's joints are found from the model)",
                "joints",
            )
        if self.torso and self.limb is None:
            raise refused("expected torso = true only with limb", "torso")
        return self


def _seeds(value: Any) -> Any:
    if not isinstance(value, list) or not value:
        raise expected("a non-empty list of integers >= 0", value)
    for i, s in enumerate(value):
        if type(s) is not int or s < 0:
            raise expected("an integer >= 0", s, f"[{i}]")
        if s in value[:i]:
            raise refused(f"seed {s} given twice", f"[{i}]")
    return value


SOLVERS = "a non-empty list of solver names or tables [[solvers]] with name"


class SweepFile(Table):
    """A sweep file (``docs/sweeps.md``, ``config/sweep_file.py``)."""

    name: Name
    description: String = ""
    seeds: Annotated[list[int], BeforeValidator(_seeds)] = [0]
    package_path: Packages = {}
    solvers: Annotated[list[SweepSolver], tables(SOLVERS)] = Field(description=SOLVERS)
    scenes: Annotated[
        list[SceneEntry], tables("a list of tables [[scenes]] with scene", nonempty=False)
    ] = []
    targets: Annotated[
        list[TargetSetEntry], tables("a list of tables [[targets]] with name and n", nonempty=False)
    ] = []

    @model_validator(mode="after")
    def _sizes(self) -> SweepFile:
        count = 0
        for i, entry in enumerate(self.solvers):
            count += len(entry.configs)
            if count > MAX_JOBS:
                raise refused(
                    f"expected at most {MAX_JOBS} configurations (one job each)",
                    f"solvers[{i}].grid",
                )
        if not self.scenes and not self.targets:
            raise refused("no scenes and no targets; give [[scenes]] or [[targets]]", "scenes")
        return self

    @property
    def configs(self) -> list[SolverSpec]:
        """Every solver configuration, in file order."""
        return [c for entry in self.solvers for c in entry.configs]
