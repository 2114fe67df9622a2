"""The ``griploop`` command line.

Subcommands live in :mod:`scenarios.commands`, one module each. Errors a user
can cause (bad files, bad options, infeasible designs) are subclasses of
``ValueError``, ``OSError`` or ``LookupError``; they are printed as one line on
stderr with exit status 2. Set ``GRIPLOOP_TRACEBACK=1`` to see the traceback.

MuJoCo chooses its OpenGL backend when first imported, so headless EGL is
selected here, before any command module is loaded (an explicit ``MUJOCO_GL``
in the environment wins).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])
os.environ.setdefault("MPLBACKEND", "Agg")

import argparse  # noqa: E402
import importlib  # noqa: E402
import pkgutil  # noqa: E402
import sys  # noqa: E402
from collections.abc import Sequence  # noqa: E402

import scenarios.commands as _commands  # noqa: E402

USER_ERRORS = (ValueError, OSError, LookupError)


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every subcommand registered."""
    parser = argparse.ArgumentParser(
        prog="griploop",
        description="Simulation-in-the-loop testbed for myoelectric prosthesis grip control.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for info in sorted(pkgutil.iter_modules(_commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{_commands.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``griploop`` console script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except USER_ERRORS as exc:
        if os.environ.get("GRIPLOOP_TRACEBACK"):
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"griploop {args.command}: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"griploop {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
