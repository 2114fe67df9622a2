"""What the prosthesis does with the force estimate: controllers and loop analysis.

Every controller satisfies :class:`controllers.base.Controller`: ``reset()``,
``act(observation) -> command`` (normalized motor command in -1..1) and
``loop(plant) -> control.LTI`` (the open loop ``C P z**-d`` with sample-and-hold
and computation delay), and is designed from a specification (phase margin,
crossover) with a ``report_``. Controller kinds are named in
:mod:`controllers.registry` (:func:`~controllers.registry.register_controller`);
:mod:`controllers.design` designs a kind over an object's force range and
schedules it, :mod:`controllers.analysis` and :mod:`controllers.measure` give
its margins, predicted and measured.

May import: numpy, scipy, python-control, DAQP and CasADi (the MPC's QP), matplotlib
(figures), and :mod:`sim` (the hand, for plants and loop measurement; :mod:`sim.errors`,
:mod:`sim.registry`). Never :mod:`estimation` or :mod:`scenarios`.

The public names below are imported on first use, so that ``import
controllers.registry`` (listing the controller kinds) does not import
python-control.
"""

from sim.lazy import lazy_exports

#: Public names, imported on first use: ``name -> module``.
_LAZY = {
    "LoopMargins": "controllers.analysis", "loop_margins": "controllers.analysis",
    "sweep_margins": "controllers.analysis",
    "ContactGate": "controllers.approach", "GateSpec": "controllers.approach",
    "Controller": "controllers.base", "Implementation": "controllers.base",
    "Observation": "controllers.base",
    "as_observation": "controllers.base",
    "ForceBounds": "controllers.bounds", "force_bounds": "controllers.bounds",
    "slip_threshold_n": "controllers.bounds",
    "DesignSpec": "controllers.design_spec",
    "IdentificationError": "controllers.errors", "PlantError": "controllers.errors",
    "SpecificationError": "controllers.errors", "UnknownControllerError": "controllers.errors",
    "save_loop_figures": "controllers.figures",
    "IdentifiedPlant": "controllers.identify", "identify_low_order": "controllers.identify",
    "LinearController": "controllers.lead_lag", "design_lead_lag": "controllers.lead_lag",
    "MPC": "controllers.mpc", "MPCTuning": "controllers.mpc", "design_mpc": "controllers.mpc",
    "PID": "controllers.pid", "design_pid": "controllers.pid",
    "PlantReport": "controllers.plant", "check_plant": "controllers.plant",
    "loop_plant": "controllers.plant", "plant_dt": "controllers.plant",
    "ReflexSpec": "controllers.reflex", "SlipReflex": "controllers.reflex",
    "CONTROLLER_NAMES": "controllers.registry", "design_controller": "controllers.registry",
    "register_controller": "controllers.registry",
    "DesignReport": "controllers.report",
}
__all__ = sorted(_LAZY)


__getattr__ = lazy_exports(__name__, _LAZY)
