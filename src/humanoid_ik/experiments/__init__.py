"""Experiments over many solves: the benchmark (``bench``), sweeps (``sweep``) and IK
datasets (``dataset``)."""
