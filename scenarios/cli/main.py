"""The ``griploop`` command line.

Subcommands live in :mod:`scenarios.cli.commands`, one module each, listed in
:data:`COMMANDS` with their one-line help so that ``griploop --help`` imports
none of them: only the chosen subcommand's module is imported (``griploop
--help`` answers in a fraction of a second). Errors a user can cause (bad
files, bad options, infeasible designs) are :class:`~sim.errors.GriploopError`
subclasses; they, and the operating system refusing a file (``OSError``), are
printed as one line on stderr with exit status 2. Any other exception is a bug:
it is printed as one ``internal error`` line naming the file and line where it
was raised, with exit status 1. Set ``GRIPLOOP_TRACEBACK=1`` to see the
traceback instead.

Ctrl-C (SIGINT) and SIGTERM stop a command with exit status 130 and 143
(128 + the signal number), after its clean-up ran (a sweep releases its claims
and stops its worker processes; nothing is recorded as failed).

MuJoCo chooses its OpenGL backend when first imported; :mod:`sim` selects a
headless one when none is set and there is no display. Matplotlib draws with
Agg (set here, before any command module is loaded).
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import traceback
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

from scenarios.checks import load_recorded
from scenarios.execution.interrupt import exit_status, raise_on_stop
from scenarios.plugins import PluginError
from sim.errors import GriploopError

#: What a user can cause: griploop's own errors (bad files, options, infeasible designs)
#: and the operating system refusing a file (missing, unreadable, disk full).
USER_ERRORS = (GriploopError, OSError)

#: ``name -> (module, one-line help)`` of every subcommand, in the order of ``--help``.
#: Each module defines ``register(subparsers)`` (adding its parser with the same help)
#: and ``run(args) -> int``; ``tests/scenarios/test_cli.py`` checks the two helps agree.
COMMANDS: dict[str, tuple[str, str]] = {
    "calibrate": ("scenarios.cli.commands.calibrate",
                  "record the paper's calibration session from a live sEMG stream (LSL)"),
    "check": ("scenarios.cli.commands.check",
              "check what a plugin registered: controllers, estimators, objects, scenario kinds"),
    "compare-references": ("scenarios.cli.commands.compare_references",
                           "grasp one object with references from several estimators and the "
                           "oracle"),
    "demo": ("scenarios.cli.commands.demo",
             "run the main job on embedded defaults and write a report"),
    "eggs": ("scenarios.cli.commands.eggs",
             "Virtual Eggs Test: transfer 11 fragile blocks, feedback modes side by side"),
    "episode": ("scenarios.cli.commands.episode",
                "run one closed-loop grasp-lift-hold episode from sEMG to the MuJoCo hand"),
    "evaluate": ("scenarios.cli.commands.evaluate",
                 "fit and score every force estimator on one recording"),
    "export": ("scenarios.cli.commands.export", "write a results store as Parquet and CSV tables"),
    "export-c": ("scenarios.cli.commands.export_c",
                 "write the fitted estimator and the designed controller as C99 for a "
                 "microcontroller"),
    "force-matching": ("scenarios.cli.commands.force_matching",
                       "hold target grip forces: absolute error and CV, feedback modes side by "
                       "side"),
    "live": ("scenarios.cli.commands.live",
             "drive the simulated hand in real time from a live sEMG stream (LSL)"),
    "margins": ("scenarios.cli.commands.margins",
                "design a controller for an object and report its margins at each grip force"),
    "measure-loop": ("scenarios.cli.commands.measure_loop",
                     "measure L(jw) and |S(jw)| on the simulated hand by sine injection"),
    "plot-recording": ("scenarios.cli.commands.plot_recording",
                       "plot a recording: force above the stacked sEMG channels"),
    "report": ("scenarios.cli.commands.report",
               "write a self-contained HTML report of a results store"),
    "published": ("scenarios.cli.commands.published",
                  "the scoreboard: which published human findings griploop reproduces"),
    "reproduce": ("scenarios.cli.commands.reproduce",
                  "reproduce the paper's Tables 2 and 3 on virtual subjects"),
    "slip-recovery": ("scenarios.cli.commands.slip_recovery",
                      "recover a held object made to slip (rising load or involuntary "
                      "opening), feedback modes side by side"),
    "stream": ("scenarios.cli.commands.stream",
               "play a recording as a Lab Streaming Layer (LSL) sEMG stream"),
    "subjects": ("scenarios.cli.commands.subjects",
                 "simulate the paper's squeeze session for a virtual population"),
    "sweep": ("scenarios.cli.commands.sweep",
              "run a YAML sweep of scenarios into the results store (resumable)"),
    "transfers": ("scenarios.cli.commands.transfers",
                  "the Box and Blocks Test: blocks per minute, prosthesis and intact hand"),
}


def version() -> str:
    """The installed distribution's version (``importlib.metadata``), or ``unknown``."""
    from importlib import metadata

    try:
        return metadata.version("griploop")
    except metadata.PackageNotFoundError:
        return "unknown (not installed)"


def _chosen(argv: Sequence[str]) -> str | None:
    """The subcommand named in ``argv`` (the first word that is not an option or its value)."""
    words = iter(argv)
    for word in words:
        if word == "--plugin":
            next(words, None)
        elif not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def _plugins(argv: Sequence[str]) -> list[str]:
    """Modules named by ``--plugin MODULE`` (or ``--plugin=MODULE``) before the subcommand."""
    out, words = [], iter(argv)
    for word in words:
        if word == "--plugin":
            out.append(next(words, ""))
        elif word.startswith("--plugin="):
            out.append(word.partition("=")[2])
        elif not word.startswith("-"):
            break
    return out


def build_parser(command: str | None = "*") -> argparse.ArgumentParser:
    """The top-level parser.

    Parameters
    ----------
    command : str or None
        The subcommand whose module is imported and whose full parser is
        registered; ``"*"`` (default) imports every one, ``None`` none (the
        others are listed by name and help only).
    """
    parser = argparse.ArgumentParser(
        prog="griploop",
        description="Simulation-in-the-loop testbed for myoelectric prosthesis grip control.",
        epilog="griploop COMMAND --help describes a command. Exit status: 0 done, 2 user "
        "error, 130/143 stopped by Ctrl-C/SIGTERM.",
    )
    parser.add_argument("--version", action="version", version=f"griploop {version()}")
    parser.add_argument("--plugin", action="append", metavar="MODULE", default=[],
                        help="import MODULE first, which registers its own controllers, "
                        "estimators, objects or scenario kinds (repeatable)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, help_) in COMMANDS.items():
        if command in ("*", name):
            importlib.import_module(module).register(sub)
        else:
            sub.add_parser(name, help=help_, add_help=False)
    return parser


def one_line_warnings(command: str) -> Callable[..., None]:
    """A ``warnings.showwarning`` that prints griploop's own warnings in one line.

    A warning that is also a :class:`~sim.errors.GriploopError` (for example
    :class:`estimation.adaptive.AdaptationWarning`) is a message for the person at the
    terminal: ``griploop COMMAND: warning: MESSAGE`` on stderr, no file and line. Any
    other warning is shown as Python shows it.
    """
    default = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, GriploopError):
            text = str(message).splitlines()[0] if str(message) else category.__name__
            print(f"griploop {command}: warning: {text}", file=sys.stderr if file is None
                  else file)
            return
        default(message, category, filename, lineno, file, line)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``griploop`` console script; returns the exit status."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    argv = sys.argv[1:] if argv is None else list(argv)
    try:  # before the parser is built: its choices list what the plugins register
        load_recorded(_plugins(argv))  # what each added: ``griploop check`` checks it
    except PluginError as exc:
        print(f"griploop: error: {exc}", file=sys.stderr)
        return 2
    parser = build_parser(_chosen(argv))
    args = parser.parse_args(argv)
    try:
        with raise_on_stop(), warnings.catch_warnings():
            warnings.showwarning = one_line_warnings(args.command)
            return int(args.func(args) or 0)
    except USER_ERRORS as exc:
        if os.environ.get("GRIPLOOP_TRACEBACK"):
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"griploop {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM (interrupt.Interrupted)
        status = exit_status(exc)
        print(f"griploop {args.command}: stopped by {signal.Signals(status - 128).name}",
              file=sys.stderr)
        return status
    except Exception as exc:  # a bug in griploop or a library: say so, briefly
        if os.environ.get("GRIPLOOP_TRACEBACK"):
            raise
        where = traceback.extract_tb(exc.__traceback__)[-1]
        message = str(exc).splitlines()[0] if str(exc) else ""
        print(f"griploop {args.command}: internal error: {type(exc).__name__}: {message} "
              f"(at {Path(where.filename).name}:{where.lineno}; this is a bug, "
              "GRIPLOOP_TRACEBACK=1 shows the traceback)", file=sys.stderr)
        return 1


def entry() -> None:
    """The ``griploop`` console script: defer plotting modules, run :func:`main`, exit.

    python-control imports ``matplotlib.pyplot`` at import time; in the ``griploop``
    process it is loaded only if a figure is drawn (:mod:`scenarios.cli.deferred`).
    """
    from scenarios.cli.deferred import defer_plotting

    defer_plotting()
    sys.exit(main())


if __name__ == "__main__":
    entry()
