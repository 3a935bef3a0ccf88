"""Robot files as ROS ships them: the original ``package://`` URDFs of example-robot-data
load with no edit and no flag; a copy elsewhere loads with ``--package-path`` (or
``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``) and fails without in one line; xacro files
expand; visual geoms are drawn, collision geoms collide and are hidden; the loader
fixes a non-physical inertia with a note and handles a floating base from any root link;
model digests follow the meshes a URDF finds through its packages."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, ModelError, SceneError
from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene
from humanoid_ik.config.sweep_file import load_sweep
from humanoid_ik.core.model_files import model_digest, model_files
from humanoid_ik.core.models import (
    COLLISION_GROUP,
    VISUAL_GROUP,
    ModelWarning,
    load_model,
)
from humanoid_ik.core.robot_files import PackageIndex
from humanoid_ik.errors import SweepError
from tests.processes import virtual_display
from tests.robots import PACKAGE, SHARE, robot_file

ERD = "example-robot-data"
"""The ROS package the example-robot-data URDFs name."""


# ----------------------------------------------------------------------------- helpers
def _rpy(rpy: list[float]) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw as a rotation matrix ``Rz @ Ry @ Rx``."""
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _urdf_link_positions(text: str) -> dict[str, np.ndarray]:
    """Every link's world position [m] at zero joint angles, from the URDF's joint
    origins alone (the root link at the origin): FK independent of MuJoCo."""
    root = ET.fromstring(text)
    joints = {j.find("child").get("link"): j for j in root.findall("joint")}
    frames: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def frame(link: str) -> tuple[np.ndarray, np.ndarray]:
        if link not in frames:
            j = joints.get(link)
            if j is None:
                frames[link] = (np.eye(3), np.zeros(3))
            else:
                rot, pos = frame(j.find("parent").get("link"))
                o = j.find("origin")
                xyz = [
                    float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()
                ]
                rpy = [
                    float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()
                ]
                frames[link] = (rot @ _rpy(rpy), pos + rot @ np.array(xyz))
        return frames[link]

    return {link.get("name"): frame(link.get("name"))[1] for link in root.findall("link")}


def _counts(path: Path) -> tuple[int, int]:
    """``(<visual> count, <collision> count)`` of a URDF's links."""
    root = ET.parse(path).getroot()
    return len(root.findall("link/visual")), len(root.findall("link/collision"))


def _cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "humanoid_ik", *args],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        check=False,
    )


def _copy_so100(tmp_path: Path) -> Path:
    """The SO-100 arm's URDF alone, copied out of its package (its meshes stay there)."""
    dst = tmp_path / "so100.urdf"
    shutil.copy(robot_file("so100"), dst)
    return dst


def _tetra_stl(path: Path, size: float) -> None:
    """A binary STL of a tetrahedron with legs ``size`` [m] along x, y and z."""
    import struct

    v = [(0, 0, 0), (size, 0, 0), (0, size, 0), (0, 0, size)]
    data = bytearray(b"\0" * 80 + struct.pack("<I", 4))
    for f in [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]:
        data += struct.pack("<3f", 0, 0, 0)
        for k in f:
            data += struct.pack("<3f", *v[k])
        data += struct.pack("<H", 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(bytes(data))


def _mesh_span(m: mujoco.MjModel) -> float:
    """The largest distance [m] between two vertices of the model's first mesh (MuJoCo
    moves a mesh into its inertial frame; distances stay): ``size * sqrt(2)`` for
    :func:`_tetra_stl`."""
    v = m.mesh_vert[m.mesh_vertadr[0] : m.mesh_vertadr[0] + m.mesh_vertnum[0]]
    return float(np.linalg.norm(v[:, None, :] - v[None, :, :], axis=-1).max())


_INERTIAL = (
    '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" '
    'ixz="0" iyz="0"/></inertial>'
)


def _arm_urdf(mesh: str, name: str = "arm") -> str:
    """A one-hinge arm whose link collides through ``mesh`` and shows a box."""
    return (
        f'<robot name="{name}">\n  <link name="base"/>\n'
        f'  <link name="l1">{_INERTIAL}<visual><geometry><box size="0.1 0.1 0.1"/></geometry>'
        f'</visual><collision><geometry><mesh filename="{mesh}"/></geometry></collision></link>\n'
        '  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n</robot>\n'
    )


# ----------------------------------------------------------------------------- originals
@pytest.fixture(scope="module")
def g1() -> mujoco.MjModel:
    return load_model(robot_file("g1"))


@pytest.fixture(scope="module")
def talos() -> mujoco.MjModel:
    return load_model(robot_file("talos"))


@pytest.mark.parametrize("name", ["g1", "talos", "panda", "ur5", "romeo", "kinova", "baxter"])
def test_original_urdf_loads_as_it_comes(name, request):
    """Humanoids and arms load from their package:// URDFs with no flag: every link a
    body where the URDF's joint origins put it, one collision geom per <collision>, and
    a visual geom per <visual> (STL meshes), or more (a Collada mesh of several
    materials is one geom per material)."""
    m = request.getfixturevalue(name) if name in ("g1", "talos") else load_model(robot_file(name))
    path = robot_file(name)
    text = path.read_text()
    visuals, collisions = _counts(path)
    assert np.sum(m.geom_group == COLLISION_GROUP) == collisions
    if "dae" in text.lower():
        assert np.sum(m.geom_group == VISUAL_GROUP) >= visuals
    else:
        assert np.sum(m.geom_group == VISUAL_GROUP) == visuals
    assert m.ngeom == np.sum(m.geom_group == VISUAL_GROUP) + collisions
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    expected = _urdf_link_positions(text)
    expected.pop("world", None)  # a link called world is MuJoCo's world body
    bodies = {m.body(i).name: i for i in range(1, m.nbody)}
    assert set(bodies) == set(expected)
    for link, pos in expected.items():
        np.testing.assert_allclose(d.xpos[bodies[link]], pos, atol=1e-9, err_msg=link)


def test_g1_geoms_match_its_urdf(g1):
    """G1 (71 geoms: 35 visual, 36 collision): visuals collide with nothing, collisions
    collide; the URDF's materials colour the visuals (dark 0.2 and white 0.7 greys)."""
    assert g1.ngeom == 71
    vis = g1.geom_group == VISUAL_GROUP
    col = g1.geom_group == COLLISION_GROUP
    assert vis.sum() == 35 and col.sum() == 36
    assert np.all(g1.geom_contype[vis] == 0) and np.all(g1.geom_conaffinity[vis] == 0)
    assert np.all(g1.geom_contype[col] == 1) and np.all(g1.geom_conaffinity[col] == 1)
    greys = {round(float(v), 2) for v in g1.geom_rgba[vis, 0]}
    assert greys == {0.2, 0.7}


def test_renders_show_the_visuals_and_hide_the_collisions(g1):
    """A 64x48 segmentation render of G1 at home shows only visual geoms (MuJoCo draws
    groups 0-2 by default); switching group 3 on shows collision geoms too."""
    d = mujoco.MjData(g1)
    mujoco.mj_forward(g1, d)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = [0.0, 0.0, 0.0]
    cam.distance, cam.azimuth, cam.elevation = 2.2, 180.0, -10.0
    opt = mujoco.MjvOption()
    with mujoco.Renderer(g1, 48, 64) as r:
        r.enable_segmentation_rendering()
        r.update_scene(d, cam, opt)
        seen = _geoms_seen(r.render())
        opt.geomgroup[COLLISION_GROUP] = 1
        r.update_scene(d, cam, opt)
        seen_all = _geoms_seen(r.render())
    assert len(seen) >= 10
    assert all(g1.geom_group[g] == VISUAL_GROUP for g in seen)
    assert any(g1.geom_group[g] == COLLISION_GROUP for g in seen_all)


def test_panda_renders_white_and_black():
    """The Panda's visual meshes (Collada) keep their materials: its visual geoms are
    white and near-black, and the robot's pixels in a 64x48 render are bright and dark
    (a robot left in MuJoCo's default grey has no pixel brighter than 110)."""
    m = load_model(robot_file("panda"))
    vis = m.geom_group == VISUAL_GROUP
    grey = m.geom_rgba[vis, :3].mean(axis=1)
    assert grey.max() > 0.85 and grey.min() < 0.3
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = [0.0, 0.0, 0.45]
    cam.distance, cam.azimuth, cam.elevation = 1.6, 150.0, -15.0
    with mujoco.Renderer(m, 48, 64) as r:
        r.update_scene(d, cam)
        rgb = r.render().astype(float)
        r.enable_segmentation_rendering()
        r.update_scene(d, cam)
        robot = r.render()[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
    shade = rgb[robot].mean(axis=1)  # the headlight alone: white shows about 130 of 255
    assert robot.sum() >= 150
    assert (shade > 110).sum() > 30 and (shade < 50).sum() > 10  # all MuJoCo grey: 0 > 110


def _geoms_seen(seg: np.ndarray) -> set[int]:
    ids, types = seg[..., 0], seg[..., 1]
    return {int(i) for i in np.unique(ids[types == int(mujoco.mjtObj.mjOBJ_GEOM)])}


def test_mimic_joints_are_equality_constraints_and_continuous_joints_unlimited(talos):
    """Talos's 12 <mimic> joints are joint equalities with the URDF's multiplier and
    offset; PR2's 4 continuous joints are unlimited hinges."""
    root = ET.parse(robot_file("talos")).getroot()
    mimics = {
        j.get("name"): j.find("mimic") for j in root.findall("joint") if j.find("mimic") is not None
    }
    assert talos.neq == len(mimics) == 12
    for i in range(talos.neq):
        assert talos.eq_type[i] == mujoco.mjtEq.mjEQ_JOINT
        mimic = mimics[talos.joint(talos.eq_obj1id[i]).name]
        assert talos.joint(talos.eq_obj2id[i]).name == mimic.get("joint")
        offset, multiplier = float(mimic.get("offset", 0)), float(mimic.get("multiplier", 1))
        np.testing.assert_allclose(talos.eq_data[i][:2], [offset, multiplier])
    pr2_root = ET.parse(robot_file("pr2")).getroot()
    continuous = {j.get("name") for j in pr2_root.findall("joint") if j.get("type") == "continuous"}
    with pytest.warns(ModelWarning):
        pr2 = load_model(robot_file("pr2"))
    assert len(continuous) == 4
    for name in continuous:
        assert pr2.joint(name).type == mujoco.mjtJoint.mjJNT_HINGE
        assert not pr2.jnt_limited[pr2.joint(name).id]


# ----------------------------------------------------------------------------- packages
def test_a_copy_fails_in_one_line_then_loads_with_its_package_path(tmp_path):
    """The SO-100 URDF copied out of its package: the error names the URI, the places
    looked in and --package-path; with the package's folder it loads as the original."""
    copy = _copy_so100(tmp_path)
    with pytest.raises(ModelError) as exc:
        load_model(copy)
    msg = str(exc.value)
    assert "\n" not in msg
    assert f"mesh 'package://{ERD}/robots/so_arm_description/meshes/so100/" in msg
    assert "ROS_PACKAGE_PATH" in msg and "AMENT_PREFIX_PATH" in msg and str(tmp_path) in msg
    assert f"--package-path {ERD}=DIR" in msg
    original = load_model(robot_file("so100"))
    m = load_model(copy, packages={ERD: PACKAGE})
    assert m.nmesh == original.nmesh and m.ngeom == original.ngeom == 18
    np.testing.assert_array_equal(m.mesh_vert, original.mesh_vert)


@pytest.mark.parametrize("variable", ["ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"])
def test_a_copy_loads_through_the_environment(tmp_path, monkeypatch, variable):
    """ROS_PACKAGE_PATH (a folder holding the package, or the package itself) and
    AMENT_PREFIX_PATH (PREFIX/share/NAME) each find the copy's meshes."""
    copy = _copy_so100(tmp_path)
    values = [str(SHARE), str(PACKAGE)] if variable == "ROS_PACKAGE_PATH" else [str(SHARE.parent)]
    for value in values:
        monkeypatch.setenv(variable, f"{tmp_path}{os.pathsep}{value}")
        assert load_model(copy).ngeom == 18  # its 13 <visual> and 5 <collision>


def test_package_found_by_its_package_xml_name_a_sibling_or_share(tmp_path):
    """Above the URDF: a folder whose package.xml names the package (whatever the
    folder is called), a package folder beside an ancestor (a source workspace), and
    share/NAME beside an ancestor (an install)."""
    ws = tmp_path / "ws" / "src"
    (ws / "arm_description").mkdir(parents=True)
    (ws / "arm_description" / "package.xml").write_text("<package><name>my_arm</name></package>")
    _tetra_stl(ws / "arm_description" / "meshes" / "a.stl", 0.1)
    _tetra_stl(ws / "arm_meshes" / "b.stl", 0.2)
    _tetra_stl(tmp_path / "share" / "arm_parts" / "c.stl", 0.3)
    urdf = ws / "arm_description" / "urdf" / "arm.urdf"
    urdf.parent.mkdir()
    for uri, size in [
        ("package://my_arm/meshes/a.stl", 0.1),
        ("package:///arm_meshes/b.stl", 0.2),
        ("package://arm_parts/c.stl", 0.3),
    ]:
        urdf.write_text(_arm_urdf(uri))
        m = load_model(urdf)
        assert m.nmesh == 1
        assert _mesh_span(m) == pytest.approx(size * math.sqrt(2), rel=1e-6), uri


def test_explicit_package_path_comes_first_and_file_uris_load(tmp_path):
    """--package-path wins over a package found above the file; a file:// URI and a
    relative path are files (relative to the URDF's folder)."""
    pkg = tmp_path / "arm"
    _tetra_stl(pkg / "m.stl", 0.1)
    other = tmp_path / "elsewhere"
    _tetra_stl(other / "m.stl", 0.4)
    urdf = pkg / "arm.urdf"
    urdf.write_text(_arm_urdf("package://arm/m.stl"))
    index = PackageIndex(urdf, {"arm": other})
    assert index.resolve("package://arm/m.stl") == (other / "m.stl").resolve()
    for uri in ["package://arm/m.stl", "package:///arm/m.stl", "package:/arm/m.stl"]:
        assert PackageIndex(urdf).resolve(uri) == (pkg / "m.stl").resolve()
    for uri in [(other / "m.stl").as_uri(), "../elsewhere/m.stl"]:
        urdf.write_text(_arm_urdf(uri))
        assert _mesh_span(load_model(urdf)) == pytest.approx(0.4 * math.sqrt(2), rel=1e-6)


def test_bad_package_paths_are_one_line():
    """A package name that is not one, and a folder that does not exist."""
    with pytest.raises(ModelError, match=r"'a b' is not a package name"):
        load_model(robot_file("so100"), packages={"a b": PACKAGE})
    with pytest.raises(ModelError, match=r"folder '/nonexistent/x' does not exist"):
        load_model(robot_file("so100"), packages={ERD: Path("/nonexistent/x")})


# ----------------------------------------------------------------------------- xacro
def test_xacro_with_an_include_a_property_and_find_loads(tmp_path):
    """A .urdf.xacro that includes a macro file through $(find PKG), sets a property and
    names a package:// mesh: expanded, found and compiled; the included file is one of
    the model's files, so editing it changes the digest."""
    pkg = tmp_path / "my_arm"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>my_arm</name></package>")
    _tetra_stl(pkg / "meshes" / "l.stl", 0.1)
    macro = pkg / "urdf" / "link.xacro"
    macro.write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:macro name="arm_link" params="name length">\n'
        f'    <link name="${{name}}">{_INERTIAL}\n'
        '      <visual><geometry><cylinder radius="0.03" length="${length}"/></geometry></visual>\n'
        '      <collision><geometry><mesh filename="package://my_arm/meshes/l.stl"/></geometry>'
        "</collision>\n    </link>\n  </xacro:macro>\n</robot>\n"
    )
    main_file = pkg / "urdf" / "arm.urdf.xacro"
    main_file.write_text(
        '<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:property name="upper" value="0.4"/>\n'
        '  <xacro:include filename="$(find my_arm)/urdf/link.xacro"/>\n'
        '  <link name="base"/>\n  <xacro:arm_link name="upper_arm" length="${upper}"/>\n'
        '  <joint name="shoulder" type="revolute"><parent link="base"/>'
        '<child link="upper_arm"/><axis xyz="0 1 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>\n'
        '  <link name="hand"/>\n  <joint name="wrist" type="fixed"><parent link="upper_arm"/>'
        '<child link="hand"/><origin xyz="0 0 ${upper * 2}"/></joint>\n</robot>\n'
    )
    m = load_model(main_file)
    assert m.nmesh == 1 and list(m.geom_group) == [VISUAL_GROUP, COLLISION_GROUP]
    assert m.geom_size[0][1] == pytest.approx(0.2)  # the cylinder's half length: 0.4 / 2
    chain = Chain(m, body="hand")
    np.testing.assert_allclose(chain.fk([0.0])[0], [0, 0, 0.8], atol=1e-12)
    np.testing.assert_allclose(chain.fk([math.pi / 2])[0], [0.8, 0, 0], atol=1e-12)
    files = model_files(main_file)
    assert files == [main_file.resolve(), macro.resolve(), (pkg / "meshes" / "l.stl").resolve()]
    before = model_digest(main_file)
    macro.write_text(macro.read_text().replace('radius="0.03"', 'radius="0.04"'))
    assert model_digest(main_file) != before


def test_xacro_mistake_is_one_line(tmp_path):
    """An undefined property: one line naming the file."""
    p = tmp_path / "bad.urdf.xacro"
    p.write_text(
        '<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<link name="a"><visual><geometry><box size="${nope} 1 1"/></geometry></visual></link>'
        "</robot>"
    )
    with pytest.raises(ModelError) as exc:
        load_model(p)
    assert "\n" not in str(exc.value) and f"xacro file '{p}' does not expand" in str(exc.value)
    assert "nope" in str(exc.value)


# ----------------------------------------------------------------------------- loader fixes
def test_a_non_physical_inertia_is_balanced_with_a_note(capsys):
    """PR2's sensor_mount_link breaks A + B >= C: the model loads with balanceinertia
    and one note naming the link and the compiler flag, printed once by the CLI."""
    with pytest.warns(ModelWarning, match=r"link 'sensor_mount_link'.*balanceinertia") as rec:
        m = load_model(robot_file("pr2"))
    assert len([r for r in rec if "balanceinertia" in str(r.message)]) == 1 and m.nbody == 83
    code = main(["inspect", "--model", str(robot_file("pr2")), "--json"])
    out, err = capsys.readouterr()
    notes = [line for line in err.splitlines() if line.startswith("humanoid-ik: note: ")]
    assert code == 0 and json.loads(out)["counts"]["bodies"] == 83
    assert len([n for n in notes if "balanceinertia" in n]) == 1
    assert len(notes) == 2 and "10 joint(s) kept as equality constraints" in " ".join(notes)


@pytest.mark.parametrize(
    ("urdf", "note"),
    [
        (
            "tiago_description/robots/tiago_no_hand.urdf",
            r"link 'base_antenna_left_link' has an <inertia> that is not positive definite",
        ),
        ("alex_description/urdf/alex_nub_hands.urdf", r"mesh 'nub' encloses no volume"),
    ],
)
def test_other_mistakes_mujoco_refuses_are_fixed_with_a_note(urdf, note):
    """TIAGo's antenna inertias are not positive definite (their diagonal is kept), Alex's
    'nub' mesh is an open surface (a shell's inertia): each loads, with a note."""
    with pytest.warns(ModelWarning, match=note):
        m = load_model(PACKAGE / "robots" / urdf)
    assert m.nbody > 30


def test_floating_base_from_a_named_root_link(tmp_path):
    """base_link -> (floating) -> pelvis -> (revolute) -> arm -> (fixed) -> hand: the
    free joint is at the top level (the dummy root fused into the world), the other
    links stay bodies, and FK follows both the floating base and the hinge."""
    p = tmp_path / "floating.urdf"
    p.write_text(
        '<robot name="f">\n  <link name="base_link"/>\n'
        f'  <link name="pelvis">{_INERTIAL}<collision><geometry><box size="0.2 0.2 0.2"/>'
        "</geometry></collision></link>\n"
        '  <joint name="root" type="floating"><parent link="base_link"/>'
        '<child link="pelvis"/><origin xyz="0 0 1"/></joint>\n'
        f'  <link name="arm">{_INERTIAL}</link>\n'
        '  <joint name="shoulder" type="revolute"><parent link="pelvis"/><child link="arm"/>'
        '<origin xyz="0 0.2 0"/><axis xyz="0 1 0"/>'
        '<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>\n'
        '  <link name="hand"/>\n  <joint name="wrist" type="fixed"><parent link="arm"/>'
        '<child link="hand"/><origin xyz="0.3 0 0"/></joint>\n</robot>\n'
    )
    m = load_model(p)
    assert [m.body(i).name for i in range(m.nbody)] == ["world", "pelvis", "arm", "hand"]
    assert m.nq == 8 and m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    chain = Chain(m, body="hand")
    assert chain.joint_names == ["shoulder"]
    np.testing.assert_allclose(chain.position, [0.3, 0.2, 1.0], atol=1e-12)
    np.testing.assert_allclose(chain.fk([math.pi / 2])[0], [0.0, 0.2, 0.7], atol=1e-12)
    d = mujoco.MjData(m)
    d.qpos[:3] = [1.0, 2.0, 3.0]
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.xpos[m.body("hand").id], [1.3, 2.2, 3.0], atol=1e-12)


def test_a_urdf_with_only_visuals_lets_them_collide(tmp_path):
    """Without any <collision> the visuals are drawn and collide (else nothing would)."""
    p = tmp_path / "v.urdf"
    p.write_text(
        '<robot name="v"><link name="a"><visual><geometry><box size="0.1 0.1 0.1"/>'
        '</geometry><material name="red"><color rgba="1 0 0 1"/></material></visual></link>'
        "</robot>"
    )
    m = load_model(p)
    assert list(m.geom_group) == [VISUAL_GROUP] and m.geom_contype[0] == 1
    np.testing.assert_allclose(m.geom_rgba[0], [1, 0, 0, 1])


# ----------------------------------------------------------------------------- digests
def test_digest_follows_package_meshes(tmp_path):
    """A URDF's package:// mesh is one of its model files, through the package search
    and through explicit package paths: editing the mesh changes the digest, moving
    the whole tree does not."""
    pkg = tmp_path / "a" / "arm"
    _tetra_stl(pkg / "meshes" / "l1.stl", 0.1)
    urdf = pkg / "urdf" / "arm.urdf"
    urdf.parent.mkdir()
    urdf.write_text(_arm_urdf("package://arm/meshes/l1.stl"))
    assert model_files(urdf) == [urdf.resolve(), (pkg / "meshes" / "l1.stl").resolve()]
    before = model_digest(urdf)
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    assert model_digest(tmp_path / "b" / "arm" / "urdf" / "arm.urdf") == before
    _tetra_stl(pkg / "meshes" / "l1.stl", 0.2)
    assert model_digest(urdf) != before
    copy = tmp_path / "copy.urdf"
    shutil.copy(urdf, copy)
    assert model_files(copy) == [copy.resolve()]  # the mesh is nowhere near it
    assert model_files(copy, packages={"arm": pkg})[1] == (pkg / "meshes" / "l1.stl").resolve()
    g1_files = model_files(robot_file("g1"))
    meshes = {el.get("filename") for el in ET.parse(robot_file("g1")).getroot().iter("mesh")}
    assert len(g1_files) == 1 + len(meshes) == 36


# ----------------------------------------------------------------------------- files
def test_scene_and_sweep_files_take_a_package_path_table(tmp_path):
    """package_path = { NAME = "DIR" } in a scene and a sweep file (DIR relative to the
    file) finds the copy's meshes; a folder that does not exist is one line naming the
    key."""
    copy = _copy_so100(tmp_path)
    rel = os.path.relpath(PACKAGE, tmp_path)
    body = 'body = "gripper"'
    scene = tmp_path / "s.toml"
    scene.write_text(
        f'model = "so100.urdf"\npackage_path = {{ {ERD} = "{rel}" }}\nduration = 0.1\n'
        '[[targets]]\nname = "t"\nmotion = { kind = "points", points = [[0.0, -0.2, 0.1]] }\n'
        f'[[effectors]]\n{body}\ntarget = "t"\n'
    )
    s = load_scene(scene)
    assert s.packages == {ERD: tmp_path / rel} and s.model == copy
    bad = tmp_path / "bad.toml"
    bad.write_text(scene.read_text().replace(f'"{rel}"', '"nowhere"'))
    with pytest.raises(SceneError) as exc:
        load_scene(bad)
    assert str(exc.value) == (
        f"{bad}: package_path.{ERD}: folder '{tmp_path / 'nowhere'}' does not exist"
    )
    sweep = tmp_path / "w.toml"
    sweep.write_text(
        f'package_path = {{ {ERD} = "{rel}" }}\nsolvers = ["dls"]\n'
        f'[[targets]]\nname = "arm"\nn = 2\nmodel = "so100.urdf"\n{body}\n'
    )
    jobs = load_sweep(sweep).jobs
    assert len(jobs) == 1 and jobs[0].package_dict == {ERD: tmp_path / rel}
    assert jobs[0].param["model_sha256"] == model_digest(copy, packages={ERD: PACKAGE})
    sweep.write_text(sweep.read_text().replace(f'"{rel}"', "3"))
    with pytest.raises(SweepError, match=rf"package_path\.{ERD}: expected a package folder"):
        load_sweep(sweep)


# ----------------------------------------------------------------------------- CLI
def test_cli_inspect_g1_as_it_comes_and_with_joints(capsys):
    """inspect --model <G1 URDF> exits 0 and counts its bodies; --joints is taken."""
    urdf = str(robot_file("g1"))
    assert main(["inspect", "--model", urdf, "--json"]) == 0
    counts = json.loads(capsys.readouterr().out)["counts"]
    assert counts == {"bodies": 40, "joints": 29, "sites": 0, "cameras": 0}
    joints = "shoulder_pan,elbow_flex"
    assert main(["inspect", "--model", str(robot_file("so100")), "--joints", joints]) == 0
    assert "so100.urdf" in capsys.readouterr().out


def test_cli_package_path_fixes_a_copy_and_a_bad_value_is_one_line(tmp_path, capsys):
    """solve on a copy: exit 2 with the one-line error, then 0 with --package-path; a
    value that is not NAME=DIR or names no folder: one line, exit 2."""
    copy = str(_copy_so100(tmp_path))
    args = ["solve", "--model", copy, "--body", "gripper", "--target", "0,-0.2,0.1"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--package-path {ERD}=DIR" in err
    assert main([*args, "--package-path", f"{ERD}={PACKAGE}"]) in (0, 1)
    capsys.readouterr()
    for value, why in [
        ("example-robot-data", "is not NAME=DIR"),
        (f"{ERD}=/nonexistent/x", "folder '/nonexistent/x' does not exist"),
    ]:
        assert main(["inspect", "--model", copy, "--package-path", value]) == 2
        err = capsys.readouterr().err
        assert err == (
            f"humanoid-ik: error: inspect: argument --package-path: package path '{value}': {why}\n"
            if "folder" in why
            else f"humanoid-ik: error: inspect: argument --package-path: package path "
            f"'{value}' {why} (e.g. my_robot=./my_robot)\n"
        )


def test_cli_usage_errors_name_the_command_once(capsys):
    """An unknown option: 'humanoid-ik: error: unrecognized arguments: ...', not the
    program's name twice."""
    assert main(["inspect", "--nope"]) == 2
    assert capsys.readouterr().err == "humanoid-ik: error: unrecognized arguments: --nope\n"
    assert main(["render", "circle", "--frames", "0"]) == 2
    err = capsys.readouterr().err
    assert (
        err == "humanoid-ik: error: render: argument --frames: expected an integer >= 1, got '0'\n"
    )


@pytest.mark.slow
def test_cli_view_takes_joints(tmp_path):
    """view --model <SO-100 URDF> --body gripper --joints J1,J2 under a virtual X
    server: the effector's chain is those two joints."""
    from humanoid_ik.outputs.trajectory import load_trajectory

    joints = ["shoulder_pan", "elbow_flex"]
    out = tmp_path / "view"
    cmd = [
        sys.executable,
        "-m",
        "humanoid_ik",
        "view",
        "--model",
        str(robot_file("so100")),
        "--body",
        "gripper",
        "--joints",
        ",".join(joints),
        "--duration",
        "0.2",
        "--out",
        str(out),
    ]
    with virtual_display() as display:
        proc = subprocess.run(
            cmd,
            capture_output=True,
            text=True,
            env={**os.environ, "MUJOCO_GL": "glfw", "DISPLAY": display},
            timeout=240,
            check=False,
        )
    assert proc.returncode == 0, proc.stderr
    assert load_trajectory(out / "trajectory.npz").effectors[0].joints == tuple(joints)


# ----------------------------------------------------------------------------- geom names
def test_urdf_geoms_are_named_after_their_links(capsys):
    """A URDF names no geom: each gets ``<link>_visual`` / ``<link>_collision``, then
    ``_1``, ``_2`` ... in file order (G1's ankle has four collision spheres), unique and
    the same on every load; ``inspect`` lists the collision pairs derived from the limbs
    by those names, in its text and its JSON."""
    g1 = robot_file("g1")
    m = load_model(g1)
    names = [m.geom(i).name for i in range(m.ngeom)]
    assert all(names) and len(set(names)) == m.ngeom == 71
    assert [n for n in names if n.startswith("left_ankle_roll_link_collision")] == [
        "left_ankle_roll_link_collision",
        "left_ankle_roll_link_collision_1",
        "left_ankle_roll_link_collision_2",
        "left_ankle_roll_link_collision_3",
    ]
    elbow = m.geom("left_elbow_link_collision")
    assert m.body(elbow.bodyid[0]).name == "left_elbow_link"
    assert elbow.group[0] == COLLISION_GROUP
    assert m.geom("left_elbow_link_visual").group[0] == VISUAL_GROUP
    assert [load_model(g1).geom(i).name for i in range(m.ngeom)] == names
    assert main(["inspect", "--model", str(g1)]) == 0
    out = capsys.readouterr().out
    assert (
        "  left_elbow_link_collision .. left_wrist_yaw_link_collision (4 geoms) vs "
        "pelvis_contour_link_collision .. head_link_collision (4 geoms)"
    ) in out.splitlines()
    assert main(["inspect", "--model", str(g1), "--json"]) == 0
    pairs = json.loads(capsys.readouterr().out)["collision_pairs"]
    assert len(pairs) == 3
    assert pairs[2] == [["left_wrist_yaw_link_collision"], ["right_wrist_yaw_link_collision"]]


INERTIAL = (
    '<inertial><mass value="1"/>'
    '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
)


def _three_joint_urdf(j1_limit: str, j2_extra: str = "") -> str:
    """A planar arm of three revolute joints; ``j1``'s ``<limit>`` attributes given."""
    links = "".join(f'<link name="{n}">{INERTIAL}</link>' for n in "abc")
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
    return (
        f'<robot name="r"><link name="base"/>{links}'
        f'<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
        f'<axis xyz="0 0 1"/><limit {j1_limit} effort="1" velocity="1"/></joint>'
        f'<joint name="j2" type="revolute"><parent link="a"/><child link="b"/>'
        f'<origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>{limit}{j2_extra}</joint>'
        f'<joint name="j3" type="revolute"><parent link="b"/><child link="c"/>'
        f'<origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>{limit}</joint></robot>'
    )


def test_a_urdf_joint_with_lower_equal_upper_stays_locked(tmp_path):
    """``lower = upper`` locks the joint (MuJoCo would drop the limit): it keeps its
    value through a solve, with a note; the other joints reach the target."""
    from humanoid_ik import solve

    path = tmp_path / "r.urdf"
    path.write_text(_three_joint_urdf('lower="0.5" upper="0.5"'))
    with pytest.warns(
        ModelWarning, match=r"1 joint\(s\) locked \(lower = upper in the URDF.*: 'j1' at 0.5"
    ):
        model = load_model(path)
    chain = Chain(model, body="c")
    assert chain.lower[0] == pytest.approx(0.5, abs=1e-8) and chain.upper[0] == pytest.approx(0.5)
    target = chain.fk([0.5, 0.4, -0.3])[0]
    result = solve(chain, target, solver="dls")
    assert result.q[0] == pytest.approx(0.5, abs=1e-8)
    assert np.linalg.norm(chain.fk(result.q)[0] - target) < 1e-4


def test_a_urdf_joint_with_lower_above_upper_is_refused(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(_three_joint_urdf('lower="0.5" upper="-0.5"'))
    with pytest.raises(ModelError, match=r"joint 'j1' has lower limit 0.5 > upper -0.5; swap"):
        load_model(path)


def test_a_urdf_mimic_joint_is_said(tmp_path):
    """A ``<mimic>`` becomes an equality constraint the solvers do not apply: a note."""
    path = tmp_path / "r.urdf"
    path.write_text(_three_joint_urdf('lower="-1" upper="1"', '<mimic joint="j1" multiplier="2"/>'))
    with pytest.warns(
        ModelWarning, match="1 joint\\(s\\) kept as equality constraints.*: 'j2' mimics 'j1'"
    ):
        load_model(path)
