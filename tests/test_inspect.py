"""``humanoid-ik inspect``: the end effectors of a model, their joints, the solvers that
apply (and why the others do not), the reach, and the warnings, on the bundled humanoid,
the URDF arm and models with suspicious ranges."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from humanoid_ik.cli import main
from humanoid_ik.core.models import load_model
from humanoid_ik.experiments.inspection import inspect_model, range_hints

REPO = Path(__file__).resolve().parents[1]
ARM7 = REPO / "examples" / "urdf_arm" / "arm7.urdf"
DEGREES = REPO / "tests" / "models" / "degrees_arm.xml"


def _effector(report, name):
    return next(e for e in report.effectors if e.name == name)


def test_humanoid_palm_joints_solvers_and_reach():
    """right_palm_site: the 7 arm hinges in order with their ranges in rad and deg,
    every reaching solver applies; the reach is the polyline shoulder-elbow-wrist-palm."""
    report = inspect_model()
    assert report.model == "models/humanoid/scene.xml" and not report.staged
    palm = _effector(report, "right_palm_site")
    assert palm.kind == "site" and palm.error is None
    names = [j.name for j in palm.joints]
    assert names[0] == "right_shoulder_flexion_joint" and names[3] == "right_elbow_joint"
    assert len(names) == 7 and all(j.type == "hinge" for j in palm.joints)
    elbow = palm.joints[3]
    assert elbow.range_rad == pytest.approx((0.0, 2.62))
    assert elbow.range_deg == pytest.approx((0.0, math.degrees(2.62)))
    assert elbow.axis == pytest.approx((0.0, -1.0, 0.0)) and elbow.qpos0_inside
    assert palm.solvers["closed_form"] is None and palm.solvers["dls"] is None
    assert "does not reach" in palm.solvers["look_at"]
    assert palm.reach == pytest.approx(0.63, abs=1e-6)
    assert palm.base == pytest.approx((0.0, -0.19, 1.40))
    assert report.warnings == ()


def test_humanoid_says_why_a_solver_does_not_apply():
    """A 4-hinge chain (elbow site) is not closed_form's: the reason names the count; a
    site without hinges (torso) has no chain and says so."""
    report = inspect_model()
    elbow = _effector(report, "right_elbow_site")
    assert elbow.solvers["closed_form"] == (
        "closed_form needs 7 hinges (3 shoulder, elbow, 3 wrist); the chain has 4 joint(s)"
    )
    torso = _effector(report, "torso_site")
    assert torso.error == "no hinge joint moves site 'torso_site'" and torso.joints == ()


def test_urdf_arm_offers_its_tool_link():
    """The URDF arm has no sites: its candidate is the leaf body tool_link with joint1..7,
    their URDF limits, reach 1.1 m (shoulder to tool: 0.2+0.2+0.2+0.2+0.18+0.06+0.06 from
    joint1), and a render needs the stage."""
    report = inspect_model(ARM7)
    assert report.staged and report.counts == {"bodies": 10, "joints": 7, "sites": 0, "cameras": 0}
    assert [(e.kind, e.name) for e in report.effectors] == [("body", "tool_link")]
    tool = report.effectors[0]
    assert [j.name for j in tool.joints] == [f"joint{i}" for i in range(1, 8)]
    assert tool.joints[1].range_rad == pytest.approx((-2.0, 2.0))
    assert tool.joints[1].axis == pytest.approx((0.0, 1.0, 0.0))
    assert tool.reach == pytest.approx(1.10, abs=1e-9)
    assert tool.base == pytest.approx((0.0, 0.0, 0.10))
    assert tool.solvers["dls"] is None


def test_ranges_read_as_degrees_are_flagged():
    """An MJCF without angle="radian" and range="-3 3" reads +-3 deg: inspect warns, and
    a failed solve on it prints the same hint."""
    report = inspect_model(DEGREES)
    assert len(report.warnings) == 2
    assert report.warnings[0].startswith("joint 'shoulder' range -3 .. 3 deg (-0.0524 .. ")
    assert 'add <compiler angle="radian"/>' in report.warnings[0]
    assert report.effectors[0].joints[0].range_rad == pytest.approx(
        (-math.radians(3), math.radians(3))
    )


def test_failed_solve_hints_at_degrees(capsys):
    """Every solve on the degrees arm fails (the arm barely moves); the output hints at
    the angle unit, once per joint of the chain."""
    code = main(
        [
            "solve",
            "--model",
            str(DEGREES),
            "--site",
            "tip",
            "--target",
            "0.3,0,0.8",
            "--solver",
            "dls",
        ]
    )
    out = capsys.readouterr().out
    assert code == 1
    hints = [line for line in out.splitlines() if line.startswith("hint: ")]
    assert len(hints) == 2 and "joint 'elbow' range -3 .. 3 deg" in hints[1]


def test_wide_ranges_free_joint_and_unlimited_joint(tmp_path):
    """A radian MJCF with range="-180 180" (wider than 2 pi), a hinge without a range and a
    free joint on the path each give one warning; qpos0 outside a range is marked."""
    p = tmp_path / "odd.xml"
    p.write_text(
        """<mujoco><compiler angle="radian"/><worldbody>
  <body name="base" pos="0 0 1"><freejoint name="float"/>
    <geom type="sphere" size="0.05"/>
    <body name="a"><joint name="wide" axis="0 0 1" range="-180 180"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="b" pos="0.3 0 0"><joint name="free_spin" axis="0 1 0" limited="false"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02"/>
        <body name="c" pos="0.2 0 0"><joint name="late" axis="0 1 0" range="0.5 1"/>
          <geom type="sphere" size="0.02"/><site name="tip"/></body></body></body></body>
</worldbody></mujoco>"""
    )
    report = inspect_model(p)
    w = "\n".join(report.warnings)
    assert "joint 'wide' range -180 .. +180 rad is wider than 2 pi" in w
    assert "joint 'free_spin' has no range" in w
    assert "joint 'late' qpos0 +0.000 rad is outside its range" in w
    assert "free joint 'float' on the path of site 'tip'" in w
    tip = _effector(report, "tip")
    assert [j.name for j in tip.joints] == ["wide", "free_spin", "late"]
    assert tip.joints[1].range_rad is None and not tip.joints[2].qpos0_inside
    assert range_hints(load_model(p)) == [x for x in report.warnings if "free joint" not in x]


def test_cli_inspect_text_and_json(capsys):
    """inspect prints the joint table; --json gives the same report as a document."""
    assert main(["inspect", "--model", str(ARM7)]) == 0
    out = capsys.readouterr().out
    assert "body tool_link: 7 joint(s), reach 1.100 m from [0.000, 0.000, 0.100]" in out
    assert "  joint2  hinge  +0.00 +1.00 +0.00  -2.000 .. +2.000  -114.6 .. +114.6  +0.000" in out
    assert "not look_at: " in out and "warnings: none" in out
    assert main(["inspect", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    palm = next(e for e in doc["effectors"] if e["name"] == "right_palm_site")
    assert palm["joints"][3]["range_rad"] == pytest.approx([0.0, 2.62])
    assert doc["counts"]["sites"] == 10


def test_cli_inspect_bad_model_is_one_line(capsys, tmp_path):
    """A missing model file: exit 2, one line naming it."""
    code = main(["inspect", "--model", str(tmp_path / "none.urdf")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "none.urdf' does not exist" in err
