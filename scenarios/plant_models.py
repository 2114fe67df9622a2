"""Design plants for an object, built from the MuJoCo hand environment.

Two models of the motor-command -> grip-force dynamics around a steady grasp:

* ``"linearized"``: :func:`sim.linearize.linearize_grasp` (finite-difference
  linearization of the physics, reduced by balanced truncation);
* ``"identified"``: a first- or second-order-plus-delay model fitted by
  :func:`controllers.identify.identify_low_order` to the simulated nonlinear
  response to a command step (:func:`sim.linearize.simulate_step`).

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

from dataclasses import dataclass, field
from typing import Any, Literal

import control
import numpy as np

from controllers.bounds import ForceBounds, force_bounds, slip_threshold_n
from controllers.errors import PlantError
from controllers.identify import identify_low_order
from controllers.plant import delay, truncate_slow_modes
from sim.linearize import linearize_grasp, nrmse_fit, simulate_step
from sim.objects import ObjectSpec, make_object

PLANT_METHODS = ("linearized", "identified")
# Samples at the operating point before the command step, in the step-response
# data and in the fit figures (the fit then measures the whole step, not only
# the small drift after it).
_N_PRE = 10


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


def design_plant(
    name: str | ObjectSpec,
    *,
    mass_kg: float | None = None,
    friction: float | None = None,
    method: Literal["linearized", "identified"] = "linearized",
    grip_force_n: float | None = None,
    control_dt_s: float = 0.01,
    step_command: float = 0.05,
    step_duration_s: float = 1.0,
    slow_mode_rad_s: float = 0.1,
) -> DesignPlant:
    """Build the design plant of an object grasped by the simulated hand.

    The operating point is the object lifted and held at ``grip_force_n``: the
    regime the force loop must hold. (On the table, the first pad to touch
    pushes the object to its table-friction limit, where the dynamics are not
    smooth and finite differences give spurious unstable poles.)

    Parameters
    ----------
    name : str or ObjectSpec
        Object name in :data:`sim.objects.LIBRARY`, or a full object spec.
    mass_kg, friction : float, optional
        Overrides of the object's mass (kg) and friction coefficient.
    method : {"linearized", "identified"}
    grip_force_n : float, optional
        Operating grip force in N; default :func:`default_operating_force_n`.
    control_dt_s : float
        Control period in seconds.
    step_command : float
        Command step (normalized) for the step response.
    step_duration_s : float
        Length of the simulated step response, s.
    slow_mode_rad_s : float
        ``"linearized"`` only: modes slower than this (rad/s; time constants
        above 10 s by default: the object's creep on the pads, which the
        linearization keeps as near-unit poles with nearly cancelling zeros)
        are truncated (:func:`controllers.plant.truncate_slow_modes`). They
        make the polynomial margin computation ill-conditioned and act as a
        slow disturbance that integral action rejects.

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
    if isinstance(name, ObjectSpec):
        overrides = {k: v for k, v in (("mass_kg", mass_kg), ("friction", friction))
                     if v is not None}
        obj = name.replace(**overrides) if overrides else name
    else:
        obj = object_for(name, mass_kg=mass_kg, friction=friction)
    force = default_operating_force_n(obj) if grip_force_n is None else float(grip_force_n)
    try:
        lin = linearize_grasp(obj, force, lifted=True, control_dt_s=control_dt_s)
    except RuntimeError as exc:
        raise PlantError(
            f"design plant: expected a steady grasp of {obj.name} at {force:.3g} N, found: {exc}"
        ) from exc
    n_steps = int(round(step_duration_s / control_dt_s))
    y_nonlinear, y_linear = simulate_step(lin, step_command, n_steps)
    if method == "linearized":
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
               "step_fit_percent": 100.0 * nrmse_fit(y_ref, np.concatenate([pad, y_reduced])),
               "full_step_fit_percent": 100.0 * nrmse_fit(
                   y_ref, np.concatenate([pad, y_linear])),
               "step_command": step_command}
        model = control.ss(reduced * delay(1, control_dt_s))
        return DesignPlant(model=model, method=method, object=obj, u0=lin.u0,
                           y0_n=lin.y0_n, fit=fit)
    u = np.concatenate([np.zeros(_N_PRE), np.full(n_steps, step_command)])
    # sampled convention: the force read at k reflects commands up to k - 1
    y = np.concatenate([np.zeros(_N_PRE + 1), y_nonlinear[:-1]])
    ident = identify_low_order(u, y, control_dt_s)
    fit = {"gain_n": ident.gain_n, "time_constants_s": list(ident.time_constants_s),
           "delay_samples": ident.delay_samples, "fit_percent": ident.fit_percent,
           "r2": ident.r2, "rms_error_n": ident.rms_error_n, "step_command": step_command}
    return DesignPlant(model=ident.model, method=method, object=obj, u0=lin.u0,
                       y0_n=lin.y0_n, fit=fit)
