"""Analytic solvers: ``two_link`` (law of cosines) and ``closed_form`` (7-DOF arm,
elbow swivel)."""
