"""What the checkers for plugin authors report: one :class:`~sim.checks.CheckFailure` each.

Each family that plugins extend has a behavioural checker in the style of
Gymnasium's ``check_env`` and scikit-learn's ``check_estimator``:
:func:`controllers.checks.check_controller`, :func:`estimation.checks.check_estimator`,
:func:`sim.hand.checks.check_object` and
:func:`scenarios.runners.kind_checks.check_scenario_kind`. Each runs a registered name
through the checks of its family and returns the failures, an empty list when it
passes; ``griploop check`` runs them on what a plugin registered and prints one line
per failure (:meth:`CheckFailure.line`).

The record lives in ``sim``, the layer every package may import.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CheckFailure:
    """One failed check of one registered name.

    Attributes
    ----------
    family : str
        What was checked: ``"controller"``, ``"estimator"``, ``"object"`` or
        ``"scenario kind"``.
    subject : str
        The registered name.
    check : str
        The check that failed (``"finite_output"``, ``"reset_reproduces"``, ...).
    expected : str
        What the check expected, with its tolerance.
    found : str
        What it found instead.
    """

    family: str
    subject: str
    check: str
    expected: str
    found: str

    def line(self) -> str:
        """``controller toy_nan: finite_output: expected ..., found ...`` (one line)."""
        found = " ".join(str(self.found).split())  # an error message stays on one line
        return f"{self.family} {self.subject}: {self.check}: expected {self.expected}, " \
               f"found {found}"

    def __str__(self) -> str:
        return self.line()


def raised(exc: BaseException) -> str:
    """``raised TypeError: message`` (the message's first line), for :attr:`CheckFailure.found`."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"raised {type(exc).__name__}: {text}" if text else f"raised {type(exc).__name__}"
