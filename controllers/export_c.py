"""The runtime force controller in C: gain schedule, anti-windup, contact gate and slip reflex.

What the hand runs (:func:`controllers.design._runtime`) is a
:class:`~controllers.schedule.ScheduledController` bank inside a
:class:`~controllers.approach.ContactGate`, optionally inside a
:class:`~controllers.reflex.SlipReflex`. :func:`export_controller` writes all of it
as one C file that reproduces the Python step by step:

- the bank, by the emitter registered for the controller kind
  (:func:`register_controller_c_export`): ``pid`` (``"interpolate"`` blend: one PID
  whose gains are interpolated in force and changed bumplessly, back-calculation
  anti-windup, derivative filter) and ``lead_lag`` (``"switch"`` blend: one
  biproper compensator per grid force with conditioning (Hanus) anti-windup, cells
  split at the geometric midpoints, hysteresis, and the state handed over at a
  switch with the integrator absorbing the output difference);
- the schedule's attack-release filter of ``max(grip, reference)``;
- the gate's phases (open, releasing, closing, approach speed servo, force
  control with the reference rate limit) and its feedforward table;
- the reflex's arming, latency line, onset boost, decay and ceiling.

Counts of time (the gate's lost-contact delay) are written as whole control steps,
the count the Python float sum reaches, so no rounding changes when a phase ends.
The MPC is not exported (its QP solver would have to be ported or shipped); the
refusal names what can be.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.approach import ContactGate
from controllers.lead_lag import LinearController
from controllers.pid import PID
from controllers.reflex import SlipReflex
from controllers.schedule import ScheduledController
from sim.c_source import (
    CModel,
    EmitterRegistry,
    ExportError,
    check_finite,
    check_stable,
    model_digest,
    render,
)


class ControllerNotExportableError(ExportError, LookupError):
    """The controller kind has no C export (the MPC, or a plugin without one)."""


@dataclass(frozen=True)
class BankTables:
    """A scheduled bank as the C template runs it.

    Attributes
    ----------
    family : {"pid", "linear"}
        ``pid``: one PID with interpolated gains; ``linear``: switched compensators.
    tables : dict of str to ndarray
        Per-design coefficients.
    constants : dict
        Sizes and scalars (``order``, ``dt_s``, limits, ...).
    """

    family: str
    tables: dict[str, np.ndarray]
    constants: dict[str, Any]


_EMITTERS = EmitterRegistry("controller", ControllerNotExportableError)


def register_controller_c_export(kind: str, emitter: Callable[[ScheduledController], BankTables]
                                 | str, *, replace: bool = False) -> None:
    """Register how the bank of controller kind ``kind`` is exported to C.

    Parameters
    ----------
    kind : str
        Registered controller kind (:mod:`controllers.registry`).
    emitter : callable or str
        ``emitter(core) -> BankTables`` for the design's
        :class:`~controllers.schedule.ScheduledController`, or its ``"module:attribute"``.
    """
    _EMITTERS.register(kind, emitter, replace=replace)


def c_exportable_controllers() -> tuple[str, ...]:
    """Controller kinds with a C export."""
    return _EMITTERS.names()


def check_controller_exportable(kind: str) -> None:
    """Refuse a controller kind without a C export (before anything is designed).

    Raises
    ------
    ControllerNotExportableError
        The message lists the kinds that have one.
    """
    _EMITTERS.check(kind)


def pid_bank(core: ScheduledController) -> BankTables:
    """The ``"interpolate"`` bank: grid gains of PID designs, the runner's filter and limits."""
    if core.blend != "interpolate" or not all(isinstance(d, PID) for d in core.designs):
        raise ExportError(f"{core.name}: expected PID designs with blend 'interpolate', found "
                          f"{type(core.designs[0]).__name__} with blend {core.blend!r}")
    runner = core.designs[0]
    gains = np.array([(d.kp, d.ki_per_s, d.kd_s) for d in core.designs], dtype=float)
    fixed_tt = runner._tracking_time_s
    constants = {"tf": float(runner.derivative_filter_s),
                 "u_lo": runner.u_limits[0], "u_hi": runner.u_limits[1],
                 "derivative_on_error": runner.derivative_on == "error",
                 "fixed_tracking": fixed_tt is not None,
                 "tracking_time_s": float(fixed_tt) if fixed_tt is not None else 0.0}
    return BankTables("pid", {"kp": gains[:, 0], "ki": gains[:, 1], "kd": gains[:, 2]},
                      constants)


def linear_bank(core: ScheduledController) -> BankTables:
    """The ``"switch"`` bank of :class:`~controllers.lead_lag.LinearController` designs.

    Raises
    ------
    ExportError
        Designs of different orders or limits, a warm mode other than ``none`` or
        ``neighbours``, or an unstable compensator or anti-windup map.
    """
    designs = core.designs
    if core.blend != "switch" or not all(isinstance(d, LinearController) for d in designs):
        raise ExportError(f"{core.name}: expected LinearController designs with blend "
                          f"'switch', found {type(designs[0]).__name__} with {core.blend!r}")
    if core.warm not in ("none", "neighbours"):
        raise ExportError(f"{core.name}: expected warm 'none' or 'neighbours', found "
                          f"{core.warm!r}")
    orders = {d._A.shape[0] for d in designs}
    limits = {d.u_limits for d in designs}
    if len(orders) != 1 or len(limits) != 1:
        raise ExportError(f"{core.name}: expected designs of one order and one command range, "
                          f"found orders {sorted(orders)} and ranges {sorted(limits)}")
    n = orders.pop()
    for i, d in enumerate(designs):
        check_stable(f"{core.name} design {i}", d._A, allow_unit=True)
        check_stable(f"{core.name} design {i} anti-windup", d._A - np.outer(d._Baw, d._C))
    e1 = np.zeros(n + 1)
    e1[0] = 1.0
    x_reset = [np.linalg.lstsq(np.vstack([d._C[None, :], np.eye(n) - d._A]), e1,
                               rcond=None)[0] for d in designs]
    direction = [np.zeros(n) if d._integrator_dir is None else d._integrator_dir
                 for d in designs]
    tables = {"A": np.array([d._A for d in designs]), "B": np.array([d._B for d in designs]),
              "C": np.array([d._C for d in designs]), "D": np.array([d._D for d in designs]),
              "Baw": np.array([d._Baw for d in designs]), "x_reset": np.array(x_reset),
              "int_dir": np.array(direction),
              "has_int_dir": np.array([d._integrator_dir is not None for d in designs],
                                      dtype=float)}
    lo, hi = limits.pop()
    return BankTables("linear", tables, {"order": n, "u_lo": lo, "u_hi": hi})


register_controller_c_export("pid", pid_bank)
register_controller_c_export("lead_lag", linear_bank)


def steps_to_reach(duration_s: float, dt_s: float) -> int:
    """Steps after which a float64 sum of ``dt_s`` (from 0) first reaches ``duration_s``."""
    total, n = 0.0, 0
    while total < duration_s:
        total += dt_s
        n += 1
    return n


def _layers(design: Any) -> tuple[SlipReflex | None, ContactGate, ScheduledController]:
    runtime = design.controller
    reflex = runtime if isinstance(runtime, SlipReflex) else None
    gate = reflex.controller if reflex is not None else runtime
    if not isinstance(gate, ContactGate) or gate.controller is not design.core:
        raise ExportError(f"{design.kind}: expected the runtime controller to be the design's "
                          f"bank in a ContactGate (and a SlipReflex), found "
                          f"{type(runtime).__name__}")
    return reflex, gate, design.core


def _gate_context(design: Any, gate: ContactGate) -> tuple[dict[str, np.ndarray], dict]:
    if gate.feedforward is not None and gate.feedforward != design.feedforward:
        raise ExportError("ContactGate: expected the design's feedforward table, found another "
                          "function")
    y0, u0 = design._static_map if gate.feedforward is not None else (np.zeros(1), np.zeros(1))
    tables = {"ff_y": np.asarray(y0, float), "ff_u": np.asarray(u0, float)}
    constants = {"has_ff": gate.feedforward is not None, "n_ff": int(np.asarray(y0).size),
                 "ff_left_slope_inv": float(max(float(y0[0]), 1e-9)),
                 "closing": gate.closing_command, "release_below": gate.release_below_n,
                 "opening": gate.opening_command, "approach_speed": gate.approach_speed_rad_s,
                 "approach_gain": gate.approach_gain, "rate_step": gate.force_rate_n_s * gate.dt_s,
                 "lost_steps": steps_to_reach(gate.lost_contact_s, gate.dt_s),
                 "handover_fraction": gate.handover_fraction, "gate_dt": gate.dt_s}
    return tables, constants


def _reflex_context(reflex: SlipReflex | None) -> dict[str, Any]:
    if reflex is None:
        return {"reflex": False}
    return {"reflex": True, "r_dt": reflex.dt_s, "r_latency": reflex.latency_samples,
            "r_gain": reflex.gain, "r_threshold": reflex.slip_speed_threshold_m_s,
            "r_arm_steps": reflex._arm_steps, "r_decay": reflex._decay,
            "r_max_boost": reflex.max_boost, "r_distance_gain": reflex.distance_gain_per_m,
            "r_has_ceiling": math.isfinite(reflex.ceiling_n),
            "r_ceiling": reflex.ceiling_n if math.isfinite(reflex.ceiling_n) else 0.0,
            "r_release_below": reflex.release_below_n}


def controller_context(design: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Every table and constant of the runtime controller of a design, checked.

    Raises
    ------
    ControllerNotExportableError
        The design's kind has no C export; lists the kinds that have one.
    ExportError
        A runtime not built as :func:`controllers.design._runtime` builds it,
        non-finite coefficients, or an unstable compensator.
    """
    kind = design.kind
    emit = _EMITTERS.emitter(kind)
    reflex, gate, core = _layers(design)
    bank = emit(core)
    forces = np.asarray(core.forces_n, float)
    edges = np.sqrt(forces[:-1] * forces[1:]) if forces.size > 1 else np.zeros(0)
    gate_tables, gate_constants = _gate_context(design, gate)
    tables = {**bank.tables, **gate_tables, "forces": forces, "edges": edges}
    constants = {**bank.constants, **gate_constants, **_reflex_context(reflex),
                 "kind": kind, "family": bank.family, "n_designs": int(forces.size),
                 "dt": float(core.dt_s), "alpha": min(1.0, core.dt_s / core.release_s),
                 "hysteresis": core.hysteresis, "warm_neighbours": core.warm == "neighbours"}
    if constants["n_designs"] > 32:
        raise ExportError(f"{kind}: {forces.size} designs; the C bank holds at most 32")
    check_finite(f"controller {kind}", tables)
    check_finite(f"controller {kind}", {k: np.asarray(v, float) for k, v in constants.items()
                                        if isinstance(v, float)})
    return tables, constants


def export_controller(design: Any) -> CModel:
    """``griploop_controller.h`` and ``.c`` of a design's runtime controller.

    Parameters
    ----------
    design : controllers.design.ControllerDesign
        As :func:`controllers.design.design_for_object` (or the design cache) built it,
        before any episode ran it.

    Raises
    ------
    ControllerNotExportableError, ExportError
        As :func:`controller_context`; nothing is rendered then.
    """
    tables, constants = controller_context(design)
    digest = model_digest(f"controller {constants['kind']}", tables, constants)
    ctx = dict(constants, tables=tables, digest=digest, object_name=design.object.name)
    files = {name: render("controllers", name + ".j2", **ctx)
             for name in ("griploop_controller.h", "griploop_controller.c")}
    summary = {"controller": constants["kind"], "object": design.object.name,
               "designs": constants["n_designs"], "control_dt_s": constants["dt"],
               "blend": "interpolate" if constants["family"] == "pid" else "switch",
               "slip_reflex": constants["reflex"],
               "design_forces_n": [float(f) for f in tables["forces"]]}
    return CModel("controller", files, digest, summary)
