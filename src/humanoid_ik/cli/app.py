"""The ``humanoid-ik`` command line. ``main(argv) -> int`` serves the console script and
``python -m humanoid_ik`` alike; each command lives in its own module of this package.

Exit codes: 0 success; 1 a solve that did not converge; 2 bad input (one line on
stderr, no traceback unless ``--debug``, which is accepted before or after the command);
130 interrupted (Ctrl-C); 143 terminated (SIGTERM, handled like Ctrl-C); 141 the reader
of the output went away (``humanoid-ik scenes | head -1``: no message).
"""

from __future__ import annotations

import _thread
import argparse
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Sequence
from importlib.metadata import version
from typing import Any, TextIO

from humanoid_ik.cli import (
    bench,
    dataset,
    export,
    inspect,
    render,
    replay,
    retarget,
    run,
    scenes,
    solve,
    sweep,
    view,
)
from humanoid_ik.cli.args import Parser, add_joints_arg, add_package_arg
from humanoid_ik.cli.interrupts import interrupted
from humanoid_ik.core.robot_files import ModelWarning
from humanoid_ik.errors import HumanoidIKError

__all__ = ["build_parser", "main"]

_COMMANDS: tuple[Any, ...] = (solve, bench, inspect, render, scenes, run, replay, export, view)
_COMMANDS += (sweep, dataset, retarget)
_MODEL_COMMANDS = ("inspect", "view", "replay", "export-bvh", "export-keyframes")
"""The commands with a ``--model`` of their own (not ``add_chain_args``'), which get
``--package-path`` here: every command that takes ``--model`` takes it."""
_JOINTS_COMMANDS = ("inspect", "view")
"""The commands with an end effector of their own that get ``--joints`` here, as the
``add_chain_args`` commands (solve, bench, dataset) have it."""

EXIT_INTERRUPTED = 130
"""Ctrl-C: 128 + SIGINT."""
EXIT_BROKEN_PIPE = 141
"""The output's reader closed the pipe: 128 + SIGPIPE, what a shell shows."""
EXIT_TERMINATED = 143
"""SIGTERM: 128 + SIGTERM."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so it stops as Ctrl-C does (the frame
    loop's and the commands' Ctrl-C handling applies), then exits 143."""


class _Version(argparse.Action):
    """``--version``: the package and MuJoCo (imported only when asked, so other
    commands start without it)."""

    def __call__(self, parser, namespace, values, option_string=None):
        import mujoco

        print(f"humanoid-ik {version('humanoid-ik')} (mujoco {mujoco.__version__})")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The parser of every command."""
    parser = Parser(
        prog="humanoid-ik", description="Inverse kinematics for humanoid arms on MuJoCo."
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    parser.add_argument(
        "--version", action=_Version, nargs=0, help="show the version and the build, then exit"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for command in _COMMANDS:
        command.register(sub)
    for name, command_parser in sub.choices.items():
        command_parser.add_argument(
            "--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS
        )
        if name in _MODEL_COMMANDS:
            add_package_arg(command_parser)
        if name in _JOINTS_COMMANDS:
            add_joints_arg(command_parser)
    return parser


def _quiet_stdout() -> None:
    """Point stdout at the null device, so the interpreter's last flush into a closed pipe
    raises nothing (the recipe of Python's ``signal`` documentation)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is not a real file (a test's)
        pass


def _show_notes() -> Any:
    """A ``warnings.showwarning`` that prints a :class:`ModelWarning` (a model file's
    mistake fixed while loading) as one ``humanoid-ik: note: ...`` line on stderr, and
    any other warning as Python does."""
    shown = warnings.showwarning

    def show(
        message: Warning | str,
        category: type[Warning],
        filename: str,
        lineno: int,
        file: TextIO | None = None,
        line: str | None = None,
    ) -> None:
        if issubclass(category, ModelWarning):
            print(f"humanoid-ik: note: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    return show


REDELIVERY_DELAY = 0.05
"""[s] after which an interrupt Python could not raise is delivered again: long enough
for the unraisable hook to have returned, so it is raised in the program's own code."""


def _deliver_later(signum: signal.Signals) -> None:
    time.sleep(REDELIVERY_DELAY)
    _thread.interrupt_main(signum)


def _interrupts_delivered_again() -> Any:
    """A ``sys.unraisablehook`` for a Ctrl-C or SIGTERM that landed where Python cannot
    raise it (a finaliser, the import system's module-lock callback): Python would print
    ``Exception ignored in ...`` and go on as if no signal had come. This one prints
    nothing and delivers the signal again a moment later from a bare thread (started
    without ``threading``'s hand-shake, so the hook returns at once), so that it is
    raised in the main thread's code and stops the command as a signal should."""
    shown = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        exc = unraisable.exc_value
        if not isinstance(exc, KeyboardInterrupt):
            shown(unraisable)
            return
        signum = signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT
        _thread.start_new_thread(_deliver_later, (signum,))

    return hook


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    from humanoid_ik.core.mujoco_warnings import mujoco_warnings

    unraisable = sys.unraisablehook
    sys.unraisablehook = _interrupts_delivered_again()
    try:  # MuJoCo's warnings (it would print them and write a MUJOCO_LOG.TXT): notes
        with warnings.catch_warnings(), mujoco_warnings():
            warnings.showwarning = _show_notes()
            warnings.simplefilter("default", ModelWarning)  # each note once
            return _main(argv)
    finally:
        sys.unraisablehook = unraisable


def _main(argv: Sequence[str] | None) -> int:
    args_list = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args_list
    sigterms: list[int] = []

    def on_sigterm(signum: int, frame: object) -> None:
        sigterms.append(signum)
        raise Terminated()

    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, on_sigterm) if in_main_thread else None
    try:
        args = build_parser().parse_args(args_list)
        code = int(args.func(args))
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        # a command that handles Ctrl-C itself (render) stopped early on SIGTERM
        return EXIT_TERMINATED if sigterms and code == EXIT_INTERRUPTED else code
    except HumanoidIKError as exc:
        if debug:
            traceback.print_exc()
        print(f"humanoid-ik: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        _quiet_stdout()
        return EXIT_BROKEN_PIPE
    except OSError as exc:
        if debug:
            traceback.print_exc()
        print(
            f"humanoid-ik: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return 2
    except (KeyboardInterrupt, Exception) as exc:  # compiled code may report one otherwise
        if not interrupted(exc):
            raise
        print(f"humanoid-ik: {'terminated' if sigterms else 'interrupted'}", file=sys.stderr)
        return EXIT_TERMINATED if sigterms else EXIT_INTERRUPTED
    except SystemExit as exc:  # --help
        return int(exc.code or 0)
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
