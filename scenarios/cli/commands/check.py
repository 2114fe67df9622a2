"""``griploop check``: run the checkers for plugin authors on what a plugin registered.

Example::

    griploop --plugin my_grip_plugin check

checks every controller, estimator, object and scenario kind that ``my_grip_plugin``
registered (:mod:`scenarios.checks`); without ``--plugin``, everything registered,
griploop's own pieces included. Each failed check is one line on stdout
(``controller my_integral: reset_reproduces: expected ..., found ...``), then one error
line on stderr and exit status 2; a pass prints a one-line summary.
"""

from __future__ import annotations

import argparse
import sys

from scenarios.checks import check_all, plugin_registrations, registered_names

#: Plural of each family, for the summary.
_PLURAL = {"controller": "controllers", "estimator": "estimators", "object": "objects",
           "scenario kind": "scenario kinds"}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``check`` subcommand."""
    parser = subparsers.add_parser(
        "check",
        help="check what a plugin registered: controllers, estimators, objects, scenario kinds",
        description="Run the behavioural checks for plugin authors (docs/EXTENDING.md) on "
        "every controller, estimator, object and scenario kind the --plugin modules "
        "registered, or on everything registered without --plugin. Prints one line per "
        "failed check and exits with status 2 if any failed.",
    )
    parser.set_defaults(func=run)


def family_counts(names: dict[str, tuple[str, ...]]) -> str:
    """``1 controller, 2 objects`` (families with no name left out; ``nothing`` if none)."""
    parts = [f"{len(v)} {k if len(v) == 1 else _PLURAL.get(k, k + 's')}"
             for k, v in names.items() if v]
    return ", ".join(parts) or "nothing"


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    plugins = [p.strip() for p in args.plugin]
    names = plugin_registrations(plugins) if plugins else registered_names()
    if not any(names.values()):
        print(f"griploop check: OK: nothing to check ({', '.join(plugins)} registered no "
              "controller, estimator, object or scenario kind)")
        return 0
    scope = (f"{', '.join(plugins)} registered {family_counts(names)}" if plugins
             else f"{family_counts(names)} registered")
    failures = check_all(names)
    for failure in failures:
        print(failure.line())
    if failures:
        n = len(failures)
        subjects = dict.fromkeys(f"{f.family} {f.subject}" for f in failures)
        print(f"griploop check: error: {n} check{'s' if n != 1 else ''} failed on "
              f"{', '.join(subjects)} ({scope})", file=sys.stderr)
        return 2
    print(f"griploop check: OK: {scope}; each passed every check")
    return 0
