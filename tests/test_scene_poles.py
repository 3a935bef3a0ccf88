"""Elbow poles in scene files (``pole`` on an effector): a world point, another target
of the scene (moving), or a point placed relative to a limb. The right arm traces a
circle with its pole above, then below: in every frame the elbow (MuJoCo FK of the
elbow joint's body, on a fresh ``MjData``) is on the pole's side, in the plane of the
shoulder, the wrist and the pole within 1 degree, with the exact solvers."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from humanoid_ik.config.placement import LimbPoint
from humanoid_ik.config.scene import EffectorSpec, Scene, SolverSpec, check_scene, parse_scene
from humanoid_ik.errors import SceneError
from humanoid_ik.motion import Circle, TargetTrack
from humanoid_ik.run.runner import run_scene

ONE_DEGREE = math.radians(1.0)
REACH = 0.63  # [m]: the bundled right arm's sampled reach
SHOULDER = np.array([0.0, -0.19, 1.40])  # the bundled right shoulder at home
AT = [0.7, -0.1, 0.2]  # the circle's centre, in reach fractions from the shoulder
CENTER = SHOULDER + REACH * np.array(AT)
OFFSET = {"above": np.array([0.0, -0.3, 1.0]), "below": np.array([0.0, -0.3, -1.0])}


def _doc(solver: str, side: str, form: str) -> dict:
    """A 2 s scene: the right arm's palm on a 10 cm circle in front of the shoulder, its
    elbow's pole ``OFFSET[side]`` from the circle's centre, given in ``form``."""
    off = OFFSET[side]
    ball = {
        "kind": "circle",
        "center": {"limb": "right_arm", "at": AT},
        "radius": 0.1,
        "normal": {"robot": [1, 0, 0]},
        "period": 2.0,
    }
    targets = [{"name": "ball", "motion": ball}]
    if form == "point":
        pole: object = (CENTER + off).tolist()
    elif form == "limb":
        pole = {"limb": "right_arm", "at": (np.array(AT) + off / REACH).tolist()}
    else:  # a target that circles with the ball, offset: the pole moves every frame
        moved = dict(
            ball, center={"limb": "right_arm", "at": (np.array(AT) + off / REACH).tolist()}
        )
        targets.append({"name": "elbow_pole", "motion": moved})
        pole = "elbow_pole"
    return {
        "name": "poles",
        "duration": 2.0,
        "fps": 15,
        "solver": {"name": solver},
        "targets": targets,
        "effectors": [{"limb": "right_arm", "target": "ball", "pole": pole}],
    }


def _elbow_angles(scene: Scene, recording) -> list[tuple[float, float]]:
    """Per frame: the angle [rad] between the elbow's half-plane and the pole's about the
    shoulder-wrist line, and the elbow's height above that line's midpoint [m] (from
    MuJoCo FK of the recorded ``qpos`` on a fresh ``MjData``)."""
    m = recording.model
    d = mujoco.MjData(m)
    elbow = m.joint("right_elbow_joint").id
    shoulder = m.joint("right_shoulder_flexion_joint").id
    wrist = m.joint("right_wrist_pronation_joint").id
    eff = scene.effectors[0]
    out = []
    for frame, qpos in zip(recording.frames, recording.qpos, strict=True):
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        S, W = d.xanchor[shoulder].copy(), d.xanchor[wrist].copy()
        E = d.xpos[m.jnt_bodyid[elbow]].copy()
        if isinstance(eff.pole, str):
            P = scene.target(eff.pole).motion.position(frame.time)
        else:
            P = np.array(eff.pole)
        u = (W - S) / np.linalg.norm(W - S)
        a = (E - S) - ((E - S) @ u) * u
        b = (P - S) - ((P - S) @ u) * u
        out.append((math.atan2(np.linalg.norm(np.cross(a, b)), a @ b), E[2] - (S[2] + W[2]) / 2))
    return out


@pytest.mark.parametrize("form", ["point", "limb", "target"])
@pytest.mark.parametrize("solver", ["closed_form", "two_link"])
def test_pole_above_and_below_puts_the_elbow_on_its_side(solver, form):
    heights = {}
    for side in ("above", "below"):
        scene = parse_scene(_doc(solver, side, form), "<poles>")
        if form == "limb":  # placed on the model: the world point of the fractions
            np.testing.assert_allclose(scene.effectors[0].pole, CENTER + OFFSET[side], atol=1e-9)
        rec = run_scene(scene)
        assert len(rec.frames) == 30
        assert max(f.samples[0].position_error for f in rec.frames) < 1e-9
        angles = _elbow_angles(scene, rec)
        assert max(a for a, _ in angles) < ONE_DEGREE, (side, max(a for a, _ in angles))
        heights[side] = [h for _, h in angles]
    # the two poles give two different arms: elbow up in every frame, then down
    assert min(heights["above"]) > 0.05 and max(heights["below"]) < -0.05


def test_the_pole_is_what_lifts_the_elbow():
    """The same scene without ``pole``: in every frame the elbow is lower than with the
    pole above."""
    doc = _doc("closed_form", "above", "point")
    del doc["effectors"][0]["pole"]
    rec = run_scene(parse_scene(doc, "<poles>"))
    q_up = run_scene(parse_scene(_doc("closed_form", "above", "point"), "<poles>")).qpos
    d = mujoco.MjData(rec.model)
    body = rec.model.jnt_bodyid[rec.model.joint("right_elbow_joint").id]
    for qpos, up in zip(rec.qpos, q_up, strict=True):
        d.qpos[:] = qpos
        mujoco.mj_kinematics(rec.model, d)
        low = d.xpos[body][2]
        d.qpos[:] = up
        mujoco.mj_kinematics(rec.model, d)
        assert d.xpos[body][2] > low + 0.05


def _error(doc: dict) -> str:
    with pytest.raises(SceneError) as info:
        check_scene(parse_scene(doc, "scenes/x.toml"))
    message = str(info.value)
    assert "\n" not in message
    return message


def test_pole_mistakes_are_one_line():
    doc = _doc("closed_form", "above", "point")
    eff = doc["effectors"][0]
    for pole, message in (
        ("nowhere", "pole: expected a target other than its own 'ball' (no other target), got"),
        ("ball", "effectors[0].pole: expected a target other than its own 'ball' (no other"),
        ([0, 1], "effectors[0].pole: expected [x, y, z] (a world point), another target's name"),
        ([0, True, 1], "effectors[0].pole: expected [x, y, z] (a world point)"),
        ({"limb": "right_leg", "at": [0, 0, 1]}, "effectors[0].pole.limb: expected one of"),
        ({"limb": "right_arm", "at": [[0, 0, 1]]}, "effectors[0].pole.at: expected [forward, l"),
        ({"robot": [0, 0, 1]}, "effectors[0].pole: expected [x, y, z] (a world point), another"),
        ([0, 0, 1e7], "effectors[0].pole: expected coordinates within 1e+06 m, got [0.0, 0.0, 1"),
    ):
        eff["pole"] = pole
        assert message in _error(doc), pole
    gaze = _doc("closed_form", "above", "target")
    gaze["effectors"] = [{"limb": "head", "target": "ball", "task": "look_at", "pole": [0, 0, 2]}]
    assert _error(gaze).startswith(
        "scenes/x.toml: effectors[0].pole: expected no pole on a look_at effector"
    )


def test_a_scene_built_in_python_takes_a_pole():
    """``EffectorSpec(pole=...)``: a point (any sequence of 3 numbers, kept as a tuple)
    or a target's name; a limb-relative pole is placed when a file is read, so a
    Python-built scene with one is refused."""
    ball = TargetTrack("ball", Circle(CENTER, 0.1, period=2.0))
    eff = EffectorSpec("right_palm_site", "ball", pole=np.array(CENTER + OFFSET["above"]))
    assert isinstance(eff.pole, tuple) and len(eff.pole) == 3
    scene = Scene("py", 1.0, 10, SolverSpec("closed_form"), (ball,), (eff,))
    rec = run_scene(scene)
    assert max(a for a, _ in _elbow_angles(scene, rec)) < ONE_DEGREE
    with pytest.raises(SceneError, match=r"^<effector>: pole: expected 3 numbers \[x, y, z\]"):
        EffectorSpec("right_palm_site", "ball", pole=[1, 2])
    unplaced = replace(eff, pole=LimbPoint("right_arm", np.array([0.5, 0.0, 1.0])))
    with pytest.raises(SceneError, match=r"effectors\[0\].pole: expected a world point: a \{ "):
        check_scene(replace(scene, effectors=(unplaced,)))
