"""Choices of the command-line options, read from the registries when a parser is built.

``--controller``, ``--estimator``, ``--object`` and ``--generator`` take the
names registered at the time the subcommand's parser is built, so a kind
registered by a plugin (or a test) is offered without editing any command.
Importing this module imports only the light registry modules.
"""

from __future__ import annotations

from collections.abc import Sequence

from scenarios.cli.errors import UnknownChoiceError, UsageError
from scenarios.schema.names import (
    PRACTICE_RANGE,
    STEP_RANGE_MS,
    WINDOW_RANGE_MS,
    controller_names,
    decoder_names,
    drive_names,
    estimator_choices,
    feedback_modes,
    generator_names,
    object_names,
    paradigm_names,
    user_kinds,
)

__all__ = ["add_drive_option", "add_hand_options", "add_practice_window_options",
           "add_user_options", "check_choice", "check_drive", "check_hand_options",
           "check_practice_window", "check_user_options", "controller_names",
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


def add_drive_option(parser: object) -> None:
    """Add ``--drive``."""
    parser.add_argument("--drive", default="backdrivable", metavar="NAME",
                        help=f"the hand's transmission, {one_of(drive_names())} (default "
                        "backdrivable; self_locking: a worm stage, the digits hold without "
                        "motor torque)")


def check_drive(drive: str) -> None:
    """Refuse an unknown ``--drive`` in one line listing the registered drives."""
    check_choice("--drive", drive, drive_names())


def add_hand_options(parser: object, *, paradigm_list: bool = False) -> None:
    """Add ``--paradigm`` (a comma-separated list with ``paradigm_list``), ``--drive`` and
    ``--auto-grip``."""
    what = "comma-separated paradigms, each" if paradigm_list else "paradigm"
    parser.add_argument("--paradigm", default="force", metavar="LIST" if paradigm_list
                        else "NAME", help=f"{what} {one_of(paradigm_names())}: how the hand's "
                        "reference follows the estimate (default force, the paper's; "
                        "force_hold keeps the grip when the estimate falls and releases at rest; "
                        "velocity, the clinical one: a close and an open signal move the hand "
                        "at proportional speed)")
    parser.add_argument("--decoder", default=None, metavar="NAME",
                        help=f"open/close decoder {one_of(decoder_names())}, fitted on open "
                        "contractions added to the calibration (default: none, or "
                        "the default decoder where the paradigm needs one)")
    add_drive_option(parser)
    parser.add_argument("--auto-grip", action="store_true",
                        help="the hand's own slip response: the grip rises on a sensed slip")


def check_hand_options(paradigms: Sequence[str], drive: str, decoder: str | None = None
                       ) -> None:
    """Refuse an unknown ``--paradigm``, ``--drive`` or ``--decoder`` in one line listing the
    known ones.

    Raises
    ------
    UnknownChoiceError
    """
    for paradigm in paradigms:
        check_choice("--paradigm", paradigm, paradigm_names())
    check_drive(drive)
    if decoder is not None:
        check_choice("--decoder", decoder, decoder_names())


def add_practice_window_options(parser: object) -> None:
    """Add ``--practice``, ``--window-ms`` and ``--step-ms``."""
    lo, hi = PRACTICE_RANGE
    parser.add_argument("--practice", type=int, default=5, metavar="N",
                        help=f"practice lifts of the object's class before the measured trials, "
                        f"{lo}..{hi} (default 5; 0 is the novice)")
    parser.add_argument("--window-ms", type=float, default=400.0, metavar="W",
                        help=f"sEMG feature window, ms, {WINDOW_RANGE_MS[0]:g}..."
                        f"{WINDOW_RANGE_MS[1]:g} (default 400, the paper's)")
    parser.add_argument("--step-ms", type=float, default=125.0, metavar="S",
                        help=f"window increment, ms, {STEP_RANGE_MS[0]:g}..{STEP_RANGE_MS[1]:g}, "
                        "at most the window (default 125, the paper's)")


def check_practice_window(practice: int, window_ms: float, step_ms: float) -> None:
    """Refuse a practice count or a window out of range, or a window shorter than its step.

    Raises
    ------
    UsageError
        One line naming the flag.
    """
    lo, hi = PRACTICE_RANGE
    if not lo <= practice <= hi:
        raise UsageError(f"--practice: expected {lo}..{hi} lifts, found {practice}")
    for flag, value, (a, b) in (("--window-ms", window_ms, WINDOW_RANGE_MS),
                                ("--step-ms", step_ms, STEP_RANGE_MS)):
        if not a <= value <= b:  # NaN fails too
            raise UsageError(f"{flag}: expected {a:g}..{b:g} ms, found {value:g}")
    if step_ms > window_ms:
        raise UsageError(f"--step-ms: expected at most the window (--window-ms {window_ms:g}), "
                         f"found {step_ms:g}")
