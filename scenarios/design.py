"""Controller design for a grasped object, from a scenario's controller specification.

Joins the hand's design plant (:mod:`scenarios.plant_models`) and the
controller designs (:mod:`controllers`). Design plants are cached per object
and control period, because linearizing the hand costs about a second while a
sweep designs many controllers for the same object.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import control
import numpy as np

from controllers import CONTROLLER_NAMES, ContactGate, SlipReflex, design_controller, loop_margins
from controllers.analysis import LoopMargins
from controllers.errors import SpecificationError
from scenarios.plant_models import DesignPlant, design_plant, object_force_bounds
from sim.objects import ObjectSpec

#: Crossover used when a specification gives neither crossover nor bandwidth, rad/s.
DEFAULT_CROSSOVER_RAD_S = 30.0
#: Lag-to-crossover ratio of the lead-lag design (see docs/CONTROL.md).
LEAD_LAG_RATIO = 2.0


@dataclass(frozen=True)
class ControllerDesign:
    """A designed controller, its analysed loop and where they came from.

    Attributes
    ----------
    controller : object
        The force controller, wrapped in a :class:`controllers.ContactGate`
        (closing command until contact) and optionally a
        :class:`controllers.SlipReflex`. ``reset()``/``act(observation)``.
    core : object
        The bare force controller (PID, lead-lag or MPC) inside the wrappers.
    plant : DesignPlant
        The design plant (linearized hand-object model).
    loop : control.StateSpace
        The open loop analysed (controller x plant, with the computation delay).
    margins : LoopMargins
        Its margins.
    spec : dict
        The specification the design was computed from.
    """

    controller: Any
    core: Any
    plant: DesignPlant
    loop: control.StateSpace
    margins: LoopMargins
    spec: dict[str, Any]


@functools.lru_cache(maxsize=64)
def cached_design_plant(obj: ObjectSpec, control_dt_s: float,
                        grip_force_n: float | None = None) -> DesignPlant:
    """:func:`scenarios.plant_models.design_plant` memoized per object, period and force."""
    return design_plant(obj, control_dt_s=control_dt_s, grip_force_n=grip_force_n)


def _crossover_for_bandwidth(kind: str, plant: control.LTI, phase_margin_deg: float,
                             bandwidth_rad_s: float, extra: dict[str, Any]) -> float:
    """Crossover whose design has the requested closed-loop bandwidth.

    Scans a log grid of crossovers around the bandwidth for feasible designs,
    then bisects (in log frequency) between the two feasible neighbours that
    bracket the requested bandwidth.
    """

    def bandwidth_of(wc: float) -> float | None:
        try:
            core = design_controller(kind, plant, phase_margin_deg=phase_margin_deg,
                                     crossover_rad_s=wc, **extra)
        except SpecificationError:
            return None
        return float(loop_margins(core.loop(plant)).bandwidth_rad_s)

    nyquist = np.pi / float(plant.dt)
    grid = np.geomspace(bandwidth_rad_s / 5.0, min(bandwidth_rad_s * 2.0, 0.5 * nyquist), 17)
    feasible = [(float(w), b) for w in grid if (b := bandwidth_of(float(w))) is not None]
    bracket = next(((lo, hi) for lo, hi in zip(feasible, feasible[1:], strict=False)
                    if lo[1] <= bandwidth_rad_s <= hi[1]), None)
    if bracket is None:
        reach = (f"{min(b for _, b in feasible):.3g}..{max(b for _, b in feasible):.3g} rad/s"
                 if feasible else "none")
        raise SpecificationError(
            f"bandwidth {bandwidth_rad_s:g} rad/s is out of reach of a {kind} design with "
            f"{phase_margin_deg:g} deg phase margin on this plant: reachable {reach}"
        )
    lo, hi = bracket[0][0], bracket[1][0]
    while hi / lo > 1.005:
        mid = float(np.sqrt(lo * hi))
        b = bandwidth_of(mid)
        if b is None:
            break
        lo, hi = (mid, hi) if b < bandwidth_rad_s else (lo, mid)
    return float(np.sqrt(lo * hi))


def design_for_object(
    obj: ObjectSpec,
    kind: str,
    *,
    control_dt_s: float = 0.01,
    phase_margin_deg: float = 60.0,
    crossover_rad_s: float | None = None,
    bandwidth_rad_s: float | None = None,
    horizon: int = 20,
    safety_factor: float = 1.5,
    slip_reflex: dict[str, float] | None = None,
    closing_command: float = 0.2,
    operating_force_n: float | None = None,
) -> ControllerDesign:
    """Design a force controller for ``obj`` from a specification.

    Parameters
    ----------
    obj : ObjectSpec
        The grasped object (its mass, friction and break force set the MPC's
        force bounds and the slip reflex's ceiling).
    kind : {"pid", "lead_lag", "mpc"}
        Controller family.
    control_dt_s : float
        Control period, s.
    phase_margin_deg : float
        Target phase margin (PID and lead-lag), degrees.
    crossover_rad_s, bandwidth_rad_s : float, optional
        Target gain crossover or closed-loop bandwidth (PID and lead-lag), rad/s;
        neither: :data:`DEFAULT_CROSSOVER_RAD_S`.
    horizon : int
        MPC horizon in control periods.
    safety_factor : float
        MPC lower force bound over the slip threshold ``m g / (2 mu)``.
    slip_reflex : dict, optional
        ``{"latency_s": ..., "gain": ...}`` enables a slip reflex that, ``latency_s``
        after each slip onset, raises the grip by ``gain`` times the current
        reference (:class:`controllers.SlipReflex` ``onset_fraction``).
    closing_command : float
        Normalized motor command while closing onto the object (real hands
        close fully in 0.4-1 s; 0.2 closes in about 1 s here).
    operating_force_n : float, optional
        Grip force the design plant is linearized at, N (the force the loop
        will hold: the hand's compliant pads make the plant much slower below
        about 8 N than above). Default
        :func:`scenarios.plant_models.default_operating_force_n`.

    Raises
    ------
    LookupError
        Unknown ``kind`` (lists the valid ones).
    SpecificationError
        Specification the plant cannot meet (names the limit).
    """
    if kind not in CONTROLLER_NAMES:
        raise LookupError(f"unknown controller {kind!r}; expected one of {list(CONTROLLER_NAMES)}")
    plant = cached_design_plant(obj, float(control_dt_s),
                                None if operating_force_n is None else float(operating_force_n))
    if kind == "mpc":  # only the MPC needs feasible bounds: it enforces them
        bounds = object_force_bounds(obj, safety_factor=safety_factor)
        spec: dict[str, Any] = {"horizon": int(horizon), "force_bounds": bounds}
    else:
        extra = {"structure": "pi"} if kind == "pid" else {"lag_ratio": LEAD_LAG_RATIO}
        if bandwidth_rad_s is not None:
            wc = _crossover_for_bandwidth(kind, plant.model, phase_margin_deg,
                                          float(bandwidth_rad_s), extra)
        else:
            wc = DEFAULT_CROSSOVER_RAD_S if crossover_rad_s is None else float(crossover_rad_s)
        spec = {"phase_margin_deg": float(phase_margin_deg), "crossover_rad_s": wc, **extra}
    core = design_controller(kind, plant.model, **spec)
    loop = control.ss(core.loop(plant.model))
    margins = loop_margins(loop)
    controller: Any = ContactGate(core, closing_command=closing_command,
                                  force_per_command_n=plant.y0_n / plant.u0)
    if slip_reflex:
        limit = 1e3 if obj.break_force_n is None else float(obj.break_force_n)
        controller = SlipReflex(
            controller, dt_s=control_dt_s, latency_s=float(slip_reflex["latency_s"]),
            step_n=float(slip_reflex["gain"]), max_reference_n=limit,
            slip_speed_threshold_m_s=0.005,
        )
    public_spec = {k: v for k, v in spec.items() if k != "force_bounds"}
    if kind == "mpc":
        public_spec.update(force_min_n=bounds.min_n, force_max_n=bounds.max_n)
    return ControllerDesign(controller=controller, core=core, plant=plant, loop=loop,
                            margins=margins, spec=public_spec)
