"""Design plants for an object over its grip-force range, built from the MuJoCo hand.

The hand-object plant changes several-fold with grip force: below the pads'
knee (about 8 N) the compliant fingertip pads make it slow and low-gain, above
it the pads are bottomed out and it is nearly static. A margin is therefore a
property of a loop *at an operating point*: :func:`plant_family` linearizes the
lifted grasp on a grid of grip forces (:data:`DEFAULT_FORCE_GRID_N`, denser
around the knee), detects linearization artefacts and repairs them, and
records how each point was obtained.

Two models of the motor-command -> grip-force dynamics around a steady grasp:

* ``"linearized"``: :func:`sim.hand.linearize.linearize_grasp` (finite-difference
  linearization of the physics, reduced by balanced truncation);
* ``"identified"``: a first- or second-order-plus-delay model fitted by
  :func:`controllers.identify.identify_low_order` to the simulated nonlinear
  response to a command step (:func:`sim.hand.linearize.simulate_step`).

Timing convention. ``GraspEnv.step`` reports the force at the end of the
control period in which the command was applied, so the environment's model
has a direct feedthrough (``D != 0``). The controllers use the usual sampled
convention instead: ``y[k]`` is the force measured when ``u[k]`` is computed,
so the design plant is the environment's model times ``z**-1`` (strictly
proper, the zero-order hold's one-sample lag). A controller's
``computation_delay_samples`` then adds the processing delay on top; to
reproduce it in an episode, apply each command that many periods late.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from controllers.bounds import ForceBounds, force_bounds, slip_threshold_n
from controllers.errors import IdentificationError, PlantError
from controllers.identify import identify_low_order
from controllers.plant import delay, truncate_slow_modes
from sim.codec import stored_systems
from sim.hand.linearize import (
    LinearGrasp,
    LinearizationSettings,
    linearize_grasp,
    simulate_step,
    step_response_fit,
)
from sim.hand.objects import ObjectSpec, make_object

if TYPE_CHECKING:
    import control

PLANT_METHODS = ("linearized", "identified")
#: Grip forces (N) of the design grid: from 1 N to the reference cap of the
#: episodes (1.2 x 30 N), denser around the pads' knee (about 8 N).
DEFAULT_FORCE_GRID_N = (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 5.5, 6.0, 6.5, 7.0, 7.5, 8.0, 9.0,
                        10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 36.0)
#: Length of the simulated step that checks each family point's fit, s.
FAMILY_STEP_S = 0.4
#: Below this multiple of the slip threshold the object cannot be held in the
#: air steadily, and it is linearized weightless (see :func:`design_plant`).
WEIGHTLESS_BELOW_SLIP_FACTOR = 1.3
# A pole farther than this outside the unit circle is unstable.
_UNSTABLE_TOL = 1e-6
# Unstable modes slower than this (rad/s; time constants above 2 s) are creep of
# the object on the pads, which a re-linearization may still show; they can be
# truncated like the slow stable creep modes.
_CREEP_RATE_RAD_S = 0.5
# Samples at the operating point before the command step, in the step-response
# data and in the fit figures (the fit then measures the whole step, not only
# the small drift after it).
_N_PRE = 10


@stored_systems("model")
@dataclass(frozen=True)
class DesignPlant:
    """A design plant and where it came from.

    Attributes
    ----------
    model : control.StateSpace
        Discrete (``dt`` = control period), strictly proper; input: command
        deviation from ``u0`` (normalized), output: grip-force deviation from
        ``y0_n`` (N).
    method : {"linearized", "identified"}
    object : ObjectSpec
    u0 : float
        Operating-point command.
    y0_n : float
        Operating-point grip force, N.
    fit : dict
        For ``"identified"``: gain, time constants, delay, fit percent and R^2
        against the simulated step; for ``"linearized"``: the NRMSE fit (percent)
        of the reduced and full linear step responses against the nonlinear
        one, the orders and the time constants of the truncated modes. Fits
        are over the step with ``_N_PRE`` samples of the operating point before it.
    """

    model: control.StateSpace
    method: str
    object: ObjectSpec
    u0: float
    y0_n: float
    fit: dict[str, Any] = field(default_factory=dict)

    @property
    def unstable(self) -> bool:
        """Whether the model has a pole outside the unit circle (a linearization artefact)."""
        poles = np.asarray(self.model.poles())
        return bool(poles.size and np.max(np.abs(poles)) > 1.0 + _UNSTABLE_TOL)


def object_for(name: str, *, mass_kg: float | None = None,
               friction: float | None = None) -> ObjectSpec:
    """A library object with optional mass (kg) and friction overrides."""
    overrides: dict[str, float] = {}
    if mass_kg is not None:
        overrides["mass_kg"] = mass_kg
    if friction is not None:
        overrides["friction"] = friction
    return make_object(name, **overrides)


def object_force_bounds(obj: ObjectSpec, *, safety_factor: float = 1.5) -> ForceBounds:
    """Slip bound ``m g / (2 mu) * safety_factor`` and the object's fragility limit, N."""
    limit = float("inf") if obj.break_force_n is None else float(obj.break_force_n)
    return force_bounds(obj.mass_kg, obj.friction, fragility_limit_n=limit,
                        safety_factor=safety_factor)


def default_operating_force_n(obj: ObjectSpec, *, safety_factor: float = 1.5) -> float:
    """Operating grip force for linearization, N.

    10 N (the pads bottomed out: the stiffest, highest-gain regime) or the
    secure grip ``safety_factor * m g / (2 mu)`` if larger; for a fragile object,
    midway between that grip and the break force, capped at 10 N. An object that
    breaks below its secure grip is linearized at the secure grip: the design
    needs the object held in the air, and whether it then cracks is the
    episode's outcome, not the design's.
    """
    secure_n = safety_factor * slip_threshold_n(obj.mass_kg, obj.friction)
    if obj.break_force_n is None:
        return float(max(10.0, secure_n))
    if secure_n >= obj.break_force_n:
        return float(secure_n)
    return float(min(10.0, 0.5 * (secure_n + obj.break_force_n)))


@dataclass(frozen=True)
class StepTest:
    """The simulated command step that checks a design plant's fit or identifies it.

    Attributes
    ----------
    command : float
        Command step from the operating point, normalized command.
    duration_s : float
        Length of the simulated step response, s.
    """

    command: float = 0.05
    duration_s: float = 1.0


def design_plant(
    obj: str | ObjectSpec,
    *,
    method: Literal["linearized", "identified"] = "linearized",
    grip_force_n: float | None = None,
    control_dt_s: float = 0.01,
    step: StepTest | None = None,
    slow_mode_rad_s: float = 0.1,
    weightless: bool | None = None,
    linearization: LinearizationSettings | None = None,
) -> DesignPlant:
    """Build the design plant of an object grasped by the simulated hand.

    The operating point is the object lifted and held at ``grip_force_n``: the
    regime the force loop must hold. (On the table, the first pad to touch
    pushes the object to its table-friction limit, where the dynamics are not
    smooth and finite differences give spurious unstable poles.)

    Parameters
    ----------
    obj : str or ObjectSpec
        Object name in ``sim.hand.objects.LIBRARY``, or a full object spec (with
        other mass or friction: :func:`object_for`).
    method : {"linearized", "identified"}
    grip_force_n : float, optional
        Operating grip force in N; default :func:`default_operating_force_n`.
    control_dt_s : float
        Control period in seconds.
    step : StepTest, optional
        The simulated command step (default ``StepTest()``: 0.05 for 1 s).
    slow_mode_rad_s : float
        ``"linearized"`` only: modes slower than this (rad/s; time constants
        above 10 s by default: the object's creep on the pads, which the
        linearization keeps as near-unit poles with nearly cancelling zeros)
        are truncated (:func:`controllers.plant.truncate_slow_modes`). They
        make the polynomial margin computation ill-conditioned and act as a
        slow disturbance that integral action rejects.
    weightless : bool, optional
        Linearize with the object's weight cancelled (``body_gravcomp``). Default:
        when ``grip_force_n`` is below :data:`WEIGHTLESS_BELOW_SLIP_FACTOR` times
        the slip threshold ``m g / (2 mu)``, where no steady lifted grasp exists.
        Recorded in ``fit["weightless"]``.
    linearization : LinearizationSettings, optional
        Settling time of each grip correction before linearizing, finite-difference
        step and truncation threshold (default ``LinearizationSettings()``).

    Returns
    -------
    DesignPlant

    Raises
    ------
    LookupError
        Unknown ``method`` (lists the valid ones).
    PlantError
        If the environment cannot reach a steady grasp.
    """
    if method not in PLANT_METHODS:
        raise LookupError(f"plant method: expected one of {list(PLANT_METHODS)}, found {method!r}")
    obj = obj if isinstance(obj, ObjectSpec) else make_object(obj)
    step = StepTest() if step is None else step
    step_command = step.command
    force = default_operating_force_n(obj) if grip_force_n is None else float(grip_force_n)
    if weightless is None:
        weightless = force < WEIGHTLESS_BELOW_SLIP_FACTOR * slip_threshold_n(obj.mass_kg,
                                                                              obj.friction)
    try:
        lin = linearize_grasp(obj, force, lifted=True, control_dt_s=control_dt_s,
                              weightless=weightless, settings=linearization)
    except RuntimeError as exc:
        raise PlantError(
            f"design plant: expected a steady grasp of {obj.name} at {force:.3g} N, found: {exc}"
        ) from exc
    n_steps = int(round(step.duration_s / control_dt_s))
    y_nonlinear, y_linear = simulate_step(lin, step_command, n_steps)
    if method == "linearized":
        return _linearized_plant(obj, lin, y_nonlinear, y_linear, control_dt_s=control_dt_s,
                                 step_command=step_command, slow_mode_rad_s=slow_mode_rad_s,
                                 weightless=weightless)
    return _identified_plant(obj, lin, y_nonlinear, control_dt_s=control_dt_s,
                             step_command=step_command, weightless=weightless)


def _linearized_plant(obj: ObjectSpec, lin: LinearGrasp, y_nonlinear: np.ndarray,
                      y_linear: np.ndarray, *, control_dt_s: float, step_command: float,
                      slow_mode_rad_s: float, weightless: bool) -> DesignPlant:
    """The linearization without its slow modes, plus the sampled convention's delay.

    Parameters
    ----------
    lin : LinearGrasp
        The hand linearized at the operating point.
    y_nonlinear, y_linear : ndarray, shape (n_steps,)
        Grip-force responses (N) of the hand and of ``lin`` to the command step.
    control_dt_s : float
        Control period, s.
    step_command : float
        The step, command units.
    slow_mode_rad_s : float
        Modes slower than this are truncated, rad/s.
    weightless : bool
        Whether the object's weight was cancelled (recorded in ``fit``).
    """
    import control
    n_steps = y_nonlinear.size
    reduced, removed = truncate_slow_modes(lin.sys, slow_mode_rad_s)
    t = np.arange(n_steps) * control_dt_s
    y_reduced = np.asarray(control.forced_response(
        reduced, T=t, U=np.full(n_steps, step_command)).outputs).ravel()
    rates = np.abs(np.log(np.abs(removed))) / control_dt_s
    pad = np.zeros(_N_PRE)
    y_ref = np.concatenate([pad, y_nonlinear])
    fit = {"order": int(reduced.nstates + 1),
           "full_order": int(lin.sys.nstates + 1),
           "removed_time_constants_s": sorted((1.0 / rates).tolist(), reverse=True),
           "step_fit_percent": 100.0 * step_response_fit(
               y_ref, np.concatenate([pad, y_reduced])),
           "full_step_fit_percent": 100.0 * step_response_fit(
               y_ref, np.concatenate([pad, y_linear])),
           "step_command": step_command, "weightless": bool(weightless)}
    model = control.ss(reduced * delay(1, control_dt_s))
    return DesignPlant(model=model, method="linearized", object=obj, u0=lin.u0,
                       y0_n=lin.y0_n, fit=fit)


def _identified_plant(obj: ObjectSpec, lin: LinearGrasp, y_nonlinear: np.ndarray, *,
                      control_dt_s: float, step_command: float, weightless: bool) -> DesignPlant:
    """A low-order model identified from the hand's simulated step response.

    Parameters
    ----------
    lin : LinearGrasp
        The hand at the operating point (its period and operating command).
    y_nonlinear : ndarray, shape (n_steps,)
        Grip-force response (N) of the hand to the command step.
    control_dt_s : float
        Control period, s.
    step_command : float
        The step, command units.
    weightless : bool
        Whether the object's weight was cancelled (recorded in ``fit``).
    """
    n_steps = y_nonlinear.size
    u = np.concatenate([np.zeros(_N_PRE), np.full(n_steps, step_command)])
    # sampled convention: the force read at k reflects commands up to k - 1
    y = np.concatenate([np.zeros(_N_PRE + 1), y_nonlinear[:-1]])
    ident = identify_low_order(u, y, control_dt_s)
    fit = {"gain_n": ident.gain_n, "time_constants_s": list(ident.time_constants_s),
           "delay_samples": ident.delay_samples, "fit_percent": ident.fit_percent,
           "r2": ident.r2, "rms_error_n": ident.rms_error_n, "step_command": step_command,
           "weightless": bool(weightless)}
    return DesignPlant(model=ident.model, method="identified", object=obj, u0=lin.u0,
                       y0_n=lin.y0_n, fit=fit)


# ------------------------------------------------------------------ the force range
@dataclass(frozen=True)
class OperatingPoint:
    """The design plant at one grip force of a :class:`PlantFamily`.

    Attributes
    ----------
    force_n : float
        Requested grip force, N.
    plant : DesignPlant or None
        The model; ``None`` if no model could be built (see ``reason``).
    how : str
        ``"linearized"``; ``"relinearized"`` (the first linearization had an
        unstable pole that the neighbouring forces do not have, a second one
        with a longer settling and a larger finite-difference step did not);
        ``"creep_truncated"`` (a slow unstable creep mode removed);
        ``"identified"`` (fitted to a simulated step); or ``"failed"``.
    notes : tuple of str
        What was tried and found, in order.
    reason : str
        Why the point failed (empty otherwise).
    """

    force_n: float
    plant: DesignPlant | None
    how: str
    notes: tuple[str, ...] = ()
    reason: str = ""

    @property
    def ok(self) -> bool:
        """Whether a usable (stable) model exists at this force."""
        return self.plant is not None


def _max_pole(plant: DesignPlant) -> float:
    poles = np.asarray(plant.model.poles())
    return float(np.max(np.abs(poles))) if poles.size else 0.0


def operating_point(obj: ObjectSpec, force_n: float, *, control_dt_s: float = 0.01
                    ) -> OperatingPoint:
    """The design plant at ``force_n``, with linearization artefacts repaired.

    A finite-difference linearization of a contact-rich grasp can show a pole
    just outside the unit circle (the egg at 2.87 N: ``z = 1.0014``) where the
    forces on either side have none. Repairs, in order, each recorded in
    ``notes``: re-linearize with a longer settling and a larger step; remove a
    slow unstable creep mode (time constant above 2 s) by modal truncation,
    accepted only if the reduced model still fits the simulated nonlinear step
    (NRMSE fit at least 80 %); identify a low-order model from the simulated
    step.
    """
    import control
    notes: list[str] = []
    try:  # the step that checks the fit lasts 0.4 s: the grasp's modes settle within it
        first = design_plant(obj, grip_force_n=force_n, control_dt_s=control_dt_s,
                             step=StepTest(duration_s=FAMILY_STEP_S))
    except PlantError as exc:
        return OperatingPoint(force_n, None, "failed", (str(exc),), str(exc))
    if not first.unstable:
        return OperatingPoint(force_n, first, "linearized")
    notes.append(f"linearization has a pole at |z| = {_max_pole(first):.4f}")
    try:
        second = design_plant(obj, grip_force_n=force_n, control_dt_s=control_dt_s,
                              step=StepTest(duration_s=FAMILY_STEP_S),
                              linearization=LinearizationSettings(settle_s=1.5, eps=1e-5))
    except PlantError as exc:
        second = None
        notes.append(f"re-linearization failed: {exc}")
    if second is not None and not second.unstable:
        notes.append("re-linearized with 1.5 s settling and step 1e-5: stable")
        return OperatingPoint(force_n, second, "relinearized", tuple(notes))
    if second is not None:
        notes.append(f"re-linearization still has |z| = {_max_pole(second):.4f}")
        reduced, removed = truncate_slow_modes(second.model, _CREEP_RATE_RAD_S)
        stable = not reduced.nstates or np.max(np.abs(reduced.poles())) <= 1.0 + _UNSTABLE_TOL
        if stable and removed.size:
            fit = _step_fit(second, reduced, control_dt_s)
            notes.append(f"removed {removed.size} creep mode(s) slower than "
                         f"{_CREEP_RATE_RAD_S} rad/s: step fit {fit:.0f} %")
            if fit >= 80.0:
                plant = DesignPlant(model=control.ss(reduced), method="linearized",
                                    object=obj, u0=second.u0, y0_n=second.y0_n,
                                    fit={**second.fit, "creep_truncated_poles":
                                         [abs(complex(p)) for p in removed],
                                         "step_fit_percent": fit})
                return OperatingPoint(force_n, plant, "creep_truncated", tuple(notes))
    try:  # a small step: a large one crosses the pads' knee and averages two regimes
        step = max(0.002, 0.1 * first.u0)
        ident = design_plant(obj, grip_force_n=force_n, control_dt_s=control_dt_s,
                             method="identified", step=StepTest(command=step))
    except (PlantError, IdentificationError) as exc:
        notes.append(f"identification failed: {exc}")
        return OperatingPoint(force_n, None, "failed", tuple(notes), notes[-1])
    notes.append(f"identified from a simulated step: fit {ident.fit['fit_percent']:.0f} %")
    return OperatingPoint(force_n, ident, "identified", tuple(notes))


def _step_fit(plant: DesignPlant, reduced: control.StateSpace, dt_s: float) -> float:
    """NRMSE fit (percent) of ``reduced`` against ``plant``'s simulated nonlinear step."""
    import control
    lin = linearize_grasp(plant.object, plant.y0_n, lifted=True, control_dt_s=dt_s,
                          weightless=bool(plant.fit.get("weightless", False)))
    du = float(plant.fit.get("step_command", 0.05))
    n_steps = int(round(1.0 / dt_s))
    y_nonlinear, _ = simulate_step(lin, du, n_steps)
    t = np.arange(n_steps + 1) * dt_s
    y_red = np.asarray(control.forced_response(reduced, T=t, U=np.full(t.size, du)).outputs)
    # the design plant carries the sampled convention's extra z**-1
    return 100.0 * step_response_fit(y_nonlinear, y_red.ravel()[1:])


@dataclass(frozen=True)
class PlantFamily:
    """Design plants of one object on a grid of grip forces.

    Attributes
    ----------
    object : ObjectSpec
    control_dt_s : float
        Control period, s.
    points : tuple of OperatingPoint
        One per grid force, ascending.
    build_s : float
        Wall time to build the family, s.
    source : str
        ``"built"`` here, or where it came from (:mod:`controllers.plant_cache`).
    """

    object: ObjectSpec
    control_dt_s: float
    points: tuple[OperatingPoint, ...]
    build_s: float
    source: str = "built"

    @property
    def forces_n(self) -> np.ndarray:
        """Grid forces with a usable model, N, ascending."""
        return np.array([p.force_n for p in self.points if p.ok])

    @property
    def usable(self) -> tuple[OperatingPoint, ...]:
        """The points with a model."""
        return tuple(p for p in self.points if p.ok)

    @property
    def range_n(self) -> tuple[float, float]:
        """Smallest and largest grid force, N."""
        return float(self.points[0].force_n), float(self.points[-1].force_n)

    def summary(self) -> list[dict[str, Any]]:
        """JSON-ready list of ``{force_n, how, notes, reason}``."""
        return [{"force_n": p.force_n, "how": p.how, "notes": list(p.notes),
                 "reason": p.reason} for p in self.points]


def plant_family(obj: ObjectSpec, *, control_dt_s: float = 0.01,
                 forces_n: tuple[float, ...] = DEFAULT_FORCE_GRID_N) -> PlantFamily:
    """Linearize the lifted grasp of ``obj`` at every force of ``forces_n``.

    Raises
    ------
    PlantError
        If no grid force gives a usable model.
    """
    start = time.perf_counter()
    forces = sorted(float(f) for f in forces_n)
    points = tuple(operating_point(obj, f, control_dt_s=control_dt_s) for f in forces)
    family = PlantFamily(object=obj, control_dt_s=float(control_dt_s), points=points,
                         build_s=time.perf_counter() - start)
    if not family.usable:
        raise PlantError(
            f"plant family of {obj.name}: expected a model at some of {forces} N, found none "
            f"({points[0].reason})"
        )
    return family
