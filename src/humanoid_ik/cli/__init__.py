"""The ``humanoid-ik`` command line: one module per command, :mod:`.app` ties them up."""

from humanoid_ik.cli.app import build_parser, main

__all__ = ["build_parser", "main"]
