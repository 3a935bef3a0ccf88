"""Meshes MuJoCo cannot read and the model cache: the Collada robots of example-robot-data
(iCub, Baxter, Romeo, Kinova) load with converted meshes, upright and in one piece; a
file's unit, up axis and colours are kept and the URDF's scale applied once; heavy
visual meshes are decimated while collision meshes keep their hull; converted meshes
and compiled models come back from the cache, a corrupt entry is rebuilt, and a cached
model is the one ``spec.compile()`` gives."""

from __future__ import annotations

import os
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from humanoid_ik.core import meshes, model_cache
from humanoid_ik.core.meshes import (
    VISUAL_FACES,
    VISUAL_FACES_ENV,
    convert_meshes,
    decimate,
    read_mesh,
)
from humanoid_ik.core.model_cache import CACHE_ENV, compile_cached, read_entry, write_entry
from humanoid_ik.core.models import ModelWarning, load_model, model_spec
from humanoid_ik.errors import ModelError
from tests.robots import robot_file

_MESH = mujoco.mjtGeom.mjGEOM_MESH


# ----------------------------------------------------------------------------- helpers
@pytest.fixture(scope="module")
def module_cache(tmp_path_factory: pytest.TempPathFactory):
    """A cache folder of the module's own (the user's cache is left alone)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(CACHE_ENV, str(tmp_path_factory.mktemp("cache")))
        yield


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder for one test."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(folder))
    return folder


@pytest.fixture()
def conversions(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The files converted from scratch (not served by the cache) during a test."""
    seen: list[Path] = []
    real = meshes._convert

    def counting(path: Path) -> list[meshes.MeshPart]:
        seen.append(path)
        return real(path)

    monkeypatch.setattr(meshes, "_convert", counting)
    return seen


def _drawn(m: mujoco.MjModel) -> list[int]:
    """The mesh geoms that collide with nothing (a URDF's visuals)."""
    return [
        i
        for i in range(m.ngeom)
        if m.geom_type[i] == _MESH and m.geom_contype[i] == 0 and m.geom_conaffinity[i] == 0
    ]


def _colliding(m: mujoco.MjModel) -> list[int]:
    return [i for i in range(m.ngeom) if m.geom_type[i] == _MESH and i not in _drawn(m)]


def _world_vertices(m: mujoco.MjModel, d: mujoco.MjData, geoms: list[int]) -> np.ndarray:
    """The world positions ``(n, 3)`` [m] of the vertices of ``geoms`` at ``d``'s pose."""
    out = [np.zeros((0, 3))]
    for g in geoms:
        mid = m.geom_dataid[g]
        v = m.mesh_vert[m.mesh_vertadr[mid] : m.mesh_vertadr[mid] + m.mesh_vertnum[mid]]
        out.append(v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g])
    return np.concatenate(out)


def _at_qpos0(m: mujoco.MjModel) -> mujoco.MjData:
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return d


def _urdf_counts(path: Path) -> tuple[int, int]:
    """``(<visual> meshes, <collision> meshes)`` of a URDF."""
    root = ET.parse(path).getroot()
    vis = sum(1 for v in root.iter("visual") if v.find("geometry/mesh") is not None)
    col = sum(1 for c in root.iter("collision") if c.find("geometry/mesh") is not None)
    return vis, col


def _collada(path: Path, boxes: list[tuple[list[float], list[float], list[int]]], asset: str):
    """A Collada file of boxes ``(size, centre, rgba 0-255)``, one material each, with the
    ``<asset>`` content ``asset`` (up axis, unit, authoring tool)."""
    parts = []
    for size, centre, rgba in boxes:
        box = trimesh.creation.box(size)
        box.apply_translation(centre)
        box.visual.face_colors = rgba
        parts.append(box)
    text = trimesh.exchange.dae.export_collada(parts)
    text = text.decode() if isinstance(text, bytes) else text
    head, rest = text.split("<asset>", 1)
    rest = rest.split("</asset>", 1)[1]
    path.write_text(f"{head}<asset>{asset}</asset>{rest}")


def _urdf(path: Path, mesh: str, scale: str = "1 1 1", visual_rgba: str | None = None) -> Path:
    """A one-link URDF that shows ``mesh`` (scaled by ``scale``) and collides as a box."""
    material = (
        f'<material name="own"><color rgba="{visual_rgba}"/></material>' if visual_rgba else ""
    )
    path.write_text(
        '<robot name="r"><link name="base"/><link name="l1">'
        '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" '
        'ixz="0" iyz="0"/></inertial>'
        f'<visual><geometry><mesh filename="{mesh}" scale="{scale}"/></geometry>{material}'
        "</visual>"
        '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        "</robot>"
    )
    return path


RED, GREEN = [255, 0, 0, 255], [0, 255, 0, 255]
MM_Y_UP = '<unit name="millimeter" meter="0.001"/><up_axis>Y_UP</up_axis>'


# ----------------------------------------------------------------------------- robots
@pytest.fixture(scope="module")
def icub(module_cache) -> mujoco.MjModel:
    return load_model(robot_file("icub"))


@pytest.fixture(scope="module")
def baxter(module_cache) -> mujoco.MjModel:
    return load_model(robot_file("baxter"))


def test_icub_is_upright_and_in_one_piece(icub):
    """Every iCub mesh is Collada ``Y_UP``: turned to Z up, the robot stands 1.05 m tall
    and 0.23 m wide, and each limb's joint to the next link lies inside the limb's
    visual mesh (ignoring the up axis puts 9 of these 9 joints outside)."""
    m = icub
    vis, col = _urdf_counts(robot_file("icub"))
    assert (len(_drawn(m)), len(_colliding(m))) == (vis, col) == (28, 28)  # one colour each
    d = _at_qpos0(m)
    size = np.ptp(_world_vertices(m, d, _drawn(m)), axis=0)
    assert 1.0 < size[2] < 1.1 and size[0] < 0.3 and size[1] < 0.35, size
    for joint in ("l_knee", "r_knee", "l_ankle_pitch", "r_ankle_pitch", "l_elbow", "r_elbow"):
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
        limb = m.body_parentid[m.jnt_bodyid[j]]
        geoms = [g for g in _drawn(m) if m.geom_bodyid[g] == limb]
        pts = _world_vertices(m, d, geoms)
        lo, hi = pts.min(axis=0) - 0.01, pts.max(axis=0) + 0.01
        assert np.all((lo <= d.xanchor[j]) & (d.xanchor[j] <= hi)), joint


def test_icub_visuals_are_decimated_to_the_budget_and_collisions_kept(icub):
    """iCub's visuals (1.3 MB chest alone) draw at most :data:`VISUAL_FACES` triangles;
    its collision meshes keep every triangle of their files."""
    m = icub
    drawn = sum(int(m.mesh_facenum[m.geom_dataid[g]]) for g in _drawn(m))
    assert 0.5 * VISUAL_FACES < drawn <= VISUAL_FACES
    chest = robot_file("icub").parents[1] / "meshes/upmc/collision"
    want = sum(len(p.faces) for p in read_mesh(chest / "icub_simple_collision_chest.dae"))
    mid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_MESH, "icub_simple_collision_chest")
    assert m.mesh_facenum[mid] == want


def test_a_meshlab_y_up_file_is_not_turned(baxter):
    """Baxter's ``base_link.DAE`` says ``Y_UP`` (MeshLab writes it for every file) but
    holds Z-up data: its converted box is that of the link's ``Z_UP`` collision file."""
    m = baxter
    d = _at_qpos0(m)

    def box(mesh: str) -> np.ndarray:
        geoms = [
            g
            for g in range(m.ngeom)
            if m.geom_type[g] == _MESH
            and mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, m.geom_dataid[g]) == mesh
        ]
        pts = _world_vertices(m, d, geoms)
        return np.array([pts.min(axis=0), pts.max(axis=0)])

    visual, collision = box("base_link"), box("base_link_collision")
    assert np.ptp(visual, axis=0)[2] > 0.9  # the pedestal's column stands up
    np.testing.assert_allclose(visual, collision, atol=0.005)


def test_baxter_keeps_the_colours_of_its_files(baxter):
    """Baxter's URDF gives its visuals no colour; the Collada materials do (red arms,
    grey joints, black parts): a file of several materials is drawn by several geoms."""
    m = baxter
    vis, col = _urdf_counts(robot_file("baxter"))
    assert len(_colliding(m)) == col
    assert len(_drawn(m)) > vis
    colours = {tuple(np.round(m.geom_rgba[g], 2)) for g in _drawn(m)}
    assert len(colours) >= 4
    assert any(r > 0.5 and g < 0.2 and b < 0.2 for r, g, b, _ in colours)  # the red arms


@pytest.mark.parametrize("name", ["romeo", "kinova"])
def test_other_collada_robots_load(name, module_cache):
    """Romeo and Kinova (Collada ``Z_UP``, metres) load: every collision mesh of the URDF
    is one geom, every visual at least one; the arm hangs within its real size."""
    path = robot_file(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # Romeo's inertia is balanced
        m = load_model(path)
    vis, col = _urdf_counts(path)
    assert len(_colliding(m)) == col
    assert len(_drawn(m)) >= vis
    size = np.ptp(_world_vertices(m, _at_qpos0(m), _drawn(m)), axis=0)
    tall = {"romeo": (1.3, 1.5), "kinova": (0.45, 0.55)}[name]
    assert tall[0] < size[2] < tall[1], size


# ----------------------------------------------------------------------------- one file
def test_unit_up_axis_scale_and_two_colours(tmp_path, cache):
    """A millimetre ``Y_UP`` Collada file with a red and a green box, shown at URDF scale
    2: two geoms of the two colours, each box in metres, turned Z up (its y and z sizes
    swap) and scaled once."""
    _collada(
        tmp_path / "two.dae",
        [([100, 200, 300], [0, 0, 0], RED), ([50, 50, 50], [300, 0, 0], GREEN)],
        MM_Y_UP,
    )
    m = load_model(_urdf(tmp_path / "r.urdf", "two.dae", scale="2 2 2"))
    drawn = _drawn(m)
    assert len(drawn) == 2
    d = _at_qpos0(m)
    by_colour = {tuple(np.round(m.geom_rgba[g], 3)): g for g in drawn}
    assert set(by_colour) == {(1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0)}
    red = np.ptp(_world_vertices(m, d, [by_colour[(1.0, 0.0, 0.0, 1.0)]]), axis=0)
    np.testing.assert_allclose(red, [0.2, 0.6, 0.4], atol=1e-5)
    green = _world_vertices(m, d, [by_colour[(0.0, 1.0, 0.0, 1.0)]])
    np.testing.assert_allclose(green.mean(axis=0), [0.6, 0.0, 0.0], atol=1e-5)
    assert len({m.geom_bodyid[g] for g in drawn}) == 1
    assert {int(m.geom_group[g]) for g in drawn} == {int(m.geom_group[drawn[0]])}


def test_a_geom_with_its_own_colour_keeps_it_and_one_mesh(tmp_path, cache):
    """A URDF ``<material>`` colour wins over the file's: one geom, the URDF's colour."""
    _collada(tmp_path / "two.dae", [([1, 1, 1], [0, 0, 0], RED), ([1, 1, 1], [2, 0, 0], GREEN)], "")
    m = load_model(_urdf(tmp_path / "r.urdf", "two.dae", visual_rgba="0 0 1 1"))
    assert [tuple(m.geom_rgba[g]) for g in _drawn(m)] == [(0.0, 0.0, 1.0, 1.0)]


@pytest.mark.parametrize(
    ("name", "asset", "size"),
    [
        (
            "meshlab.dae",
            "<contributor><authoring_tool>VCGLib | MeshLab</authoring_tool>"
            "</contributor><up_axis>Y_UP</up_axis>",
            [1, 2, 3],
        ),
        ("xup.dae", "<up_axis>X_UP</up_axis>", [2, 3, 1]),
        ("box.glb", None, [1, 3, 2]),
        ("box.ply", None, [1, 2, 3]),
    ],
)
def test_each_format_and_up_axis(tmp_path, cache, name, asset, size):
    """A 1 x 2 x 3 box: MeshLab's ``Y_UP`` is not turned, ``X_UP`` puts x up, glTF is
    Y up (turned), PLY is taken as it is."""
    path = tmp_path / name
    if asset is not None:
        _collada(path, [([1, 2, 3], [0, 0, 0], RED)], asset)
    else:
        trimesh.creation.box([1, 2, 3]).export(path)
    (part,) = read_mesh(path)
    np.testing.assert_allclose(np.ptp(part.vertices, axis=0), size, atol=1e-6)
    m = load_model(_urdf(tmp_path / "r.urdf", name))
    assert len(_drawn(m)) == 1


def test_a_file_that_cannot_be_converted_is_one_line(tmp_path, cache):
    (tmp_path / "bad.dae").write_text("<COLLADA><asset><up_axis>Y_UP</up_axis></asset><libr")
    with pytest.raises(ModelError) as err:
        load_model(_urdf(tmp_path / "r.urdf", "bad.dae"))
    msg = str(err.value)
    assert "\n" not in msg and "bad.dae" in msg and "cannot be converted" in msg


# ----------------------------------------------------------------------------- cache
def test_second_conversion_comes_from_the_cache(tmp_path, cache, conversions):
    """The second load converts nothing; a corrupt entry is rebuilt, never trusted."""
    _collada(tmp_path / "two.dae", [([1, 1, 1], [0, 0, 0], RED), ([1, 1, 1], [2, 0, 0], GREEN)], "")
    urdf = _urdf(tmp_path / "r.urdf", "two.dae")
    first = load_model(urdf)
    assert len(conversions) == 1
    second = load_model(urdf)
    assert len(conversions) == 1
    np.testing.assert_array_equal(first.mesh_vert, second.mesh_vert)
    entries = [p for p in (cache / "meshes").iterdir() if p.suffix == ".npz"]
    assert len(entries) == 1
    entries[0].write_bytes(entries[0].read_bytes()[:-100])  # truncated
    third = load_model(urdf)
    assert len(conversions) == 2
    np.testing.assert_array_equal(first.mesh_vert, third.mesh_vert)
    assert read_entry("meshes", entries[0].name) is not None  # rebuilt


def test_an_unwritable_cache_only_means_no_caching(tmp_path, monkeypatch, conversions):
    """A cache folder under a file: every load converts again, with one note."""
    (tmp_path / "file").write_text("")
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "file" / "cache"))
    monkeypatch.setattr(model_cache, "_warned", set())
    _collada(tmp_path / "one.dae", [([1, 1, 1], [0, 0, 0], RED)], "")
    urdf = _urdf(tmp_path / "r.urdf", "one.dae")
    with pytest.warns(ModelWarning, match="cannot be written") as notes:
        load_model(urdf)
        load_model(urdf)
    assert len(conversions) == 2
    assert len([n for n in notes if issubclass(n.category, ModelWarning)]) == 1


def _all_arrays_equal(a: mujoco.MjModel, b: mujoco.MjModel) -> list[str]:
    """The names of the ``MjModel`` arrays that differ between ``a`` and ``b``."""
    differ = []
    for name in dir(a):
        if name.startswith("_"):
            continue
        x = getattr(a, name)
        if isinstance(x, np.ndarray) and not np.array_equal(x, getattr(b, name), equal_nan=True):
            differ.append(name)
    return differ


@pytest.fixture(scope="module")
def kinova_spec_path(module_cache) -> Path:
    return robot_file("kinova")


def test_compile_cached_is_spec_compile(kinova_spec_path, cache):
    """Kinova's model from the cache equals ``spec.compile()`` array by array (sizes,
    names, ``qpos0``, geom sizes, mesh vertices); an edit of the spec is another entry,
    never the old model."""
    path = kinova_spec_path
    plain = model_spec(path).compile()
    first = compile_cached(model_spec(path), path)
    assert len(list((cache / "models").glob("*.mjb"))) == 1
    again = compile_cached(model_spec(path), path)
    for m in (first, again):
        for size in ("nq", "nbody", "ngeom", "nmesh", "nmeshvert"):
            assert getattr(m, size) == getattr(plain, size), size
        assert bytes(m.names) == bytes(plain.names)
        assert _all_arrays_equal(m, plain) == []
    edited = model_spec(path)
    edited.geoms[0].rgba = [0.1, 0.2, 0.3, 1.0]
    changed = compile_cached(edited, path)
    np.testing.assert_allclose(changed.geom_rgba[0], [0.1, 0.2, 0.3, 1.0])
    assert len(list((cache / "models").glob("*.mjb"))) == 2


def test_a_corrupt_model_entry_is_rebuilt(kinova_spec_path, cache):
    path = kinova_spec_path
    plain = compile_cached(model_spec(path), path)
    (entry,) = (cache / "models").glob("*.mjb")
    data = bytearray(entry.read_bytes())
    data[len(data) // 2] ^= 0xFF
    entry.write_bytes(bytes(data))
    rebuilt = compile_cached(model_spec(path), path)
    assert _all_arrays_equal(rebuilt, plain) == []
    assert entry.read_bytes() != bytes(data)


def test_a_compile_failure_passes_through_unchanged(tmp_path, cache):
    """MuJoCo's ``ValueError`` comes out as it is, the first time and from the cache."""
    stl = tmp_path / "big.stl"
    trimesh.creation.icosphere(subdivisions=6).export(stl)  # 1.6 MB: worth caching
    spec = mujoco.MjSpec()
    spec.add_mesh(name="m", file=str(stl))
    spec.worldbody.add_geom(type=_MESH, meshname="nothere")
    with pytest.raises(ValueError) as first:
        spec.compile()
    for _ in range(2):
        with pytest.raises(ValueError) as cached:
            compile_cached(spec, stl)
        assert str(cached.value) == str(first.value)
    assert len(list((cache / "models").glob("*.mjb"))) == 1


def test_a_cheap_model_is_not_cached(cache):
    """The bundled humanoid (no meshes) compiles directly: nothing is written."""
    spec = model_spec(None)
    m = compile_cached(spec, Path("scene.xml"))
    assert m.nq == model_spec(None).compile().nq
    assert not (cache / "models").exists()


# ----------------------------------------------------------------------------- budget
def test_decimate_keeps_the_shape():
    """A 20480-triangle unit sphere decimated to 2000: at most 2000 triangles, at least
    1000, every vertex within 2% of the sphere."""
    sphere = trimesh.creation.icosphere(subdivisions=5)
    v, f = decimate(sphere.vertices, sphere.faces, 2000)
    assert 1000 <= len(f) <= 2000
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=0.02)
    assert f.max() < len(v)


def test_a_heavy_mesh_is_decimated_for_drawing_only(tmp_path, cache, monkeypatch):
    """One STL shown and colliding: the visual geom draws a copy within the budget, the
    collision geom the whole file (so its convex hull is the file's)."""
    stl = tmp_path / "sphere.stl"
    sphere = trimesh.creation.icosphere(subdivisions=5)
    sphere.export(stl)
    text = _urdf(tmp_path / "r.urdf", "sphere.stl").read_text()
    text = text.replace('<box size="0.1 0.1 0.1"/>', '<mesh filename="sphere.stl"/>')
    (tmp_path / "r.urdf").write_text(text)
    monkeypatch.setenv(VISUAL_FACES_ENV, "1000")
    m = load_model(tmp_path / "r.urdf")
    (shown,), (hit,) = _drawn(m), _colliding(m)
    assert m.mesh_facenum[m.geom_dataid[shown]] <= 1000
    assert m.mesh_facenum[m.geom_dataid[hit]] == len(sphere.faces)
    monkeypatch.setenv(VISUAL_FACES_ENV, "0")  # never decimate
    m = load_model(tmp_path / "r.urdf")
    assert m.geom_dataid[_drawn(m)[0]] == m.geom_dataid[_colliding(m)[0]]


def test_a_bad_face_budget_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv(VISUAL_FACES_ENV, "many")
    spec = mujoco.MjSpec()
    with pytest.raises(ModelError, match=f"{VISUAL_FACES_ENV}='many'.*whole number >= 0"):
        convert_meshes(spec)


def test_the_least_recently_used_entries_go_past_the_limit(cache):
    """Past the limit, the oldest entries (by last use) are removed with their checksum
    files; a newer one that fits stays."""
    for i, kind in enumerate(("models", "meshes", "models")):
        write_entry(kind, f"e{i}", bytes(1000))
        os.utime(cache / kind / f"e{i}", (1000 + i, 1000 + i))
    assert read_entry("models", "e0") is not None  # a use: the newest now
    model_cache._prune(cache, 2000)
    assert sorted(p.name for p in cache.rglob("e*")) == ["e0", "e0.sha256", "e2", "e2.sha256"]
