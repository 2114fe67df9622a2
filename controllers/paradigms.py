"""Paradigms: how the hand's command follows what was decoded from the person's sEMG.

A paradigm shapes the reference the force loop tracks, control step by control step,
as :class:`~controllers.reflex.SlipReflex` and :class:`~controllers.approach.ContactGate`
shape it: the force loops and their analysis stay as they are. Its input is the hand
reference the estimate asks for (the estimate through the rest gate and the force
mapping: exactly 0 while the gate is open, at rest), its output the reference the
controller tracks.

========================  ===================================================
paradigm                  the reference
========================  ===================================================
force                     follows the estimate up and down (the paper's, and
                          griploop's default)
force_hold                rises with the estimate; kept when the estimate falls
                          but stays above the rest gate's lower edge; released
                          when it falls below that edge (single-site, after
                          Ottobock's SensorHand Speed "VarioDual", whose grip
                          rises in proportion to the signal: CALIBRATION.md)
========================  ===================================================

``force_hold`` uses the relax-to-open rule griploop already has: the rest gate opens
when the estimate falls below its lower edge (the median of the estimate at rest in the
calibration), and the gated estimate is then 0. A new paradigm is a class with
``reset()`` and ``step(reference_n) -> reference_n``, registered with
:func:`register_paradigm` (by object or ``"module:attribute"``).
"""

from __future__ import annotations

from typing import Any, Protocol

from sim.errors import GriploopError
from sim.registry import Registry


class UnknownParadigmError(GriploopError, LookupError):
    """A paradigm that is not registered; the message lists the registered ones."""


class Paradigm(Protocol):
    """Shapes the reference a control step hands to the force loop (module notes)."""

    name: str

    def reset(self) -> None: ...

    def step(self, reference_n: float) -> float: ...


class Force:
    """The reference follows the estimate (the paper's paradigm)."""

    name = "force"

    def reset(self) -> None:
        """Nothing to forget."""

    def step(self, reference_n: float) -> float:
        """``reference_n`` itself, N."""
        return reference_n


class ForceHold:
    """The reference rises with the estimate, holds when it falls, opens at rest.

    At each step with the gated, mapped estimate ``r`` (N): while ``r > 0`` (the rest gate
    closed: the estimate above its lower edge) the output is the largest ``r`` since the
    gate closed; at ``r <= 0`` (the gate open) the hold is released and the output is 0.
    """

    name = "force_hold"

    def __init__(self) -> None:
        self.held_n = 0.0

    def reset(self) -> None:
        """Released, as at rest."""
        self.held_n = 0.0

    def step(self, reference_n: float) -> float:
        """The held reference, N."""
        if reference_n > 0.0:
            if reference_n > self.held_n:
                self.held_n = reference_n
        else:
            self.held_n = 0.0
        return self.held_n


_PARADIGMS = Registry("paradigm", UnknownParadigmError)


def register_paradigm(name: str, factory: Any, *, replace: bool = False) -> None:
    """Register a paradigm: ``factory() -> Paradigm`` or its ``"module:attribute"``."""
    _PARADIGMS.register(name, factory, replace=replace)


unregister_paradigm, paradigm_names = _PARADIGMS.functions(__name__, "paradigm")


def make_paradigm(name: str) -> Paradigm:
    """A fresh paradigm of a registered name.

    Raises
    ------
    UnknownParadigmError
        An unknown name; the message lists the registered paradigms.
    """
    return _PARADIGMS.get(name)()


register_paradigm("force", Force)
register_paradigm("force_hold", ForceHold)
