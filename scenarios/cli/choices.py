"""Choices of the command-line options, read from the registries when a parser is built.

``--controller``, ``--estimator``, ``--object`` and ``--generator`` take the
names registered at the time the subcommand's parser is built, so a kind
registered by a plugin (or a test) is offered without editing any command.
Importing this module imports only the light registry modules.
"""

from __future__ import annotations

from collections.abc import Sequence

from scenarios.cli.errors import UnknownChoiceError
from scenarios.schema.models import (
    controller_names,
    estimator_choices,
    generator_names,
    object_names,
)

__all__ = ["check_choice", "controller_names", "estimator_choices", "generator_names",
           "object_names", "one_of"]


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
