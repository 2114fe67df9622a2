"""Force controllers for an object: designed over the grip-force range, analysed where they run.

:func:`design_for_object` builds the object's plant family
(:func:`controllers.design_plant.plant_family`), designs the controller to its
specification at every grid force and schedules the designs on the measured
grip force (:class:`controllers.schedule.ScheduledController`); a fixed-gain
design (``scheduled=False``) is one design at one force. Either way,
:meth:`ControllerDesign.analyse` gives the loop's margins at any force with the
plant linearized *at that force*, so a fixed design's analysis shows where it
loses its margins.

The runtime controller is the scheduled core inside a
:class:`controllers.approach.ContactGate` (closing until both sides touch) and,
optionally, a :class:`controllers.reflex.SlipReflex`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.analysis import LoopMargins, loop_margins, state_space_dict
from controllers.approach import ContactGate
from controllers.base import Controller
from controllers.bounds import SensedSlipBound
from controllers.design_plant import (
    DEFAULT_FORCE_GRID_N,
    DesignPlant,
    OperatingPoint,
    PlantFamily,
    default_operating_force_n,
    operating_point,
    plant_family,
)
from controllers.design_spec import DesignSpec
from controllers.errors import PlantError, SpecificationError
from controllers.plant import delay
from controllers.plant_cache import cached_family
from controllers.reflex import ReflexSpec, SlipReflex
from controllers.registry import (
    bank_designer,
    controller_info,
    controller_names,
    default_spec,
    design_controller,
)
from controllers.schedule import ScheduledController
from sim.codec import stored_systems
from sim.hand.objects import ObjectSpec

if TYPE_CHECKING:
    import control

#: Crossover used when a specification gives neither crossover nor bandwidth, rad/s.
DEFAULT_CROSSOVER_RAD_S = 30.0
#: Lag-to-crossover ratio of the lead-lag design (see docs/CONTROL.md).
LEAD_LAG_RATIO = float(default_spec("lead_lag")["lag_ratio"])


def __getattr__(attr: str) -> Any:
    if attr == "DEFAULT_SPECS":  # default specification of every registered kind
        return {name: default_spec(name) for name in controller_names()}
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def controller_map(controller: Controller) -> control.StateSpace | None:
    """Discrete map from force error (N) to the command the hand receives, delay included.

    For the MPC this is its unconstrained feedback law (from ``-y``) with its
    Kalman filter, the part that closes the loop. ``None`` for a controller
    that offers neither ``transfer_function`` nor ``feedback_law`` (its loop,
    ``loop(plant)``, still gives the margins).
    """
    import control
    if hasattr(controller, "transfer_function"):
        c = controller.transfer_function()
    elif hasattr(controller, "feedback_law"):
        c = controller.feedback_law()
    else:
        return None
    delay_samples = getattr(controller, "computation_delay_samples", 1)
    return control.ss(c * delay(delay_samples, controller.dt_s))


@stored_systems("plant", "controller")
@dataclass(frozen=True)
class OperatingAnalysis:
    """The loop at one grip force.

    Attributes
    ----------
    force_n : float
    margins : LoopMargins or None
        ``None`` when the point failed.
    plant : control.StateSpace or None
        Design plant at ``force_n`` (command deviation to force deviation, N).
    controller : control.StateSpace or None
        Force error (N) to applied command, computation delay included.
    how : str
        How the plant was obtained (:class:`~controllers.design_plant.OperatingPoint`).
    reason : str
        Why the point failed (empty otherwise).
    """

    force_n: float
    margins: LoopMargins | None
    plant: control.StateSpace | None
    controller: control.StateSpace | None
    how: str
    reason: str = ""

    @property
    def ok(self) -> bool:
        """Whether the point was analysed."""
        return self.margins is not None

    def to_dict(self) -> dict[str, Any]:
        """The ``operating_points`` entry of the ``griploop margins`` JSON contract."""
        if not self.ok:
            return {"force_n": self.force_n, "failed": True, "reason": self.reason,
                    "plant_method": self.how}
        m = self.margins
        full = m.to_dict()
        return {
            "force_n": self.force_n,
            "margins": {"gain_margin_db": full["gain_margin_db"],
                        "phase_margin_deg": full["phase_margin_deg"],
                        "delay_margin_s": full["delay_margin_s"],
                        "crossover_rad_s": full["crossover_rad_s"],
                        "ms": full["ms"], "stable": full["stable"],
                        "bandwidth_rad_s": full["bandwidth_rad_s"]},
            "plant": state_space_dict(self, "plant"),
            "controller": state_space_dict(self, "controller"),
            "loop": state_space_dict(m, "loop"),
            "plant_method": self.how,
        }


def worst_case(analyses: list[OperatingAnalysis]) -> dict[str, Any]:
    """The worst margins over analysed points, each with the force where it occurs."""
    good = [a for a in analyses if a.ok]
    if not good:
        return {"n_points": 0, "n_failed": len(analyses)}

    def pick(key: Any, worst: Any) -> tuple[float | None, float]:
        values = [(key(a.margins), a.force_n) for a in good]
        finite = [(v, f) for v, f in values if v is not None and np.isfinite(v)]
        if not finite:
            return None, float("nan")
        return worst(finite, key=lambda vf: vf[0])

    gm, gm_f = pick(lambda m: m.gain_margin_db, min)
    pm, pm_f = pick(lambda m: m.phase_margin_deg, min)
    dm, dm_f = pick(lambda m: m.delay_margin_s, min)
    ms, ms_f = pick(lambda m: m.ms, max)
    return {"gain_margin_db": gm, "gain_margin_at_n": gm_f,
            "phase_margin_deg": pm, "phase_margin_at_n": pm_f,
            "delay_margin_s": dm, "delay_margin_at_n": dm_f,
            "ms": ms, "ms_at_n": ms_f,
            "all_stable": all(a.margins.stable for a in good),
            "n_points": len(good), "n_failed": len(analyses) - len(good)}


@dataclass
class ControllerDesign:
    """A controller designed over an object's force range, and its analysis at any force.

    Attributes
    ----------
    kind : str
        Controller family (``pid``, ``lead_lag``, ``mpc``).
    controller : object
        The runtime controller: ``ContactGate`` (and optionally ``SlipReflex``)
        around :attr:`core`.
    core : ScheduledController
        The scheduled (or single, fixed) force controller.
    family : PlantFamily
        The object's plant family.
    spec : dict
        The specification, as reported.
    scheduled : bool
        Whether the designs are scheduled over the grid (else one fixed design).
    notes : list of str
        Grid points skipped and why.
    """

    kind: str
    controller: Controller | None
    core: ScheduledController
    family: PlantFamily
    spec: dict[str, Any]
    scheduled: bool
    notes: list[str] = field(default_factory=list)
    _cache: dict[float, OperatingAnalysis] = field(default_factory=dict, repr=False)

    @property
    def object(self) -> ObjectSpec:
        """The object designed for."""
        return self.family.object

    @property
    def design_forces_n(self) -> list[float]:
        """Forces at which the bank's designs were made, N."""
        return list(self.core.forces_n)

    def check_force(self, force_n: float) -> None:
        """Raise ``ValueError`` naming the analysed range if ``force_n`` is outside it."""
        lo, hi = self.family.range_n
        if not lo <= float(force_n) <= hi:
            raise SpecificationError(
                f"force {force_n:g} N: expected a force in the analysed range {lo:g}..{hi:g} N"
            )

    def plant_at(self, force_n: float) -> OperatingPoint:
        """The design plant at ``force_n`` (a grid point, or linearized there)."""
        for p in self.family.points:
            if abs(p.force_n - force_n) < 1e-9:
                return p
        return cached_operating_point(self.object, float(force_n), self.family.control_dt_s)

    def analyse(self, force_n: float) -> OperatingAnalysis:
        """Margins of the loop that runs at a steady ``force_n`` (plant linearized there)."""
        force_n = float(force_n)
        if force_n in self._cache:
            return self._cache[force_n]
        point = self.plant_at(force_n)
        if not point.ok:
            result = OperatingAnalysis(force_n, None, None, None, point.how, point.reason)
        else:
            ctrl = self.core.controller_at(force_n)
            plant = point.plant.model
            try:
                margins = loop_margins(ctrl.loop(plant))
            except (ValueError, np.linalg.LinAlgError) as exc:
                result = OperatingAnalysis(force_n, None, plant, None, point.how,
                                           f"analysis failed: {exc}")
            else:
                result = OperatingAnalysis(force_n, margins, plant, controller_map(ctrl),
                                           point.how)
        self._cache[force_n] = result
        return result

    def analyse_many(self, forces_n: Iterable[float]) -> list[OperatingAnalysis]:
        """:meth:`analyse` at every force of ``forces_n``; a disk cache is written once."""
        deferred = getattr(self._cache, "deferred_writes", contextlib.nullcontext)
        with deferred():
            return [self.analyse(f) for f in forces_n]

    def analyse_grid(self) -> list[OperatingAnalysis]:
        """The analysis at every grid force of the family (failed points included)."""
        return self.analyse_many(p.force_n for p in self.family.points)

    @functools.cached_property
    def _static_map(self) -> tuple[np.ndarray, np.ndarray]:
        """Operating points of the family sorted by force: (force N, command)."""
        pts = self.family.usable
        y0 = np.array([p.plant.y0_n for p in pts])
        u0 = np.array([p.plant.u0 for p in pts])
        order = np.argsort(y0)
        return y0[order], u0[order]

    def feedforward(self, reference_n: float) -> float:
        """Static command that holds ``reference_n`` (interpolated over the family), units.

        Called every control step of the approach: the table is built once.
        """
        y0, u0 = self._static_map
        return float(np.interp(reference_n, y0, u0, left=u0[0] * reference_n / max(y0[0], 1e-9)))


@functools.lru_cache(maxsize=64)
def cached_plant_family(obj: ObjectSpec, control_dt_s: float,
                        forces_n: tuple[float, ...] = DEFAULT_FORCE_GRID_N) -> PlantFamily:
    """:func:`controllers.design_plant.plant_family` memoized per object, period and grid.

    In memory per process, and on disk for every process of the machine
    (:mod:`controllers.plant_cache`); ``PlantFamily.source`` says which.
    """
    family, source = cached_family(
        obj, control_dt_s, tuple(forces_n),
        lambda: plant_family(obj, control_dt_s=control_dt_s, forces_n=forces_n))
    return dataclasses.replace(family, source=source)


@functools.lru_cache(maxsize=512)
def cached_operating_point(obj: ObjectSpec, force_n: float, control_dt_s: float
                           ) -> OperatingPoint:
    """:func:`controllers.design_plant.operating_point` memoized."""
    return operating_point(obj, force_n, control_dt_s=control_dt_s)


def cached_design_plant(obj: ObjectSpec, control_dt_s: float,
                        grip_force_n: float | None = None) -> DesignPlant:
    """The design plant at one force (default: the fixed design's operating force).

    Raises
    ------
    PlantError
        If no usable model exists at that force.
    """
    force = default_operating_force_n(obj) if grip_force_n is None else float(grip_force_n)
    point = cached_operating_point(obj, force, float(control_dt_s))
    if not point.ok:
        raise PlantError(f"design plant of {obj.name} at {force:g} N: {point.reason}")
    return point.plant


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


def _design_at(kind: str, plant: DesignPlant, *, phase_margin_deg: float,
               crossover_rad_s: float | None, bandwidth_rad_s: float | None,
               options: dict[str, Any], slip_sensing: SensedSlipBound | None, force_max_n: float
               ) -> tuple[Any, dict]:
    """One design on one plant; returns the controller and its public spec."""
    info = controller_info(kind)
    if not info["shaping"]:
        spec: dict[str, Any] = dict(options)
        extra = ({"slip_sensing": slip_sensing, "force_max_n": force_max_n}
                 if info["slip_sensing"] else {})
        core = bank_designer(kind)(plant.model, **info["fixed"], **spec, **extra)
        if getattr(core, "solver", None) is not None:  # a QP-based design names its solver
            spec["solver"] = core.solver
        return core, spec
    extra = {**info["fixed"], **options}
    if bandwidth_rad_s is not None:
        wc = _crossover_for_bandwidth(kind, plant.model, phase_margin_deg,
                                      float(bandwidth_rad_s), extra)
    else:
        wc = DEFAULT_CROSSOVER_RAD_S if crossover_rad_s is None else float(crossover_rad_s)
    spec = {"phase_margin_deg": float(phase_margin_deg), "crossover_rad_s": wc, **extra}
    return bank_designer(kind)(plant.model, **spec), spec


def _design_bank(kind: str, points: list[tuple[float, DesignPlant]], **design: Any
                 ) -> tuple[ScheduledController, dict[str, Any], list[str]]:
    """One design per ``(force, plant)`` point, scheduled; the last spec; points skipped.

    Raises
    ------
    SpecificationError
        No point gave a design (the last point's reason).
    """
    info = controller_info(kind)
    designs, forces, notes = [], [], []
    spec: dict[str, Any] = {}
    last_error: SpecificationError | None = None
    for force, plant in points:
        try:
            core, spec = _design_at(kind, plant, **design)
        except (ValueError, np.linalg.LinAlgError) as exc:  # Specification/PlantError too
            last_error = exc if isinstance(exc, SpecificationError) else SpecificationError(
                f"{kind} at {force:g} N: {exc}")
            notes.append(f"no design at {force:g} N: {exc}")
            continue
        designs.append(core)
        forces.append(force)
    if not designs:
        raise last_error or SpecificationError(f"{kind}: no design on any grid force")
    bank = ScheduledController(forces, designs, name=kind, blend=info["blend"], warm=info["warm"])
    return bank, spec, notes


def _kind_options(kind: str, given: dict[str, Any]) -> dict[str, Any]:
    """The kind's own options (not loop shaping): its defaults updated by ``given``."""
    info = controller_info(kind)
    out = {k: v for k, v in info["defaults"].items() if k in info["options"]}
    out.update({k: v for k, v in given.items() if k in info["options"] and v is not None})
    return out


def design_for_object(obj: ObjectSpec, kind: str, spec: DesignSpec | None = None, *,
                      control_dt_s: float = 0.01) -> ControllerDesign:
    """Design a force controller for ``obj`` from a specification.

    Parameters
    ----------
    obj : ObjectSpec
        The grasped object; its plant family is linearized over ``spec.forces_n``.
    kind : str
        Controller kind registered in :mod:`controllers.registry` (``"pid"``,
        ``"lead_lag"``, ``"mpc"``, ...).
    spec : DesignSpec, optional
        Loop targets, reflex, closing command, schedule, force limit, design grid
        and the kind's own options (default ``DesignSpec()``;
        :meth:`~controllers.design_spec.DesignSpec.from_mapping` reads a flat specification).
    control_dt_s : float
        Control period, s.

    Raises
    ------
    UnknownControllerError
        Unknown ``kind`` (lists the valid ones).
    SpecificationError
        Specification the plant cannot meet at any grid force.
    PlantError
        No usable plant.
    """
    s = DesignSpec() if spec is None else spec
    info = controller_info(kind)
    options = _kind_options(kind, dict(s.options))
    dt = float(control_dt_s)
    family = cached_plant_family(obj, dt, tuple(float(f) for f in s.forces_n))
    limit = float("inf") if s.force_max_n is None else float(s.force_max_n)
    sensing = (SensedSlipBound(safety_factor=s.safety_factor, dt_s=dt) if info["slip_sensing"]
               else None)
    if s.scheduled:
        points = [(p.force_n, p.plant) for p in family.usable]
    else:
        force = default_operating_force_n(obj) if s.operating_force_n is None else float(
            s.operating_force_n)
        points = [(force, cached_design_plant(obj, dt, force))]
    core, spec_out, notes = _design_bank(
        kind, points, phase_margin_deg=s.phase_margin_deg, crossover_rad_s=s.crossover_rad_s,
        bandwidth_rad_s=s.bandwidth_rad_s, options=options, slip_sensing=sensing,
        force_max_n=limit)
    public_spec = {**spec_out, "scheduled": bool(s.scheduled),
                   "design_forces_n": [float(f) for f in core.forces_n],
                   "schedule_signal": "measured grip force (attack-release filter)"}
    if s.crossover_rad_s is None and s.bandwidth_rad_s is not None and info["shaping"]:
        public_spec["crossover_rad_s"] = "per design force"
    if sensing is not None:
        public_spec.update(slip_bound="sensed load / (2 mu_hat)", safety_factor=s.safety_factor,
                           friction_prior=sensing.friction_prior,
                           force_max_n=None if s.force_max_n is None else limit)
    design = ControllerDesign(kind=kind, controller=None, core=core, family=family,
                              spec=public_spec, scheduled=bool(s.scheduled), notes=notes)
    design.controller = _runtime(design, s.closing_command, s.reflex_spec(), limit)
    return design


def _runtime(design: ControllerDesign, closing_command: float,
             slip_reflex: ReflexSpec | None, force_max_n: float) -> Controller:
    """The controller the hand runs: the approach gate around the bank, then the reflex."""
    dt = design.family.control_dt_s
    controller: Controller = ContactGate(design.core, closing_command=closing_command,
                                         feedforward=design.feedforward, dt_s=dt)
    if slip_reflex is not None:
        controller = SlipReflex(controller, slip_reflex, dt_s=dt, max_force_n=force_max_n)
    return controller
