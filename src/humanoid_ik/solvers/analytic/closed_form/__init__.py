"""Closed-form IK of a 7-hinge arm: spherical shoulder, elbow, spherical wrist.

The method of Tolani, Goswami and Badler (2000) for anthropomorphic limbs, on the
model's own hinge axes. A hand pose fixes the wrist point ``W``; the distance from the
shoulder ``S`` to ``W`` fixes the elbow by the law of cosines (two branches); what is
left is the *swivel* ``psi`` of the elbow about the line ``S -> W``. For each swivel the
shoulder rotation is ``R_sh(psi) = Rot(n, psi) R_ref`` (``n`` the unit ``S -> W``) and
the wrist rotation follows from the hand orientation; each is decomposed onto its three
hinge axes (two branches each, so up to eight joint vectors per swivel). Both are
linear in ``(cos psi, sin psi)``, and a hinge stands at a range end ``L`` exactly where
``k_c cos psi + k_s sin psi = d``: at most two roots per range end, so the feasible
swivel set is bounded by at most 24 roots per elbow branch (plus, for joints that
cannot reach every rotation, the swivels where they stop decomposing). The solver
returns the feasible swivel closest to a preferred one: the preferred swivel itself
when feasible, otherwise the nearest feasible root.

Swivel convention: ``psi = 0`` puts the elbow on the side of the ``S -> W`` line that
faces the model's gravity (straight down for ``gravity = 0 0 -9.81``; world ``-z`` when
gravity is zero; world ``x`` when the line is vertical); ``psi`` turns the elbow
right-handed about ``S -> W``. By default the preferred swivel is the current elbow's:
the swivel at which the elbow lies closest to where it is at the starting posture.

Position-only targets: the wrist keeps its starting angles, so the hand is a rigid
extension of the forearm; the same closed form then solves the shoulder and elbow for
the end effector's position (the swivel turns about ``S -> target``).

The modules, in the order they build on each other:

- :mod:`.numeric`: the arithmetics (floats for one target, numpy for a batch);
- :mod:`.geometry`: the arm's structure read from MuJoCo and its constants, kept with
  the chain;
- :mod:`.swivel`: what a target fixes and what is linear in the swivel (the one
  derivation), the swivel of a posture;
- :mod:`.joints`: the joint angles at a swivel, branch choice, gimbal lock;
- :mod:`.batch`: the vectorised driver (:func:`solve_batch`);
- :mod:`.single`: the one-target driver on floats;
- :mod:`.queries`: every branch at given swivels, the feasible swivel intervals;
- :mod:`.solver`: the :class:`ClosedForm` solver.
"""

from humanoid_ik.solvers.analytic.closed_form.batch import BatchSolution, solve_batch
from humanoid_ik.solvers.analytic.closed_form.geometry import (
    ArmGeometry,
    arm_geometry,
    structure_problem,
)
from humanoid_ik.solvers.analytic.closed_form.numeric import RANGE_TOL, TWO_PI
from humanoid_ik.solvers.analytic.closed_form.queries import (
    Branch,
    SwivelInterval,
    solutions,
    swivel_intervals,
)
from humanoid_ik.solvers.analytic.closed_form.solver import ClosedForm, ClosedFormOptions
from humanoid_ik.solvers.analytic.closed_form.swivel import swivel_angle

__all__ = [
    "ClosedForm",
    "ClosedFormOptions",
    "ArmGeometry",
    "Branch",
    "SwivelInterval",
    "BatchSolution",
    "arm_geometry",
    "structure_problem",
    "solutions",
    "swivel_intervals",
    "solve_batch",
    "swivel_angle",
    "RANGE_TOL",
    "TWO_PI",
]
