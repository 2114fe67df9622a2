"""Choices of the command-line options, read from the registries when a parser is built.

``--controller``, ``--estimator``, ``--object`` and ``--generator`` take the
names registered at the time the subcommand's parser is built, so a kind
registered by a plugin (or a test) is offered without editing any command.
Importing this module imports only the light registry modules.
"""

from __future__ import annotations

from collections.abc import Sequence

from scenarios.cli.errors import UnknownChoiceError
from scenarios.schema.names import (
    controller_names,
    estimator_choices,
    feedback_modes,
    generator_names,
    object_names,
    user_kinds,
)

__all__ = ["add_user_options", "check_choice", "check_user_options", "controller_names",
           "estimator_choices", "feedback_modes", "generator_names", "object_names", "one_of",
           "user_kinds"]


def one_of(names: Sequence[str]) -> str:
    """``"one of a, b, c"`` for a help text."""
    return f"one of {', '.join(names)}"


def check_choice(option: str, value: str, names: Sequence[str]) -> str:
    """``value`` if it is one of ``names``.

    Raises
    ------
    UnknownChoiceError
        One line: ``--option: expected one of [...], found 'value'``.
    """
    if value not in names:
        raise UnknownChoiceError(f"{option}: expected one of {list(names)}, found {value!r}")
    return value


def add_user_options(parser: object, *, feedback_list: bool = False,
                     default_feedback: str = "none") -> None:
    """Add ``--user`` and ``--feedback`` (a comma-separated list with ``feedback_list``)."""
    parser.add_argument("--user", default="reacting", metavar="KIND",
                        help=f"who drives the intent: {one_of(user_kinds())} (default reacting: "
                        "sees the hand and corrects; scripted follows the profile whatever "
                        "happens)")
    what = "comma-separated feedback modes, each" if feedback_list else "feedback mode"
    parser.add_argument("--feedback", default=default_feedback, metavar="LIST" if feedback_list
                        else "MODE", help=f"{what} {one_of(feedback_modes())} (default "
                        f"{default_feedback}; none is vision only; a reacting user only)")


def check_user_options(user: str, feedback: Sequence[str]) -> None:
    """Refuse an unknown ``--user`` or ``--feedback``, or feedback given to a scripted user.

    Raises
    ------
    UnknownChoiceError
        One line naming the valid choices.
    """
    from sim.user.operators import takes_feedback

    check_choice("--user", user, user_kinds())
    for mode in feedback:
        check_choice("--feedback", mode, feedback_modes())
    if not takes_feedback(user) and any(m != "none" for m in feedback):
        kinds = [k for k in user_kinds() if takes_feedback(k)]
        raise UnknownChoiceError(
            f"--feedback: the {user} user takes feedback none only (found "
            f"{','.join(feedback)}); feedback needs --user {' or '.join(kinds)}")
