"""What became of a grasp: the four outcomes, and how a result row is classified.

Defined once here for the episode runner, the results store, the export and
the report (a light module: reading outcomes imports no simulator).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: Outcome categories of a grasp-lift-hold episode, best first.
OUTCOMES = ("held", "not_lifted", "dropped", "crushed")
#: The phases of a trial the user paces (:mod:`sim.user.reacting`), as coded in the
#: ``phase`` trace of an episode (the index in this tuple).
PHASE_CODES = ("grasp", "liftoff", "lift", "setdown", "release", "done", "hold")


def outcome_of(*, lifted: bool, dropped: bool, crushed: bool) -> str:
    """The episode's outcome, one of :data:`OUTCOMES` (a crush first, then a failed lift)."""
    if crushed:
        return "crushed"
    if not lifted:
        return "not_lifted"
    return "dropped" if dropped else "held"


def row_outcome(result: Mapping[str, Any]) -> str:
    """The outcome of a stored episode row.

    Its ``outcome`` field, or, for rows stored before that field existed,
    :func:`outcome_of` its flags (a row without ``lifted`` counts as lifted).
    """
    if result.get("outcome"):
        return str(result["outcome"])
    return outcome_of(lifted=bool(result.get("lifted", True)),
                      dropped=bool(result.get("dropped")), crushed=bool(result.get("crushed")))
