"""``auto`` on the arms of real robots (example-robot-data, ``tests/robots.py``) and of the
H1-like upper bodies of ``tests/models``: the exact solver where one applies, with every
reachable target reached, ``lm`` where the axes only nearly meet, and no solver listed
by ``inspect`` as applying where it misses targets the arm reaches.

Figures (time, and the near-miss measurement behind ``lm`` on the H1-like arm):
``benchmarks/real_arms.py``, ``docs/benchmarks.md``."""

from __future__ import annotations

import warnings
from functools import cache

import numpy as np
import pytest

from humanoid_ik import Chain, make_solver
from humanoid_ik.core.limbs import Profile, find_limbs, limb_chain
from humanoid_ik.core.models import load_model
from humanoid_ik.core.robot import Robot
from humanoid_ik.experiments.bench import make_targets
from humanoid_ik.experiments.limb_report import POSE_EXACT, limb_infos, limb_lines
from humanoid_ik.solvers.analytic.closed_form.geometry import MEET_TOL
from humanoid_ik.solvers.auto import Auto
from tests.chains import MODELS
from tests.robots import ROBOTS, robot_file

H1 = MODELS / "h1_arms.xml"
"""Shoulder axes that nearly meet (pitch and roll 16.5 mm apart, as on Unitree H1)."""
H1_SPHERICAL = MODELS / "h1_arms_spherical.xml"
"""The same arms with the roll hinge moved onto the pitch axis: a true spherical shoulder."""


@cache
def robot(name: str) -> tuple[Robot, Profile]:
    """A real robot (a key of ``ROBOTS``) or an H1-like model file, and its limbs."""
    path = robot_file(name) if name in ROBOTS else MODELS / f"{name}.xml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a home pose outside the ranges (HomeWarning)
        model = load_model(str(path))
    return Robot(model), find_limbs(model)


def arm(name: str, limb: str) -> Chain:
    rb, profile = robot(name)
    return limb_chain(rb, limb, profile=profile)


def reach_all(chain: Chain, solver, n: int, pose: bool, seed: int = 5) -> list[str]:
    """Solve ``n`` reachable targets (FK of random in-range joints) from home; return the
    solver that answered each, after checking each answer is on target within the
    ranges (MuJoCo FK of the returned joints)."""
    used = []
    for tgt in make_targets(chain, n, seed, pose):
        chain.reset()
        res = solver.solve(chain, tgt)
        assert res.converged, (chain, tgt, res.status, res.message)
        p, R = chain.fk(res.q)
        assert np.linalg.norm(p - tgt.position) < 1e-4
        if pose:
            assert res.orientation_error < 1e-3
        assert chain.within_limits(res.q, tol=1e-9)
        used.append(res.solver)
    return used


@pytest.mark.parametrize("name", ["romeo", "icub"])
@pytest.mark.parametrize("limb", ["left_arm", "right_arm"])
def test_romeo_and_icub_arms_are_solved_by_closed_form(name, limb):
    """Romeo's and iCub's arms are a spherical shoulder, an elbow and a spherical wrist:
    auto answers every reachable pose target with closed_form, exactly."""
    chain = arm(name, limb)
    auto = Auto()
    assert auto.choice(chain, True).name == "closed_form"
    assert auto.reason(chain, True) == "shoulder and wrist axes meet: exact"
    assert set(reach_all(chain, auto, 60, pose=True)) == {"closed_form"}


@pytest.mark.parametrize(
    ("name", "limb"),
    [("h1_arms_spherical", "left_arm"), ("h1_arms_spherical", "right_arm"), ("icub", "left_arm")],
)
def test_an_arm_two_link_places_whole_is_solved_by_two_link(name, limb):
    """A 4-joint arm with a true spherical shoulder (three hinges meeting, an elbow), and
    iCub's arm, whose hand frame is on its wrist's axes: auto answers every reachable
    position target with two_link."""
    chain = arm(name, limb)
    auto = Auto()
    assert auto.choice(chain, False).name == "two_link"
    assert auto.reason(chain, False).endswith(": exact")
    assert set(reach_all(chain, auto, 100, pose=False)) == {"two_link"}


def test_near_miss_h1_arm_gets_lm():
    """H1's shoulder axes pass 9 mm from one point: no exact solver applies (the reason
    says by how much), and auto runs lm, measured faster than two_link on the nearest
    spherical arm as a start plus an lm polish; lm reaches every target."""
    chain = arm("h1_arms", "left_arm")
    auto = Auto()
    assert auto.choice(chain, False).name == auto.choice(chain, True).name == "lm"
    why = make_solver("two_link").applicable(chain)
    assert why is not None and "pass up to 9.06 mm from one point" in why
    assert set(reach_all(chain, auto, 60, pose=False)) == {"lm"}
    assert set(reach_all(chain, auto, 30, pose=True)) == {"lm"}


@pytest.mark.parametrize(("offset", "meets"), [(0.2 * MEET_TOL, True), (4 * MEET_TOL, False)])
def test_axes_meet_within_the_stated_tolerance(offset, meets):
    """The roll hinge of the spherical H1-like shoulder moved ``offset`` off the pitch
    axis: the axes meet (two_link applies) within MEET_TOL, not beyond."""
    xml = H1_SPHERICAL.read_text().replace('pos="0 0.0565 0"', f'pos="0 0.0565 {-offset!r}"', 1)
    chain = Chain.from_xml_string(
        xml,
        "left_hand_site",
        [f"left_{j}_joint" for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")],
    )
    assert (make_solver("two_link").applicable(chain) is None) is meets
    assert (Auto().choice(chain, False).name == "two_link") is meets


@pytest.mark.parametrize("name", [*ROBOTS, "h1_arms", "h1_arms_spherical"])
def test_solvers_listed_as_applying_reach_reachable_targets(name):
    """Every solver inspect lists as applying to a real arm (closed_form and subproblem for
    pose, two_link for position targets) reaches every one of a few dozen reachable
    targets, and auto runs it there (not subproblem's search on 7 hinges, where auto runs
    closed_form or lm); a two_link that holds a wrist moving the hand is not
    listed."""
    rb, profile = robot(name)
    infos = [lb for lb in limb_infos(rb.model, profile) if lb.auto]
    assert infos, name
    listed = 0
    for info in infos:
        chain = limb_chain(rb, info.name, profile=profile)
        for solver, why in info.exact.items():
            pose = solver in POSE_EXACT
            if why is None:
                listed += 1
                if not (solver == "subproblem" and chain.n == 7):  # a search: auto keeps lm
                    assert (info.auto if pose else info.auto_position) == solver
                assert set(reach_all(chain, make_solver(solver), 24, pose)) == {solver}
    want = {  # subproblem's search on the 7-hinge arms of Talos, Romeo, iCub, PR2, TIAGo, Panda
        **{"romeo": 4, "icub": 6, "talos": 2, "pr2": 2, "tiago_dual": 2, "panda": 1},
        **{"h1_arms_spherical": 2, "ur5": 1, "kinova": 1},
    }.get(name, 0)
    assert listed == want, [lb.exact for lb in infos]


def test_inspect_says_which_solver_and_why():
    """The inspect lines of Romeo: closed_form for pose targets, lm for position targets
    because the exact solvers would hold the wrist; two_link is not said to apply."""
    rb, profile = robot("romeo")
    text = "\n".join(limb_lines(limb_infos(rb.model, profile)))
    assert "pose targets: auto runs closed_form (shoulder and wrist axes meet: exact)" in text
    assert (
        "position targets: auto runs lm (closed_form and two_link would hold the wrist and "
        "miss reachable targets)" in text
    )
    assert "two_link: no: two_link holds the 3 joint(s) after the elbow" in text
    assert "92.2 mm off their axes" in text
