"""Scene files under fuzzing end only in the package's own error; runs are deterministic."""

from __future__ import annotations

import csv
import io
import tomllib

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from humanoid_ik import HumanoidIKError
from humanoid_ik.config.scene import bundled_scenes_dir, load_scene
from humanoid_ik.run.runner import run_scene

BASE = tomllib.loads((bundled_scenes_dir() / "circle.toml").read_text())

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
values = st.recursive(
    scalars.filter(lambda v: v is not None),
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)
KEYS = [
    "name",
    "description",
    "duration",
    "fps",
    "model",
    "solver",
    "render",
    "targets",
    "effectors",
    "radius",
    "center",
    "kind",
    "site",
    "target",
    "task",
    "options",
    "camera",
    "width",
    "height",
    "motion",
    "period",
    "normal",
    "unknown",
]


def _toml(value) -> str:
    """A TOML value for a Python one (tomllib has no writer)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(value), repr(value))
    if isinstance(value, str):
        return '"' + value.encode("unicode_escape").decode("ascii").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{" + ", ".join(f'"{k}" = {_toml(v)}' for k, v in value.items()) + "}"


def _document(doc: dict) -> str:
    return "\n".join(f'"{k}" = {_toml(v)}' for k, v in doc.items() if v is not None) + "\n"


def _load(tmp_path, text: str):
    path = tmp_path / "fuzz.toml"
    path.write_text(text)
    try:
        return load_scene(path)
    except HumanoidIKError as exc:
        assert "fuzz.toml" in str(exc)  # the message names the file
        return None


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.sampled_from(KEYS), values)
def test_mutated_scene_ends_in_scene_error(tmp_path, key, value):
    """The circle scene with one top-level key replaced by anything: a scene or SceneError."""
    doc = dict(BASE)
    doc[key] = value
    _load(tmp_path, _document(doc))


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.sampled_from(["solver", "render", "targets", "effectors"]), st.sampled_from(KEYS), values)
def test_mutated_nested_key_ends_in_scene_error(tmp_path, table, key, value):
    """A key inside a table (or the first array entry) set to anything: scene or SceneError."""
    doc = {
        k: (dict(v) if isinstance(v, dict) else [dict(e) for e in v] if isinstance(v, list) else v)
        for k, v in BASE.items()
    }
    doc.setdefault(table, {})
    inner = doc[table][0] if isinstance(doc[table], list) else doc[table]
    inner[key] = value
    _load(tmp_path, _document(doc))


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.text(max_size=200))
def test_any_text_ends_in_scene_error(tmp_path, text):
    """Arbitrary text as a scene file (mostly malformed TOML): a scene or SceneError."""
    _load(tmp_path, text)


def test_same_scene_gives_identical_metrics():
    """Two runs of the seeded random walk give byte-identical metrics, apart from the
    wall-clock solve time."""

    def csv_without_times() -> str:
        text = run_scene("random_walk", frames=40).csv_text()
        rows = list(csv.DictReader(io.StringIO(text)))
        for row in rows:
            row.pop("solve_time_s")
        out = io.StringIO()
        w = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        return out.getvalue()

    a, b = csv_without_times(), csv_without_times()
    assert a == b and len(a.splitlines()) == 41
