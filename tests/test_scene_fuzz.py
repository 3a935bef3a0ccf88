"""Scene files and motions under fuzzing: a bad value ends in one line naming the file and
the key (SceneError) or the parameter (MotionError); a value that loads is what the
scene holds, and the scene's first frame runs on its motions; runs are deterministic."""

from __future__ import annotations

import csv
import io
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from humanoid_ik.config.scene import Scene, bundled_scenes_dir, load_scene
from humanoid_ik.config.toml import quote_key
from humanoid_ik.errors import MotionError, SceneError
from humanoid_ik.motion import MOTIONS, Orientation
from humanoid_ik.run.runner import run_scene

BASE = tomllib.loads((bundled_scenes_dir() / "circle.toml").read_text())
FUZZ = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)

leaves = st.one_of(
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
values = st.recursive(
    leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)
"""Any TOML value (TOML has no null)."""
plausible = st.one_of(
    st.floats(0.01, 50.0),
    st.integers(8, 1200).map(lambda n: 2 * n),
    st.booleans(),
    st.sampled_from(
        ["dls", "ccd", "look_at", "reach", "front", "ball", "right_palm_site", "left_palm_site"]
    ),
    st.lists(st.floats(-1.0, 2.0), min_size=3, max_size=3),
)
"""Values a scene key may well accept, so that fuzzed files also load."""
mutations = st.one_of(values, plausible)
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


# ----------------------------------------------------------------------------- writing TOML
def _toml_string(text: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, control characters as \\uXXXX."""
    out = []
    for ch in text:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml(value: Any) -> str:
    """A TOML value for a Python one (tomllib has no writer)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(value), repr(value))
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{" + ", ".join(f"{_toml_string(k)} = {_toml(v)}" for k, v in value.items()) + "}"


def _document(doc: dict[str, Any]) -> str:
    """A TOML document, one top-level key per line."""
    return "".join(f"{_toml_string(k)} = {_toml(v)}\n" for k, v in doc.items() if v is not None)


def _write(tmp_path: Path, doc: dict[str, Any]) -> Path:
    """``doc`` written as ``fuzz.toml``; the file reads back as ``doc`` (NaN included)."""
    text = _document(doc)
    assert _document(tomllib.loads(text)) == text  # the writer, not the scene, is wrong
    path = tmp_path / "fuzz.toml"
    path.write_text(text, encoding="utf-8")
    return path


# ----------------------------------------------------------------------------- checks
def _load(path: Path) -> Scene | SceneError:
    """The scene at ``path``, or its SceneError once checked to be one line naming the file
    (any other exception fails the test)."""
    try:
        return load_scene(path)
    except SceneError as exc:
        text = str(exc)
        assert "\n" not in text and text.startswith(f"{path}: "), text
        assert text.startswith(f"{path}: {exc.key}: " if exc.key else f"{path}: "), text
        return exc


def _names(err: SceneError, *keys: str) -> bool:
    """The error is at one of ``keys`` or inside it (``key.sub``, ``key[i]``)."""
    return any(err.key == k or err.key.startswith((f"{k}.", f"{k}[")) for k in keys)


def _plain(value: Any) -> Any:
    """Tuples, read-only mappings and arrays as lists and dicts, for comparison with TOML."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if hasattr(value, "items"):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _first_frame_runs(scene: Scene) -> None:
    """Frame 0 runs, and each effector's target there is its motion's ``position(0)``."""
    rows = run_scene(scene, frames=1).rows()
    assert len(rows) == len(scene.effectors)
    for row, eff in zip(rows, scene.effectors, strict=True):
        want = scene.target(eff.target).motion.position(0.0)
        got = [row["target_x"], row["target_y"], row["target_z"]]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- scene files
@FUZZ
@given(st.sampled_from(KEYS), mutations)
@example("duration", 0.5)
@example("fps", 1000)
@example("description", "a\nb")
@example("name", "_hidden")
@example("solver", "ccd")
@example("render", {"camera": "front", "trail": 0})
def test_mutated_top_level_key(tmp_path, key, value):
    """A top-level key set to anything: the scene holds it, or a SceneError names the key."""
    doc = dict(BASE)
    doc[key] = value
    out = _load(_write(tmp_path, doc))
    event("SceneError" if isinstance(out, SceneError) else "loaded")
    if isinstance(out, SceneError):
        assert _names(out, quote_key(key)), str(out)
        return
    if key in ("duration", "fps"):
        assert getattr(out, key) == float(value)
    elif key in ("name", "description"):
        assert getattr(out, key) == value
    elif key == "solver":
        assert out.solver.name == (value if isinstance(value, str) else value["name"])
    elif key == "render":
        assert all(_plain(getattr(out.render, k)) == v for k, v in value.items())
    _first_frame_runs(out)


@FUZZ
@given(
    st.sampled_from(["solver", "render", "targets", "effectors"]), st.sampled_from(KEYS), mutations
)
@example("render", "width", 64)
@example("render", "camera", "side")
@example("solver", "options", {})
@example("solver", "name", "ccd")
@example("targets", "name", "other")
@example("targets", "motion", {"kind": "circle", "center": [0.4, -0.3, 1.2], "radius": 0.05})
@example("effectors", "task", "look_at")
@example("effectors", "site", "left_palm_site")
def test_mutated_nested_key(tmp_path, table, key, value):
    """A key in a table or first array entry: the scene holds it, or a SceneError names it."""
    doc = {
        k: (dict(v) if isinstance(v, dict) else [dict(e) for e in v] if isinstance(v, list) else v)
        for k, v in BASE.items()
    }
    doc.setdefault(table, {})
    is_array = isinstance(doc[table], list)
    inner = doc[table][0] if is_array else doc[table]
    inner[key] = value
    out = _load(_write(tmp_path, doc))
    where = f"{table}[0]" if is_array else table
    event("SceneError" if isinstance(out, SceneError) else "loaded")
    if isinstance(out, SceneError):
        # a renamed target leaves the effector's target unknown; another solver may not
        # take the scene's options (circle's restarts = 0)
        also = {
            ("targets", "name"): ("effectors[0].target",),
            ("solver", "name"): ("solver.options",),
        }.get((table, key), ())
        assert _names(out, f"{where}.{quote_key(key)}", *also), str(out)
        return
    holder = {
        "solver": out.solver,
        "render": out.render,
        "targets": out.targets[0],
        "effectors": out.effectors[0],
    }[table]
    held = getattr(holder, key)
    if key == "motion":
        assert held.kind == value["kind"] and held.position(0.0).shape == (3,)
    elif key == "orientation":
        quat = np.asarray(value["quat"], dtype=float)
        np.testing.assert_allclose(held.quat, quat / np.linalg.norm(quat))
    elif key == "solver":
        assert held.name == (value if isinstance(value, str) else value["name"])
    else:
        assert _plain(held) == value
    _first_frame_runs(out)


@FUZZ
@given(st.text(max_size=200))
@example("")
@example('duration = 1\n[[targets]]\nname = "t"')
def test_any_text(tmp_path, text):
    """Any text: not TOML is a SceneError for the file, TOML but not a scene names a key."""
    path = tmp_path / "fuzz.toml"
    path.write_text(text, encoding="utf-8")
    try:
        tomllib.loads(text)
        is_toml = True
    except tomllib.TOMLDecodeError:
        is_toml = False
    out = _load(path)
    if isinstance(out, Scene):
        _first_frame_runs(out)
    elif is_toml:
        assert out.key != "", str(out)
    else:
        assert out.key == "" and ": not valid TOML: " in str(out)


# ----------------------------------------------------------------------------- motions
VALID = {
    "points": {"points": [[0.4, -0.3, 1.2], [0.4, -0.2, 1.3]]},
    "circle": {"center": [0.4, -0.3, 1.2], "radius": 0.1},
    "figure8": {"center": [0.4, -0.3, 1.2], "width": 0.2, "height": 0.1},
    "lissajous": {
        "center": [0.4, -0.3, 1.2],
        "amplitude": [0.05, 0.1, 0.1],
        "frequency": [0.5, 0.25, 0.0],
    },
    "waypoints": {"points": [[0.4, -0.3, 1.2], [0.4, -0.2, 1.3], [0.45, -0.25, 1.1]]},
    "random_walk": {"center": [0.4, -0.3, 1.2], "half_extent": [0.1, 0.1, 0.1]},
    "out_and_back": {"start": [0.4, -0.3, 1.2], "far": [1.2, -0.3, 1.2]},
}
"""A valid parameter set per motion kind."""
finite = st.floats(-2.0, 2.0)
parameter_values = st.one_of(
    values,
    st.lists(finite, min_size=3, max_size=3),
    st.lists(st.lists(finite, min_size=3, max_size=3), min_size=1, max_size=4),
)


def _has_key_with_line_break(value: Any) -> bool:
    """``value`` holds, at any depth, a table with a key containing a line break."""
    if isinstance(value, dict):
        return any("\n" in k or _has_key_with_line_break(v) for k, v in value.items())
    if isinstance(value, list):
        return any(_has_key_with_line_break(v) for v in value)
    return False


def _same(held: Any, value: Any) -> bool:
    """The constructor stored ``value`` (converted: an int as a float, a list as an array)."""
    if isinstance(value, str):
        return held == value
    return np.array_equal(np.asarray(held, dtype=float), np.asarray(value, dtype=float))


def test_valid_parameters_cover_every_kind():
    """The fuzzed base parameters build every registered motion kind."""
    assert set(VALID) == set(MOTIONS)
    for kind, params in VALID.items():
        assert MOTIONS[kind](**params).position(1.0).shape == (3,)


@FUZZ
@given(st.sampled_from(sorted(MOTIONS)), st.data())
def test_mutated_motion_parameter(kind, data):
    """A motion parameter set to anything: stored, or a MotionError names it."""
    cls = MOTIONS[kind]
    name = data.draw(st.sampled_from(cls.parameters()), label="parameter")
    value = data.draw(parameter_values, label="value")
    try:
        motion = cls(**(VALID[kind] | {name: value}))
    except MotionError as exc:
        event("MotionError")
        assert exc.field == name or exc.field.startswith(f"{name}["), exc.field
        assert str(exc).startswith(f"{exc.field}: expected ")
        # one line, but for a value holding a table key with a line break: show_value
        # (errors.py) writes table keys as they are
        assert "\n" not in str(exc) or _has_key_with_line_break(value), str(exc)
        return
    event("built")
    assert _same(getattr(motion, name), value)
    assert motion.position(0.0).shape == (3,)


@FUZZ
@given(st.sampled_from(Orientation.parameters()), parameter_values)
@example("quat", [0.0, 0.0, 0.0, 1.0])
@example("amplitude", 0.2)
def test_mutated_orientation_parameter(name, value):
    """An orientation parameter set to anything: stored, or a MotionError names it."""
    params = {"quat": [1.0, 0.0, 0.0, 0.0], "axis": [0.0, 0.0, 1.0]} | {name: value}
    try:
        orient = Orientation(**params)
    except MotionError as exc:
        assert exc.field == name and str(exc).startswith(f"{name}: expected "), str(exc)
        return
    held = getattr(orient, name)
    if name in ("quat", "axis"):
        v = np.asarray(value, dtype=float)
        np.testing.assert_allclose(held, v / np.linalg.norm(v))
    else:
        assert held == float(value)
    assert np.isclose(np.linalg.norm(orient.quat_at(0.7)), 1.0)


# ----------------------------------------------------------------------------- determinism
def test_same_scene_gives_identical_metrics():
    """Two runs of the seeded random walk give identical metrics but for the solve time."""

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
