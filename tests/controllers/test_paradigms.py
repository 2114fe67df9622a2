"""Paradigms: how the hand's reference follows the estimate (force, force_hold)."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.paradigms import (
    RELAXED,
    Decoded,
    DecoderMissingError,
    ForceHold,
    UnknownParadigmError,
    make_paradigm,
    needs_decoder,
    paradigm_names,
    register_paradigm,
    unregister_paradigm,
)
from estimation.rest_gate import RestGate


def test_force_passes_the_reference_through() -> None:
    force = make_paradigm("force")
    values = [0.0, 3.0, 1.0, 0.0, 2.5]
    assert [force.step(v) for v in values] == values


def test_force_hold_keeps_the_grip_above_the_gates_lower_edge_and_releases_below_it() -> None:
    """Estimates through a rest gate (closed at 2 N, open below 1 N), mapped x3: the
    reference rises with them, never falls while they stay above 1 N, and is 0 at the first
    update below."""
    gate, hold = RestGate(on_n=2.0, off_n=1.0), ForceHold()
    estimates = np.array([0.5, 2.2, 3.0, 2.5, 1.4, 1.1, 3.5, 1.2, 0.9, 0.5, 2.5, 1.5])
    out = []
    for e in estimates:
        out.append(hold.step(3.0 * gate.step(float(e))))
    np.testing.assert_allclose(out, [0.0, 6.6, 9.0, 9.0, 9.0, 9.0, 10.5, 10.5, 0.0, 0.0, 7.5,
                                     7.5], rtol=1e-12)
    above = estimates >= 1.0
    first_below = int(np.flatnonzero(~above[1:] & above[:-1])[0]) + 1
    assert np.all(np.diff(out[1:first_below]) >= 0) and out[first_below] == 0.0
    hold.reset()
    assert hold.step(1.0) == 1.0 and hold.held_n == 1.0


def test_paradigms_are_a_registered_family() -> None:
    assert paradigm_names()[:3] == ("force", "force_hold", "velocity")
    with pytest.raises(UnknownParadigmError, match="force, force_hold, velocity"):
        make_paradigm("position")

    class Halve:
        name = "halve"

        def reset(self) -> None:
            pass

        def step(self, reference_n: float) -> float:
            return 0.5 * reference_n

    register_paradigm("halve", Halve)
    try:
        assert make_paradigm("halve").step(4.0) == 2.0
    finally:
        unregister_paradigm("halve")


def test_velocity_closes_and_opens_at_the_speed_of_each_signal_and_stops_when_both_relax(
        ) -> None:
    v = make_paradigm("velocity")
    assert needs_decoder("velocity") and not needs_decoder("force")
    with pytest.raises(DecoderMissingError, match="open and close signals"):
        v.step(3.0)
    # closing at 40 % speed asks for the grip of the close level, and never loosens it
    assert v.step(0.0, Decoded(close=0.4, grip_n=12.0)) == 12.0
    assert v.command_range == (0.0, 0.4)
    assert v.step(0.0, Decoded(close=0.2, grip_n=6.0)) == 12.0
    assert v.command_range == (0.0, 0.2)
    # both relaxed: the motor stops and the grip reference stays
    assert v.step(0.0, RELAXED) == 12.0 and v.command_range == (0.0, 0.0)
    # the open signal releases the grip and opens at its own speed
    assert v.step(0.0, Decoded(open=0.7)) == 0.0 and v.command_range == (-0.7, 0.0)
    assert v.step(0.0, Decoded(close=0.3, grip_n=9.0)) == 9.0
    v.reset()
    assert v.held_n == 0.0 and v.command_range == (0.0, 0.0)


def test_force_hold_also_releases_on_the_open_signal_when_there_is_one() -> None:
    hold = make_paradigm("force_hold")
    assert hold.step(5.0) == 5.0 and hold.step(3.0, RELAXED) == 5.0
    assert hold.step(3.0, Decoded(open=0.5)) == 0.0
    assert hold.step(2.0, RELAXED) == 2.0
