"""Scene files: every bundled scene loads, and each mistake gives one message naming the
file, the key and what was expected."""

from __future__ import annotations

import math
import re
import textwrap
from dataclasses import replace
from pathlib import Path

import pytest

from humanoid_ik import Chain
from humanoid_ik.cli import main
from humanoid_ik.config.scene import (
    RenderSpec,
    Scene,
    SolverSpec,
    bundled_scenes,
    bundled_scenes_dir,
    check_scene,
    display_path,
    find_scene,
    load_scene,
    scene_model,
)
from humanoid_ik.errors import SceneError
from humanoid_ik.motion import MOTIONS, RandomWalk
from humanoid_ik.solvers import SOLVERS

GOOD = """
name = "probe"
duration = 2.0
fps = 10

[solver]
name = "dls"
options = { restarts = 0 }

[render]
width = 64
height = 48
camera = "front"

[[targets]]
name = "ball"
motion = { kind = "circle", center = [0.40, -0.30, 1.20], radius = 0.1 }

[[effectors]]
site = "right_palm_site"
target = "ball"
"""


def write(tmp_path: Path, text: str, name: str = "x.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def error_of(path: Path) -> str:
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


# ----------------------------------------------------------------------------- bundled
def test_every_bundled_scene_loads():
    """Every scenes/*.toml loads and checks against the model; names are unique."""
    paths = bundled_scenes()
    assert len(paths) >= 13
    names = [load_scene(p).name for p in paths]
    assert len(set(names)) == len(names)
    assert all(p.stem == n for p, n in zip(paths, names, strict=True))


def test_bundled_scenes_cover_the_issue():
    """Circle, figure-eight with a pose target, two hands at once, gaze, out-of-reach and
    one scene per reaching solver on the same path are bundled, and every motion kind is
    used by some scene."""
    scenes = {p.stem: load_scene(p) for p in bundled_scenes()}
    assert scenes["circle"].targets[0].motion.kind == "circle"
    f8 = scenes["figure8_pose"]
    assert f8.targets[0].motion.kind == "figure8" and f8.targets[0].is_pose
    both = scenes["both_hands"]
    assert {e.site for e in both.effectors} == {"right_palm_site", "left_palm_site"}
    assert len({e.target for e in both.effectors}) == 2
    gaze = scenes["gaze"]
    assert gaze.effectors[0].task == "look_at" and gaze.solver_for(gaze.effectors[0]).name == (
        "look_at"
    )
    assert scenes["out_of_reach"].targets[0].motion.kind == "out_and_back"
    kinds = {t.motion.kind for s in scenes.values() for t in s.targets}
    assert kinds == set(MOTIONS)
    interps = {
        t.motion.interpolation
        for s in scenes.values()
        for t in s.targets
        if t.motion.kind == "waypoints"
    }
    assert interps == {"linear", "smooth"}
    cameras = {s.render.camera for s in scenes.values()}
    assert {"front", "side", "top"} <= cameras
    arm = Chain()  # the bundled humanoid's right arm: 7 hinges (subproblem's are 6)
    reaching = [n for n, cls in SOLVERS.items() if cls.reaches and cls().applicable(arm) is None]
    paths = set()
    for name in reaching:
        sc = scenes[f"compare_{name}"]
        assert sc.solver.name == name
        m = sc.targets[0].motion
        paths.add((m.kind, m.points.tobytes(), m.speed, sc.duration, sc.effectors[0].site))
    assert len(paths) == 1  # the same path for every solver


def test_find_scene_by_name_and_unknown_name():
    """A bundled scene is found by its bare name; an unknown name lists the bundled ones."""
    assert find_scene("circle") == bundled_scenes_dir() / "circle.toml"
    with pytest.raises(SceneError, match=r"^nope: no such scene file; expected .*circle"):
        find_scene("nope")


def test_scenes_command_lists_one_line_per_scene(capsys):
    """`humanoid-ik scenes` prints one line per bundled scene, starting with its name."""
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [ln.split()[0] for ln in lines] == [p.stem for p in bundled_scenes()]
    circle = next(ln for ln in lines if ln.startswith("circle "))
    assert re.search(r"\bdls\b.*\b4 s\b.*\bfront\b.*circle", circle)


def test_scenes_command_without_scenes(tmp_path, monkeypatch, capsys):
    """With an empty scenes folder the command says so in one line and exits 2."""
    monkeypatch.setenv("HUMANOID_IK_SCENES", str(tmp_path))
    assert main(["scenes"]) == 2
    assert "no bundled scenes" in capsys.readouterr().err


# ----------------------------------------------------------------------------- values
def test_good_scene_values(tmp_path):
    """A small scene file parses into the documented values and defaults."""
    sc = load_scene(write(tmp_path, GOOD))
    assert sc.name == "probe" and sc.duration == 2.0 and sc.fps == 10.0
    assert sc.n_frames == 20
    assert sc.solver == SolverSpec("dls", {"restarts": 0})
    assert sc.render.width == 64 and sc.render.height == 48 and sc.render.trail == 1.5
    assert sc.effectors[0].task == "reach" and sc.effectors[0].joints is None
    assert sc.target("ball").motion.radius == 0.1
    assert sc.solver.label() == "dls(restarts=0)"


def test_overrides(tmp_path):
    """with_overrides replaces solver, frame count (spread over the duration, or over
    the first `until` seconds), size, camera and gif; None keeps."""
    sc = load_scene(write(tmp_path, GOOD))
    o = sc.with_overrides(solver="ccd", frames=7, width=96, height=72, camera="side", gif=True)
    assert o.solver == SolverSpec("ccd") and o.n_frames == 7 and o.duration == 2.0
    assert o.fps == pytest.approx(3.5)
    assert o.render == RenderSpec(96, 72, "side", 1.5, True, (), 12)
    assert sc.with_overrides() == sc
    cut = sc.with_overrides(until=0.6, frames=3)
    assert cut.duration == pytest.approx(0.6) and cut.fps == pytest.approx(5.0)
    assert cut.n_frames == 3


def test_name_defaults_to_file_stem_and_model_is_relative(tmp_path):
    """Without `name` the file stem names the scene; `model` is relative to the file."""
    import shutil

    models = Path(__file__).resolve().parents[1] / "models" / "humanoid"
    sub = tmp_path / "sub"
    sub.mkdir()
    for f in ("scene.xml", "humanoid.xml"):
        shutil.copy(models / f, sub / f)
    p = write(sub, 'model = "scene.xml"\n' + GOOD.replace('name = "probe"\n', ""), "walk.toml")
    sc = load_scene(p)
    assert sc.name == "walk" and sc.model == sub / "scene.xml"


def test_display_path_is_relative_inside_the_working_folder(tmp_path, monkeypatch):
    """Paths inside the working folder are shown relative to it, others as given."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a").mkdir()
    assert display_path(tmp_path / "a" / "b.toml") == str(Path("a") / "b.toml")
    assert display_path("/elsewhere/c.toml") == "/elsewhere/c.toml"


# ----------------------------------------------------------------------------- errors
BAD = [
    # (replace this, with that, expected message after "x.toml: ")
    (
        "radius = 0.1",
        'radius = "big"',
        "targets[0].motion.radius: expected a number > 0, got 'big'",
    ),
    ("radius = 0.1", "radius = -2", "targets[0].motion.radius: expected a number > 0, got -2"),
    (
        "radius = 0.1",
        "radius = 0.1, radus = 3",
        "targets[0].motion.radus: unknown key for motion 'circle'; expected one of center, kind,"
        " normal, period, phase, radius, reverse",
    ),
    (
        ", radius = 0.1",
        "",
        "targets[0].motion.radius: missing; motion 'circle' needs center, radius",
    ),
    (
        'kind = "circle"',
        'kind = "spiral"',
        "targets[0].motion.kind: expected one of points, circle, figure8, lissajous, waypoints,"
        " random_walk, out_and_back, got 'spiral'",
    ),
    ('kind = "circle", ', "", "targets[0].motion.kind: missing; expected one of points"),
    (
        "center = [0.40, -0.30, 1.20]",
        "center = [0.40, -0.30]",
        "targets[0].motion.center: expected 3 numbers [x, y, z], got [0.4, -0.3]",
    ),
    ("duration = 2.0", "duration = 0", "duration: expected a number > 0, got 0"),
    ("duration = 2.0", "", "duration: missing; expected a number > 0 (seconds)"),
    ("fps = 10", "fps = 5000", "fps: expected a number >= 0.01 and <= 1000, got 5000"),
    ("fps = 10", "fps = 0.001", "fps: expected a number >= 0.01 and <= 1000, got 0.001"),
    ("fps = 10", 'fps = "fast"', "fps: expected a number >= 0.01 and <= 1000, got 'fast'"),
    (
        "duration = 2.0",
        "duration = 1e5",
        "duration: expected a number > 0 and <= 10000 (at most 100000 frames at 10 fps), "
        "got 100000.0",
    ),
    ('name = "probe"', 'name = "a b"', "name: expected a name of letters, digits"),
    ('name = "probe"', 'name = "-probe"', "name: expected a name of letters, digits"),
    ("[render]", '[render]\n"tint colour" = 1', 'render."tint colour": unknown key; expected'),
    (
        "radius = 0.1 }",
        'radius = 0.1, "a\\nb" = 1 }',
        "targets[0].motion.\"a\\nb\": unknown key for motion 'circle'",
    ),
    ('name = "probe"', 'name = "probe"\ncolour = "red"', "colour: unknown key; expected one of"),
    ('name = "dls"', 'name = "magic"', "solver.name: expected one of auto, two_link, ccd"),
    (
        "options = { restarts = 0 }",
        "options = { restart = 0 }",
        "solver.options: option 'restart' unknown for solver 'dls'; options:",
    ),
    (
        "options = { restarts = 0 }",
        "options = { restarts = -1 }",
        "solver.options: option 'restarts' of solver 'dls' must be a finite number >= 0",
    ),
    ('[solver]\nname = "dls"', '[solver]\nnom = "dls"', "solver.nom: unknown key; expected"),
    (
        "width = 64",
        "width = 63",
        "render.width: expected an even integer >= 16 and <= 4096 (pixels), got 63",
    ),
    (
        "width = 64",
        "width = 4098",
        "render.width: expected an even integer >= 16 and <= 4096 (pixels), got 4098",
    ),
    ("width = 64", "width = 4000", "render.width: expected at most 1920 (the model's off-screen"),
    ("height = 48", "height = true", "render.height: expected an even integer >= 16 and <= 4096"),
    (
        'camera = "front"',
        'camera = "left"',
        "render.camera: expected one of front, side, top, three_quarter, got 'left'",
    ),
    ("[render]", "[render]\ntrail = -1", "render.trail: expected a number >= 0 and <= 60, got -1"),
    ("[render]", "[render]\ntrail = 61", "render.trail: expected a number >= 0 and <= 60, got 61"),
    (
        "[render]",
        "[render]\ncontact_sheet = 101",
        "render.contact_sheet: expected an integer >= 0 and <= 100, got 101",
    ),
    ('camera = "front"', "camera = 3", "render.camera: expected a camera name, got 3"),
    ('name = "probe"', 'name = "probe"\ndescription = 3', "description: expected a string, got 3"),
    ('site = "right_palm_site"', "site = 3", "effectors[0].site: expected a site name, got 3"),
    ("[render]", "[render]\ngif = 1", "render.gif: expected true or false, got 1"),
    ("[render]", '[render]\nsnapshots = "all"', "render.snapshots: expected a list of at most"),
    ("[render]", "[render]\nsnapshots = [1, -1]", "render.snapshots[1]: expected a number >= 0"),
    ("[render]", "[render]\ncontact_sheet = 2.5", "render.contact_sheet: expected an integer >= 0"),
    (
        'site = "right_palm_site"',
        'site = "right_hand"',
        "effectors[0].site: expected a site of the model (gaze_site, left_elbow_site,",
    ),
    (
        'target = "ball"',
        'target = "bal"',
        "effectors[0].target: expected one of 'ball', got 'bal'",
    ),
    ('target = "ball"', 'target = "ball"\ntask = "grab"', "effectors[0].task: expected one of"),
    (
        'target = "ball"',
        'target = "ball"\njoints = ["neck_yaw_joint"]',
        "effectors[0].joints: joint 'neck_yaw_joint' does not move site 'right_palm_site'",
    ),
    ('target = "ball"', 'target = "ball"\njoints = "all"', "effectors[0].joints: expected a list"),
    (
        'target = "ball"',
        'target = "ball"\nsolver = { name = "two_link", options = { wobble = 1 } }',
        "effectors[0].solver.options: option 'wobble' unknown for solver 'two_link'",
    ),
    (
        '[solver]\nname = "dls"\noptions = { restarts = 0 }',
        '[solver]\nname = "look_at"',
        "solver.name: solver 'look_at' aims a site at a point; effectors[0] (right_palm_site)",
    ),
    (
        'target = "ball"',
        'target = "ball"\ntask = "look_at"\nsolver = { name = "dls" }',
        "effectors[0].solver.name: solver 'dls' moves a site onto a point; "
        "effectors[0] (right_palm_site) aims (task = 'look_at'); expected 'look_at' or 'mink'",
    ),
    ("[[effectors]]", "[[effectors]]\n[[effectors.x]]", "effectors[0].x: unknown key; expected"),
    ('[[targets]]\nname = "ball"', '[[targets]]\nnam = "ball"', "targets[0].nam: unknown key"),
    ('[[targets]]\nname = "ball"', "[[targets]]", "targets[0].name: missing; expected a target"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_scene_file_names_file_key_and_expectation(tmp_path, old, new, message):
    """One line: '<file>: <key>: expected ..., got ...' (or the key's own message)."""
    assert old in GOOD
    p = write(tmp_path, GOOD.replace(old, new, 1))
    msg = error_of(p)
    assert msg.startswith(f"{display_path(p)}: {message}"), msg


MINK = '[solver]\nname = "mink"\noptions = { collision_pairs = %s }'
"""GOOD's solver table made mink with these collision pairs (TOML)."""
_DLS = '[solver]\nname = "dls"\noptions = { restarts = 0 }'


@pytest.mark.parametrize(
    ("pairs", "message"),
    [
        (
            '[[["right_hand_collision"], ["torso_colision"]]]',
            "solver.options.collision_pairs[0][1][0]: expected a geom of the model (",
        ),
        (
            '[[["right_hand_collision"], "belly"]]',
            "solver.options.collision_pairs[0][1]: expected a geom of the model (",
        ),
        (
            '[["right_hand_collision"]]',
            "solver.options.collision_pairs[0]: expected two groups of geom names "
            "[[names], [names]], got ['right_hand_collision']",
        ),
        (
            '[[["right_hand_collision", 3], ["torso_collision"]]]',
            "solver.options.collision_pairs[0][0][1]: expected a geom name, got 3",
        ),
        ('"all"', "solver.options.collision_pairs: expected a list of pairs of geom-name"),
    ],
    ids=["geom_in_list", "geom_alone", "one_group", "not_a_name", "not_a_list"],
)
def test_bad_collision_pairs_name_the_key_the_value_and_the_choices(tmp_path, pairs, message):
    """collision_pairs (mink's solver options): a wrong geom name or shape is one line
    naming the key path down to the element, the bad value and, for a name, the model's
    geoms."""
    p = write(tmp_path, GOOD.replace(_DLS, MINK % pairs, 1))
    msg = error_of(p)
    assert msg.startswith(f"{display_path(p)}: {message}"), msg
    if "geom of the model" in message:
        bad = "torso_colision" if "torso_colision" in pairs else "belly"
        assert msg.endswith(f"), got {bad!r}") and "head_collision, " in msg, msg


def test_collision_pairs_of_an_effector_solver_are_checked(tmp_path):
    """An effector's own mink solver: its pairs are checked under its key."""
    pairs = '[["right_hand_collision", "belly"]]'
    own = f'solver = {{ name = "mink", options = {{ collision_pairs = {pairs} }} }}'
    p = write(tmp_path, GOOD.replace('target = "ball"', f'target = "ball"\n{own}', 1))
    msg = error_of(p)
    assert msg.startswith(
        f"{display_path(p)}: effectors[0].solver.options.collision_pairs[0][1]: expected a "
        "geom of the model ("
    ), msg
    assert msg.endswith("), got 'belly'")


def test_collisions_true_points_to_collision_pairs(tmp_path):
    """The removed collisions = true says what replaced it."""
    text = GOOD.replace(_DLS, '[solver]\nname = "mink"\noptions = { collisions = true }', 1)
    msg = error_of(write(tmp_path, text))
    assert "solver.options: option 'collisions' of solver 'mink' was replaced by " in msg


def test_bundled_mink_scene_names_its_collision_pairs():
    """upper_body_mink keeps the humanoid's forearms and hands off torso, chest and head
    and the hands apart: its solver options derive those pairs from the limbs
    (``"limbs"``), the scene loads, and the solver keeps 13 geom pairs."""
    from humanoid_ik.solvers.mink.pairs import limb_collision_pairs

    scene = load_scene(bundled_scenes_dir() / "upper_body_mink.toml")
    assert scene.solver.name == "mink" and scene.solver.options["collision_pairs"] == "limbs"
    pairs = limb_collision_pairs(scene_model(scene))
    body = ("torso_collision", "chest_collision", "head_collision")
    as_sets = {(frozenset(a), frozenset(b)) for a, b in pairs}
    assert len(pairs) == 3 and as_sets == {
        (frozenset(("right_forearm_collision", "right_hand_collision")), frozenset(body)),
        (frozenset(("left_forearm_collision", "left_hand_collision")), frozenset(body)),
        (frozenset(("left_hand_collision",)), frozenset(("right_hand_collision",))),
    }
    from humanoid_ik.core.types import EffectorGoal

    chains = check_scene(scene)
    goals = [
        EffectorGoal(c, scene.target(e.target).at(0.0), c.q_home, e.task)
        for c, e in zip(chains, scene.effectors, strict=True)
    ]
    limit = scene.solver.make().upper_body_for(goals).collision_limit
    assert limit is not None and len(limit.geom_id_pairs) == 13


def test_pose_target_rejects_position_only_solver(tmp_path):
    """A pose target with a position-only solver fails at the solver key with the reason."""
    text = (
        GOOD.replace("radius = 0.1 }", "radius = 0.1 }\norientation = { quat = [1, 0, 0, 0] }")
        .replace('name = "dls"', 'name = "two_link"')
        .replace("options = { restarts = 0 }", "")
    )
    msg = error_of(write(tmp_path, text))
    assert msg.endswith(
        "solver.name: solver 'two_link' cannot drive effectors[0] (right_palm_site): "
        "two_link solves position targets only"
    )


def test_orientation_errors(tmp_path):
    """Orientation tables: unknown key, missing quat and a non-unit quat each name the key."""
    base = GOOD.replace("radius = 0.1 }", "radius = 0.1 }\norientation = ORIENT")
    cases = {
        "{ quat = [1, 0, 0, 0], spin = 1 }": "targets[0].orientation.spin: unknown key",
        "{ axis = [0, 0, 1] }": "targets[0].orientation.quat: missing; expected a unit quaternion",
        "{ quat = [1, 1, 0, 0] }": "targets[0].orientation.quat: expected a unit quaternion",
        "3": "targets[0].orientation: expected a table, got 3",
    }
    for orient, message in cases.items():
        msg = error_of(write(tmp_path, base.replace("ORIENT", orient)))
        assert message in msg, msg


def test_look_at_effector_rejects_pose_target(tmp_path):
    """A look_at effector on a pose target fails at its task key."""
    text = GOOD.replace(
        "radius = 0.1 }", "radius = 0.1 }\norientation = { quat = [1, 0, 0, 0] }"
    ).replace('site = "right_palm_site"', 'site = "gaze_site"\ntask = "look_at"')
    assert "effectors[0].task: expected 'reach' for pose target 'ball'" in error_of(
        write(tmp_path, text)
    )


def test_duplicates_are_rejected(tmp_path):
    """Two targets with one name, two effectors on one site, and two effectors sharing a
    joint are each reported at the second one's key."""
    twice_target = GOOD + (
        '\n[[targets]]\nname = "ball"\nmotion = { kind = "points", points = [[0.3, -0.3, 1.1]] }\n'
    )
    assert "targets[1].name: expected a name not used by another target" in error_of(
        write(tmp_path, twice_target)
    )
    twice_site = GOOD + '\n[[effectors]]\nsite = "right_palm_site"\ntarget = "ball"\n'
    assert "effectors[1].site: expected a site no other effector uses" in error_of(
        write(tmp_path, twice_site)
    )
    shared = GOOD + '\n[[effectors]]\nsite = "right_wrist_site"\ntarget = "ball"\n'
    assert (
        "effectors[1].joints: joint 'right_shoulder_flexion_joint' is already moved by "
        "effectors[0]" in error_of(write(tmp_path, shared))
    )


def test_file_level_errors(tmp_path):
    """Not TOML, a missing model and a non-table solver each give one line with the file."""
    p = write(tmp_path, "duration = = 2\n")
    msg = error_of(p)
    assert msg.startswith(f"{display_path(p)}: not valid TOML: ")
    p = write(tmp_path, 'model = "nowhere.xml"\n' + GOOD)
    assert "model: expected an MJCF or URDF file, got 'nowhere.xml' (not found)" in error_of(p)
    p = write(
        tmp_path, GOOD.replace('[solver]\nname = "dls"\noptions = { restarts = 0 }', "solver = 3")
    )
    assert "solver: expected a table, got 3" in error_of(p)
    p = write(
        tmp_path, GOOD.replace('[[effectors]]\nsite = "right_palm_site"\ntarget = "ball"', "")
    )
    assert "effectors: missing; expected an array of tables" in error_of(p)
    text = GOOD.replace('name = "probe"', 'name = "probe"\neffectors = [1]', 1)
    text = text[: text.index("[[effectors]]")]
    assert "effectors[0]: expected a table, got 1" in error_of(write(tmp_path, text))
    text = GOOD.replace('name = "probe"', 'name = "probe"\ntargets = 3', 1)
    text = text[: text.index("[[targets]]")] + text[text.index("[[effectors]]") :]
    assert "targets: expected an array of tables" in error_of(write(tmp_path, text))
    d = tmp_path / "folder.toml"
    d.mkdir()
    with pytest.raises(SceneError):
        load_scene(d)


def test_broken_model_is_a_scene_error(tmp_path):
    """A model that does not compile is reported at the model key."""
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><geom/></worldbody>")
    p = write(tmp_path, 'model = "bad.xml"\n' + GOOD)
    assert "model: model " in error_of(p)


def test_check_scene_of_a_python_built_scene():
    """A Scene built in Python is checked too; messages name it <scene 'name'>."""
    from humanoid_ik.config.scene import EffectorSpec
    from humanoid_ik.motion import Circle, TargetTrack

    sc = Scene(
        name="py",
        duration=1.0,
        fps=10,
        solver=SolverSpec("dls"),
        targets=(TargetTrack("t", Circle([0.4, -0.3, 1.2], 0.1)),),
        effectors=(EffectorSpec("right_palm_site", "t"),),
        render=RenderSpec(width=64, height=48, camera="nowhere"),
    )
    with pytest.raises(SceneError, match=r"^<scene 'py'>: render.camera: expected one of front"):
        check_scene(sc)
    with pytest.raises(SceneError, match=r"no target 'u'; targets: 't'"):
        sc.target("u")
    with pytest.raises(SceneError, match=r"task: expected one of"):
        EffectorSpec("right_palm_site", "t", task="grab")
    ok = Scene(
        name="py",
        duration=1.0,
        fps=10,
        solver=SolverSpec("dls"),
        targets=sc.targets,
        effectors=sc.effectors,
    )
    chains = check_scene(ok)
    assert chains[0].ee_name == "right_palm_site" and chains[0].n == 7
    bad_fps = Scene(
        name="py",
        duration=1.0,
        fps=float("nan"),
        solver=SolverSpec("dls"),
        targets=sc.targets,
        effectors=sc.effectors,
    )
    with pytest.raises(SceneError, match=r"fps: expected a number >= 0.01 and <= 1000, got nan"):
        check_scene(bad_fps)
    odd = replace(ok, render=RenderSpec(width=65))
    with pytest.raises(SceneError, match=r"render.width: expected an even integer >= 16"):
        check_scene(odd)
    # the bounds hold for a scene built in code too (docs/limits.md)
    walk = TargetTrack("t", RandomWalk([0.4, -0.3, 1.2], [0.1] * 3, interval=1e-9))
    for changed, message in (
        (replace(ok, duration=1e300), r"duration: expected a number > 0 and <= 10000 \(at most"),
        (replace(ok, duration=math.inf), r"duration: expected a number > 0, got inf"),
        (replace(ok, fps=0.001), r"fps: expected a number >= 0.01 and <= 1000, got 0.001"),
        (replace(ok, render=RenderSpec(trail=1e300)), r"render.trail: expected a number >= 0 and"),
        (replace(ok, render=RenderSpec(width=8192)), r"render.width: expected an even integer"),
        (replace(ok, render=RenderSpec(contact_sheet=10**6)), r"render.contact_sheet: expected"),
        (replace(ok, render=RenderSpec(snapshots=(0.0,) * 101)), r"render.snapshots: expected at"),
        (
            replace(ok, targets=(walk,)),
            r"targets\[0\].motion.interval: expected a number >= 9e-06 \(a random_walk draws",
        ),
    ):
        with pytest.raises(SceneError, match=message):
            check_scene(changed)


def test_solver_table_is_the_solvers_typed_options(tmp_path):
    """[solver] is validated into the solver's typed options object: the file's values,
    the class's defaults for the rest; an effector's own solver too."""
    from humanoid_ik.solvers.jacobian.dls import DLS

    own = 'solver = { name = "ccd", options = { max_iterations = 7 } }'
    sc = load_scene(write(tmp_path, GOOD.replace('target = "ball"', f'target = "ball"\n{own}')))
    typed = sc.solver.typed
    assert isinstance(typed, DLS.Options) and typed.restarts == 0
    assert typed.max_iterations == DLS.Options().max_iterations
    assert sc.effectors[0].solver.typed.max_iterations == 7


def test_help_and_library_do_not_import_pydantic():
    """pydantic (the file models) is loaded when a file is parsed, not by `--help`."""
    import subprocess
    import sys

    code = (
        "import sys\nfrom humanoid_ik.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "assert 'pydantic' not in sys.modules\n"
        "from humanoid_ik.config.scene import load_scene\nload_scene('circle')\n"
        "assert 'pydantic' in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


def test_check_scene_refuses_a_name_that_is_not_a_name():
    """A Python-built scene's name becomes its output folder (renders/<name>): check_scene
    refuses one that would lead out of it, in one line, as a file's name is refused."""
    from humanoid_ik.config.scene import EffectorSpec
    from humanoid_ik.motion import Circle, TargetTrack

    ok = Scene(
        name="py",
        duration=1.0,
        fps=10,
        solver=SolverSpec("dls"),
        targets=(TargetTrack("t", Circle([0.4, -0.3, 1.2], 0.1)),),
        effectors=(EffectorSpec("right_palm_site", "t"),),
    )
    assert len(check_scene(ok)) == 1
    for bad in ("../escape", "/abs", "a b", "", ".hidden"):
        with pytest.raises(SceneError) as info:
            check_scene(replace(ok, name=bad))
        message = str(info.value)
        assert message.startswith(f"<scene '{bad}'>: name: expected ") and "\n" not in message
        assert message.endswith(f"got {bad!r}")
