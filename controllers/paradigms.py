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
                          rises in proportion to the signal: CALIBRATION.md);
                          with a decoder, also released by the open signal
velocity                  the clinical two-signal paradigm: the close signal
                          closes and the open signal opens, each at a speed in
                          proportion to its level; at stall the grip is in
                          proportion to the close signal (VarioDual); with
                          both relaxed the motor stops and the drive holds
========================  ===================================================

**Decoded signals.** A paradigm that uses them (``uses_decoder``) also receives, at every
control step, the latest window's :class:`Decoded` (:mod:`estimation.decoding`: the close
and open levels, 0..1, at most one nonzero, and the grip the close level asks for, N);
one that needs them (``needs_decoder``: ``velocity``) cannot run without a calibration that
fitted a decoder, which needs open contractions. After each step a paradigm's
``command_range`` bounds the motor command (normalized, -1..1) the force loop may send:
that is how ``velocity`` sets the speed of closing and opening and stops the motor.

**Why VarioDual, not DigitalControl.** Ottobock's two clinical modes differ at stall:
VarioDual's grip grows in proportion to the close signal, DigitalControl's with how long
the signal is held, at a constant speed (CALIBRATION.md, "Clinical hands"). ``velocity``
reproduces VarioDual: griploop's decoders give a proportional level every window, the
force loop turns a level into a grip directly, and a grip that grows with holding time
would make every grip depend on the 125 ms window clock and on how long the person keeps
contracting after contact, which the virtual user does not plan.

``force_hold`` uses the relax-to-open rule griploop already has: the rest gate opens
when the estimate falls below its lower edge (the median of the estimate at rest in the
calibration), and the gated estimate is then 0. A new paradigm is a class with
``reset()`` and ``step(reference_n) -> reference_n`` (``step(reference_n, decoded)`` when
it sets ``uses_decoder``), registered with :func:`register_paradigm` (by object or
``"module:attribute"``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from sim.errors import GriploopError
from sim.registry import Registry


class UnknownParadigmError(GriploopError, LookupError):
    """A paradigm that is not registered; the message lists the registered ones."""


class DecoderMissingError(GriploopError, ValueError):
    """A paradigm that needs open and close signals, run without a fitted decoder."""


#: The motor command's full range (normalized): no bound.
FULL_RANGE = (-1.0, 1.0)


@dataclass(frozen=True)
class Decoded:
    """What the decoder made of the latest feature window (module notes).

    Attributes
    ----------
    close, open : float
        The close and open levels, 0..1 (at most one nonzero): the speed asked for.
    grip_n : float
        The hand grip the close level asks for at stall, N (the close level times the hand
        force at the user's MVC).
    """

    close: float = 0.0
    open: float = 0.0
    grip_n: float = 0.0


RELAXED = Decoded()
"""Neither signal: what a paradigm sees before the first window."""


class Paradigm(Protocol):
    """Shapes the reference a control step hands to the force loop (module notes)."""

    name: str

    def reset(self) -> None: ...

    def step(self, reference_n: float) -> float: ...


def uses_decoder(paradigm: Any) -> bool:
    """Whether ``paradigm.step`` takes the decoded signals as its second argument."""
    return bool(getattr(paradigm, "uses_decoder", False))


def needs_decoder(name: str) -> bool:
    """Whether the registered paradigm ``name`` cannot run without a decoder."""
    return bool(getattr(make_paradigm(name), "needs_decoder", False))


def command_range(paradigm: Any) -> tuple[float, float]:
    """The bounds ``paradigm`` puts on the motor command after its last step."""
    return getattr(paradigm, "command_range", FULL_RANGE)


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
    With a decoder (``decoded`` given), an open signal releases the hold as well, and the
    output stays 0 while it lasts.
    """

    name = "force_hold"
    uses_decoder = True

    def __init__(self) -> None:
        self.held_n = 0.0

    def reset(self) -> None:
        """Released, as at rest."""
        self.held_n = 0.0

    def step(self, reference_n: float, decoded: Decoded | None = None) -> float:
        """The held reference, N."""
        if decoded is not None and decoded.open > 0.0:
            self.held_n = 0.0
        elif reference_n > 0.0:
            if reference_n > self.held_n:
                self.held_n = reference_n
        else:
            self.held_n = 0.0
        return self.held_n


class Velocity:
    """The clinical two-signal paradigm (module notes; VarioDual at stall).

    At each step with the latest :class:`Decoded` ``d``:

    - ``d.open > 0``: the grip is released (reference 0) and the motor opens at a speed in
      proportion to the open level: ``command_range = (-d.open, 0)``;
    - ``d.close > 0``: the reference is the largest ``d.grip_n`` since the hand was last
      opened, and the motor closes at a speed in proportion to the close level:
      ``command_range = (0, d.close)`` (a weaker signal never loosens the grip: the motor
      only closes, and stalls at a force in proportion to its command);
    - neither: the motor stops (``command_range = (0, 0)``); a self-locking drive holds the
      grip, a backdrivable one lets the object push the digits open.

    The force estimate (``reference_n``) is not used: the grip comes from the close signal.
    """

    name = "velocity"
    uses_decoder = True
    needs_decoder = True

    def __init__(self) -> None:
        self.held_n = 0.0
        self.command_range = (0.0, 0.0)

    def reset(self) -> None:
        """Open and stopped, as at rest."""
        self.held_n = 0.0
        self.command_range = (0.0, 0.0)

    def step(self, reference_n: float, decoded: Decoded | None = None) -> float:
        """The held grip reference, N; sets :attr:`command_range`.

        Raises
        ------
        DecoderMissingError
            No decoded signals (a calibration without a decoder).
        """
        if decoded is None:
            raise DecoderMissingError(
                "paradigm velocity needs open and close signals; expected a calibration with "
                "open contractions and a decoder (--decoder two_site or pattern)")
        if decoded.open > 0.0:
            self.held_n = 0.0
            self.command_range = (-min(decoded.open, 1.0), 0.0)
        elif decoded.close > 0.0:
            if decoded.grip_n > self.held_n:
                self.held_n = decoded.grip_n
            self.command_range = (0.0, min(decoded.close, 1.0))
        else:
            self.command_range = (0.0, 0.0)
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
register_paradigm("velocity", Velocity)
