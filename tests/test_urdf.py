"""URDF models and body end effectors: loading (fixed links kept, massless links and
package:// meshes handled, a missing mesh told in one line), solve and bench by
``--body``, a scene on the URDF arm and its render on the default stage."""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import mujoco
import numpy as np
import pytest

from humanoid_ik import Chain, ModelError, SceneError, solve
from humanoid_ik.cli import main
from humanoid_ik.config.scene import load_scene, scene_model
from humanoid_ik.core.models import (
    STAGE_CAMERAS,
    URDF_MIN_MASS,
    load_model,
    needs_stage,
    staged_cameras,
)
from humanoid_ik.outputs.stage import staged_model

REPO = Path(__file__).resolve().parents[1]
ARM7 = REPO / "examples" / "urdf_arm" / "arm7.urdf"
ARM7_SCENE = REPO / "tests" / "models" / "arm7_circle.toml"
JOINTS = [f"joint{i}" for i in range(1, 8)]
LIMITS = [2.9, 2.0, 2.9, 2.1, 2.9, 2.0, 3.0]


def _urdf(tmp_path: Path, links: str, name: str = "robot.urdf") -> Path:
    p = tmp_path / name
    p.write_text(f'<robot name="r">\n  <link name="base"/>\n{links}\n</robot>\n')
    return p


def _revolute(name: str, parent: str, child: str, z: float = 0.0) -> str:
    return (
        f'  <joint name="{name}" type="revolute"><parent link="{parent}"/>'
        f'<child link="{child}"/><origin xyz="0 0 {z}"/><axis xyz="0 1 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
    )


def test_urdf_arm_loads_with_its_fixed_tool_link_and_limits():
    """MuJoCo's URDF reader would fuse the fixed tool link into link7; load_model keeps
    it a body, and the seven limits arrive in radians as written."""
    m = load_model(ARM7)
    bodies = [m.body(i).name for i in range(m.nbody)]
    assert bodies == ["world", "base_link", *[f"link{i}" for i in range(1, 8)], "tool_link"]
    assert m.nsite == 0 and m.nlight == 0 and m.ncam == 0
    np.testing.assert_allclose(m.jnt_range[:, 1], LIMITS)
    np.testing.assert_allclose(m.jnt_range[:, 0], [-v for v in LIMITS])
    assert m.body("tool_link").mass[0] == pytest.approx(0.1)
    assert m.body("link7").mass[0] == pytest.approx(0.3)  # not 0.4: nothing was fused


def test_chain_by_body_forward_kinematics():
    """The tool link stands 1.20 m up at q = 0; joint2 at +90 deg lays the arm along +x
    from the shoulder at 0.30 m: the tool then sits at (0.90, 0, 0.30)."""
    chain = Chain(ARM7, body="tool_link")
    assert chain.joint_names == JOINTS and chain.ee_kind == "body"
    p, _ = chain.fk(np.zeros(7))
    np.testing.assert_allclose(p, [0, 0, 1.20], atol=1e-12)
    p, R = chain.fk([0, math.pi / 2, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(p, [0.90, 0, 0.30], atol=1e-12)
    np.testing.assert_allclose(R[:, 2], [1, 0, 0], atol=1e-12)  # tool z now along +x


def test_solve_on_the_urdf_arm_reaches_the_target():
    """dls drives the tool link onto a reachable point; FK of the result agrees."""
    chain = Chain(ARM7, body="tool_link")
    target = [0.45, 0.10, 0.55]
    res = solve(chain, target, "dls")
    assert res.converged and res.position_error < 1e-3
    p, _ = chain.fk(res.q)
    np.testing.assert_allclose(p, target, atol=1e-3)
    assert chain.within_limits(res.q)


def test_urdf_link_without_mass_gets_a_nominal_one(tmp_path):
    """A link with neither <inertial> nor geometry (MuJoCo rejects it) gets URDF_MIN_MASS;
    a link with geometry but no <inertial> gets its mass from the geometry."""
    links = "\n".join(
        [
            _revolute("j1", "base", "l1"),
            '  <link name="l1"><collision><geometry><box size="0.1 0.1 0.3"/></geometry>'
            "</collision></link>",
            _revolute("j2", "l1", "l2", 0.3),
            '  <link name="l2"/>',
        ]
    )
    m = load_model(_urdf(tmp_path, links))
    assert m.body("l2").mass[0] == pytest.approx(URDF_MIN_MASS)
    assert m.body("l1").mass[0] == pytest.approx(1000 * 0.1 * 0.1 * 0.3)  # density 1000
    chain = Chain(m, body="l2")
    np.testing.assert_allclose(chain.fk([0.0, 0.0])[0], [0, 0, 0.3], atol=1e-12)


def test_urdf_missing_mesh_is_one_line_with_the_fix(tmp_path, capsys):
    """A package:// mesh that is nowhere near the URDF fails in one line naming the URI,
    where it was looked for and the option that fixes it; the CLI exits 2 without a
    traceback."""
    links = "\n".join(
        [
            _revolute("j1", "base", "l1"),
            '  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" '
            'izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry>'
            '<mesh filename="package://arm/meshes/l1.stl"/></geometry></collision></link>',
        ]
    )
    path = _urdf(tmp_path, links)
    with pytest.raises(ModelError) as exc:
        load_model(path)
    msg = str(exc.value)
    assert "\n" not in msg and "mesh 'package://arm/meshes/l1.stl' not found" in msg
    assert "ROS_PACKAGE_PATH" in msg and "--package-path arm=DIR" in msg
    assert str(tmp_path / "meshes" / "l1.stl") in msg  # beside the URDF, tried last
    code = main(["solve", "--model", str(path), "--body", "l1", "--target", "0,0,0"])
    out, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "l1.stl" in err and "Traceback" not in err


def _write_tetra_stl(path: Path, size: float) -> None:
    """A binary STL of a tetrahedron with legs ``size`` [m] along x, y, z."""
    v = [(0, 0, 0), (size, 0, 0), (0, size, 0), (0, 0, size)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    data = bytearray(b"\0" * 80 + struct.pack("<I", len(faces)))
    for f in faces:
        data += struct.pack("<3f", 0, 0, 0)
        for k in f:
            data += struct.pack("<3f", *v[k])
        data += struct.pack("<H", 0)
    path.write_bytes(bytes(data))


def test_urdf_package_mesh_is_found_beside_the_file(tmp_path):
    """package://PKG/meshes/x.stl resolves to meshes/x.stl beside the URDF (a ROS
    package's layout), and the mesh is in the model."""
    (tmp_path / "meshes").mkdir()
    _write_tetra_stl(tmp_path / "meshes" / "l1.stl", 0.2)
    links = "\n".join(
        [
            _revolute("j1", "base", "l1"),
            '  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" '
            'izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry>'
            '<mesh filename="package://arm/meshes/l1.stl"/></geometry></collision></link>',
        ]
    )
    m = load_model(_urdf(tmp_path, links))
    assert m.nmesh == 1 and m.ngeom == 1
    assert int(m.geom_type[0]) == int(mujoco.mjtGeom.mjGEOM_MESH)


def test_cli_solve_and_bench_by_body(capsys, tmp_path):
    """solve --model URDF --body LINK lands on the target (JSON by body); bench on the same
    chain solves every target with dls and ccd."""
    target = [0.45, -0.10, 0.60]
    code = main(
        [
            "solve",
            "--model",
            str(ARM7),
            "--body",
            "tool_link",
            "--target",
            ",".join(map(str, target)),
            "--solver",
            "dls",
            "--json",
        ]
    )
    doc = json.loads(capsys.readouterr().out)
    assert code == 0 and doc["body"] == "tool_link" and "site" not in doc
    chain = Chain(ARM7, body="tool_link")
    np.testing.assert_allclose(chain.fk([doc["q"][n] for n in JOINTS])[0], target, atol=1e-3)
    out_json = tmp_path / "bench.json"
    code = main(
        [
            "bench",
            "--model",
            str(ARM7),
            "--body",
            "tool_link",
            "--solvers",
            "dls,ccd",
            "--n",
            "20",
            "--json",
            str(out_json),
        ]
    )
    printed = capsys.readouterr().out
    assert "  body tool_link  task position" in printed.splitlines()[0]
    doc = json.loads(out_json.read_text())
    rows = {r["solver"]: r for r in doc["results"]}
    assert doc["site"] == "tool_link" and doc["effector"] == "body"
    assert code == 0 and rows["dls"]["success_rate"] == 1.0 and rows["ccd"]["success_rate"] == 1.0


def test_site_and_body_are_exclusive(capsys):
    """--site and --body together is a one-line usage error."""
    code = main(["solve", "--target", "0,0,1", "--site", "right_palm_site", "--body", "x"])
    err = capsys.readouterr().err
    assert code == 2 and "not allowed with argument" in err and err.count("\n") == 1


def test_scene_with_a_body_effector_on_the_urdf_arm():
    """A scene file names the URDF (relative) and a body effector; it runs on the model
    as the file has it (no stage: the solvers never see one), and its film's staged
    model has the stage cameras and the same joints."""
    scene = load_scene(ARM7_SCENE)
    (eff,) = scene.effectors
    assert eff.body == "tool_link" and eff.site is None and eff.name == "tool_link"
    bare, run_on = load_model(ARM7), scene_model(scene)
    assert needs_stage(run_on) and (run_on.ngeom, run_on.ncam) == (bare.ngeom, bare.ncam)
    staged = staged_model(scene.model, scene.target_points())
    assert not needs_stage(staged)
    assert bare.nq == staged.nq and bare.njnt == staged.njnt
    assert {staged.camera(i).name for i in range(staged.ncam)} == set(STAGE_CAMERAS)
    assert staged_cameras(run_on) == list(STAGE_CAMERAS)  # what a scene may film with


def test_scene_effector_needs_exactly_one_of_site_and_body(tmp_path):
    """An effector with both site and body, or none of site, body and limb, is one line
    naming the key."""
    text = ARM7_SCENE.read_text().replace(
        "../../examples/urdf_arm/arm7.urdf", str(ARM7).replace("\\", "/")
    )
    for bad, got in (("", "none"), ('body = "x"\nsite = "y"', "site, body")):
        p = tmp_path / "bad.toml"
        p.write_text(text.replace('body = "tool_link"', bad))
        with pytest.raises(SceneError) as exc:
            load_scene(p)
        assert f"effectors[0].site: expected one of site, body or limb, got {got}" in str(exc.value)
    p = tmp_path / "nobody.toml"
    p.write_text(text.replace('body = "tool_link"', 'body = "hand"'))
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    assert "effectors[0].body: expected a body of the model (base_link, link1" in str(exc.value)


def test_stage_leaves_a_complete_model_alone():
    """The bundled humanoid has lights, a floor and the cameras: staging returns it as
    load_model compiles it."""
    bare, staged = load_model(None), staged_model(None)
    assert not needs_stage(bare)
    assert (staged.ngeom, staged.nlight, staged.ncam) == (bare.ngeom, bare.nlight, bare.ncam)


def test_stage_floor_sits_under_the_lowest_geom_and_cameras_look_at_the_arm():
    """The stage's floor is at the bottom of the base cylinder (z = 0); every stage
    camera sees the arm's middle (1.20 m tall at home) in front of it."""
    m = staged_model(ARM7)
    floor = m.geom("stage_floor")
    assert int(floor.type[0]) == int(mujoco.mjtGeom.mjGEOM_PLANE)
    assert floor.pos[2] == pytest.approx(0.0, abs=1e-9)
    assert m.nlight == 2
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    middle = np.array([0, 0, 0.6])
    for name in STAGE_CAMERAS:
        c = d.cam(name)
        ahead = -c.xmat.reshape(3, 3)[:, 2]  # a camera looks along its -z
        to_mid = middle - c.xpos
        cos = float(ahead @ to_mid / np.linalg.norm(to_mid))
        assert cos > math.cos(math.radians(10)), name


def test_render_of_the_urdf_arm_shows_floor_sky_and_arm(tmp_path):
    """A render of the URDF scene (tiny frames) is not black: the lower band is the lit
    floor, the upper band the blue-grey sky, and the orange arm links are in view."""
    import imageio.v2 as imageio

    from humanoid_ik.outputs.render import render_scene

    scene = load_scene(ARM7_SCENE).with_overrides(frames=3, width=96, height=72)
    out = render_scene(scene, tmp_path / "r", video=False, plot=False)
    assert out.frames >= 2 and out.snapshots
    img = imageio.imread(out.snapshots[0]).astype(float)
    assert img.shape[:2] == (72, 96)
    floor = img[-12:]  # bottom rows: floor
    sky = img[:6]
    assert floor.mean() > 25 and floor.std() > 5  # a lit checker, not black
    assert sky.mean() > 25 and sky[..., 2].mean() > sky[..., 0].mean()  # bluish sky
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    orange = (r > 150) & (r > g + 50) & (g > b + 20)
    assert orange.sum() >= 20  # the arm's orange links


def test_sweep_target_set_and_scene_by_body(tmp_path):
    """A sweep names the URDF arm's tool link in a target set (body = ...) and runs the
    URDF scene: both jobs solve; a target set with site and body is one line."""
    from humanoid_ik.config.sweep_file import load_sweep
    from humanoid_ik.errors import SweepError
    from humanoid_ik.experiments.sweep.jobs import run_job

    scene = tmp_path / "arm7_circle.toml"
    scene.write_text(
        ARM7_SCENE.read_text().replace(
            "../../examples/urdf_arm/arm7.urdf", str(ARM7).replace("\\", "/")
        )
    )
    text = f"""name = "arm7"
seeds = [3]
solvers = ["dls"]

[[scenes]]
scene = "{scene.name}"
frames = 4

[[targets]]
name = "tool"
task = "position"
n = 10
model = "{str(ARM7).replace(chr(92), "/")}"
body = "tool_link"
"""
    sweep_file = tmp_path / "s.toml"
    sweep_file.write_text(text)
    sweep = load_sweep(sweep_file)
    records = {job.kind: run_job(job) for job in sweep.jobs}
    assert records["targets"]["status"] == "ok" and records["targets"]["success_rate"] == 1.0
    assert records["scene"]["status"] == "ok"
    sweep_file.write_text(text.replace('body = "tool_link"', 'body = "tool_link"\nsite = "x"'))
    with pytest.raises(SweepError, match=r"targets\[0\]\.body: expected one of site, body or limb"):
        load_sweep(sweep_file)
