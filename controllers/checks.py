"""Behavioural checks of a registered controller kind, for plugin authors.

:func:`check_controller` designs the kind with its default specification on
:func:`reference_plant` and runs it on :func:`standard_observations`. It checks,
in order (a failure of ``design``, ``act`` or ``loop`` stops the checks that need it):

``design``
    ``design_controller(name, reference_plant(), **default_spec(name))`` returns a
    controller (``reset``, ``act``, ``loop``).
``act``
    ``reset()`` then ``act(observation)`` on every observation raises nothing.
``finite_output``
    Every command is finite.
``command_range``
    Every command lies in -1..1 (``controllers.base.COMMAND_LIMITS``).
``reset_reproduces``
    ``reset()`` then the same observations again give the first run's commands
    within :data:`RESET_TOLERANCE`.
``loop``
    ``loop(reference_plant())`` returns an open loop that can be analysed.
``closed_loop_stable``
    That loop, closed, is stable (:func:`controllers.analysis.loop_margins`).
``stated_phase_margin``
    Where the specification (or the design's ``report_.spec``) states
    ``phase_margin_deg``, the loop has at least that phase margin, less
    :data:`MARGIN_TOLERANCE_DEG`.
``report_margins``
    Where the design carries a ``report_`` with ``margins`` (as
    :func:`~controllers.pid.design_pid` does), the loop's phase and gain margins are
    those reported, within :data:`MARGIN_TOLERANCE_DEG` and :data:`MARGIN_TOLERANCE_DB`.

Each returns :class:`sim.checks.CheckFailure` records, one line each.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.base import COMMAND_LIMITS, Observation
from controllers.registry import default_spec, design_controller
from sim.checks import CheckFailure, raised

if TYPE_CHECKING:
    import control

#: Gain of the reference plant ``gain / (tau s + 1)``, N per unit command (-1..1).
REFERENCE_GAIN_N = 50.0
#: Time constant of the reference plant, s.
REFERENCE_TIME_CONSTANT_S = 0.05
#: Control period of the reference plant (zero-order hold), s.
REFERENCE_DT_S = 0.01
#: Steps of the standard observation sequence (3 s at the reference period).
STANDARD_STEPS = 300
#: Largest difference between a run and its repetition after ``reset()``, command units.
RESET_TOLERANCE = 1e-9
#: Phase margin a design may fall short of its stated one, or differ from its report, deg.
MARGIN_TOLERANCE_DEG = 0.5
#: Gain margin a design may differ from its report by, dB.
MARGIN_TOLERANCE_DB = 0.1

_FAMILY = "controller"


def reference_plant() -> control.StateSpace:
    """The standard plant of the checks: ``50 / (0.05 s + 1)`` N per unit command, 10 ms ZOH.

    Returns
    -------
    control.StateSpace
        Discrete, ``dt`` = :data:`REFERENCE_DT_S`; input the normalized command,
        output the grip force in N.
    """
    import control

    continuous = control.tf([REFERENCE_GAIN_N], [REFERENCE_TIME_CONSTANT_S, 1.0])
    return control.c2d(control.ss(continuous), REFERENCE_DT_S)


def standard_observations(dt_s: float = REFERENCE_DT_S,
                          n_steps: int = STANDARD_STEPS) -> tuple[Observation, ...]:
    """The standard observation sequence of the checks: a grasp, a lift and a slip.

    The reference is 0 N for 0.2 s, then 5 N, ramps from 5 to 15 N over 1..2 s and
    drops to 3 N. The measured grip force follows it through an 80 ms first-order lag
    plus a 0.1 N ripple at 7 Hz; both sides touch from 0.1 s, the object (0.39 kg) is
    carried from 0.5 s and slips at 0.01 m/s during 1.5..1.6 s. No randomness.

    Parameters
    ----------
    dt_s : float
        Control period, s.
    n_steps : int
        Number of observations.

    Returns
    -------
    tuple of Observation
        ``n_steps`` observations at ``k * dt_s``.
    """
    t = np.arange(int(n_steps)) * float(dt_s)
    reference = np.select([t < 0.2, t < 1.0, t < 2.0], [0.0, 5.0, 5.0 + 10.0 * (t - 1.0)], 3.0)
    alpha = dt_s / (0.08 + dt_s)
    grip = np.zeros_like(t)
    for k in range(1, t.size):
        grip[k] = grip[k - 1] + alpha * (reference[k - 1] - grip[k - 1])
    grip += 0.1 * np.sin(2.0 * np.pi * 7.0 * t)
    velocity = np.gradient(grip, dt_s) * 0.002  # rad/s of the finger joint: ~2 mrad per N
    slipping = (t >= 1.5) & (t < 1.6)
    weight_n = 0.386 * 9.81
    return tuple(
        Observation(time_s=float(t[k]), reference_n=float(reference[k]),
                    grip_force_n=float(grip[k]), finger_velocity=float(velocity[k]),
                    slip_detected=bool(slipping[k]), slip_speed_m_s=0.01 * bool(slipping[k]),
                    thumb_contact=bool(t[k] >= 0.1), finger_contact=bool(t[k] >= 0.1),
                    finger_position_rad=0.3 + 0.002 * float(grip[k]),
                    load_force_n=weight_n * bool(t[k] >= 0.5),
                    lift_force_n=weight_n * bool(t[k] >= 0.5))
        for k in range(t.size))


def check_controller(name: str) -> list[CheckFailure]:
    """Check the registered controller kind ``name`` (the checks of the module docstring).

    Parameters
    ----------
    name : str
        A registered controller kind (:func:`controllers.registry.controller_names`).

    Returns
    -------
    list of CheckFailure
        One per failed check; empty when the controller passes.

    Raises
    ------
    controllers.errors.UnknownControllerError
        ``name`` is not registered.
    """
    plant = reference_plant()
    spec = default_spec(name)  # raises for an unknown name, before any check
    try:
        controller = design_controller(name, plant, **spec)
    except Exception as exc:  # a plugin's design may raise anything: that is the finding
        return [_failure(name, "design", "a controller from the default specification on "
                         "the reference plant", raised(exc))]
    failures = _check_runs(name, controller, standard_observations(REFERENCE_DT_S))
    return failures + _check_loop(name, controller, plant, spec)


def _failure(name: str, check: str, expected: str, found: str) -> CheckFailure:
    return CheckFailure(_FAMILY, name, check, expected, found)


def _run(controller: Any, observations: Sequence[Observation]) -> np.ndarray:
    """``reset()``, then the command at every observation, shape (n_steps,)."""
    controller.reset()
    return np.array([float(controller.act(obs)) for obs in observations])


def _check_runs(name: str, controller: Any,
                observations: Sequence[Observation]) -> list[CheckFailure]:
    """``act``, ``finite_output``, ``command_range`` and ``reset_reproduces``."""
    try:
        first = _run(controller, observations)
        again = _run(controller, observations)
    except Exception as exc:
        return [_failure(name, "act", "reset() and act(observation) to run on the standard "
                         "observations", raised(exc))]
    failures = []
    bad = np.flatnonzero(~np.isfinite(first))
    if bad.size:
        k = int(bad[0])
        failures.append(_failure(name, "finite_output", "a finite command at every step",
                                 f"{first[k]} at step {k} ({bad.size} of {first.size} steps)"))
    lo, hi = COMMAND_LIMITS
    out = np.flatnonzero(np.isfinite(first) & ((first < lo) | (first > hi)))
    if out.size:
        k = int(out[0])
        failures.append(_failure(name, "command_range", f"every command in {lo:g}..{hi:g}",
                                 f"{first[k]:.6g} at step {k} ({out.size} steps outside)"))
    same = np.isclose(again, first, rtol=0.0, atol=RESET_TOLERANCE, equal_nan=True)
    if not same.all():
        k = int(np.flatnonzero(~same)[0])
        failures.append(_failure(
            name, "reset_reproduces",
            f"after reset() the first run's commands within {RESET_TOLERANCE:g}",
            f"{again[k]:.6g} instead of {first[k]:.6g} at step {k} "
            f"({int((~same).sum())} of {same.size} steps differ)"))
    return failures


def _check_loop(name: str, controller: Any, plant: control.LTI,
                spec: dict[str, Any]) -> list[CheckFailure]:
    """``loop``, ``closed_loop_stable``, ``stated_phase_margin`` and ``report_margins``."""
    from controllers.analysis import loop_margins

    try:
        with warnings.catch_warnings():  # a wild loop is a finding, not a warning
            warnings.simplefilter("ignore", RuntimeWarning)
            margins = loop_margins(controller.loop(plant))
    except Exception as exc:
        return [_failure(name, "loop", "loop(plant) to give an open loop that can be analysed",
                         raised(exc))]
    if not margins.stable:
        largest = float(np.max(np.abs(margins.closed_loop_poles)))
        return [_failure(name, "closed_loop_stable", "a stable closed loop on the reference "
                         "plant", f"largest closed-loop pole |z| = {largest:.4f}")]
    report = getattr(controller, "report_", None)
    stated = spec.get("phase_margin_deg", getattr(report, "spec", {}).get("phase_margin_deg"))
    failures = []
    if isinstance(stated, (int, float)) and margins.phase_margin_deg < (
            stated - MARGIN_TOLERANCE_DEG):
        failures.append(_failure(
            name, "stated_phase_margin",
            f"a phase margin of at least {stated:g} deg (less {MARGIN_TOLERANCE_DEG:g})",
            f"{margins.phase_margin_deg:.2f} deg"))
    reported = getattr(report, "margins", None)
    if reported is not None:
        failures += _compare_report(name, margins, reported)
    return failures


def _compare_report(name: str, margins: Any, reported: Any) -> list[CheckFailure]:
    """``report_margins``: the analysed margins against those the design reported."""
    pairs = (("phase_margin_deg", "deg", MARGIN_TOLERANCE_DEG),
             ("gain_margin_db", "dB", MARGIN_TOLERANCE_DB))
    failures = []
    for attr, unit, tol in pairs:
        got, said = float(getattr(margins, attr)), float(getattr(reported, attr, np.nan))
        both_inf = np.isinf(got) and np.isinf(said) and np.sign(got) == np.sign(said)
        if not (both_inf or abs(got - said) <= tol):
            failures.append(_failure(
                name, "report_margins", f"{attr} {said:.2f} {unit} as its report_ states "
                f"(within {tol:g})", f"{got:.2f} {unit}"))
    return failures
