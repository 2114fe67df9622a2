"""Controller kinds by name: how each designs itself and which specification it accepts.

A controller kind is registered once with :func:`register_controller`: the
function that designs one controller on one plant (by ``"module:attribute"``
reference, imported on first use) and a :class:`ControllerKind` declaring the
specification options it accepts, their defaults, and how a bank of its designs is
scheduled over grip force (:class:`controllers.schedule.ScheduledController`)::

    register_controller("lead_lag", "controllers.lead_lag:design_lead_lag", ControllerKind(
        options=("lag_ratio",), defaults={"phase_margin_deg": 60.0, "lag_ratio": 2.0}))

Everything else reads the registry: :func:`controllers.design.design_for_object`, the
scenario schema's ``controller.kind`` and the CLI's ``--controller`` choices.

Two families of specification:

- loop shaping (``shaping=True``): ``phase_margin_deg`` with ``crossover_rad_s``
  or ``bandwidth_rad_s``; the design function is called as
  ``design(plant, phase_margin_deg=..., crossover_rad_s=..., **fixed, **options)``
  (PID, lead-lag);
- model predictive (``shaping=False``): the kind's own options (e.g. ``horizon``)
  plus the slip sensing and force limit of the grasp (MPC).

Importing this module imports neither python-control nor any controller module.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from controllers.errors import UnknownControllerError
from sim.registry import Capabilities, RegistrationError, Registry

if TYPE_CHECKING:
    import control

    from controllers.base import Controller

#: Options of a loop-shaping specification (every ``shaping=True`` kind accepts them).
LOOP_SHAPING_OPTIONS = ("phase_margin_deg", "crossover_rad_s", "bandwidth_rad_s")

@dataclass(frozen=True)
class ControllerKind(Capabilities):
    """What a controller kind declares when it registers (:func:`register_controller`).

    Every field has a default: a registration declares only what differs.

    Attributes
    ----------
    shaping : bool
        Specified by loop shaping (:data:`LOOP_SHAPING_OPTIONS`) besides ``options``;
        otherwise by ``options`` only.
    options : tuple of str
        Its own specification options besides the loop-shaping ones (e.g.
        ``("lag_ratio",)``, ``("horizon",)``).
    accepted : tuple of str
        Every option a specification may set (loop shaping and ``options``): derived
        at registration, whatever is given.
    defaults : mapping
        Default specification (what the CLI and the library start from).
    fixed : mapping
        Keyword arguments always passed to the design (e.g. ``structure="pi"``).
    bank_design : callable, str or None
        What builds each design of a scheduled bank, if not the design function (e.g.
        a constructor that skips the per-design report), or its reference.
    blend : {"switch", "interpolate"}
        How the bank's designs are scheduled over grip force.
    warm : {"neighbours", "all", "none"}
        Which inactive designs track the applied command.
    slip_sensing : bool
        The design takes ``slip_sensing`` (a sensed slip bound) and ``force_max_n``.
    specified_by : str
        How the kind is specified, for messages (empty: its accepted options).
    """

    shaping: bool = True
    options: tuple[str, ...] = ()
    accepted: tuple[str, ...] = ()
    defaults: Mapping[str, Any] = field(default_factory=dict)
    fixed: Mapping[str, Any] = field(default_factory=dict)
    bank_design: Any = None
    blend: str = "switch"
    warm: str = "neighbours"
    slip_sensing: bool = False
    specified_by: str = ""


_REGISTRY = Registry("controller", UnknownControllerError, capabilities=ControllerKind)


def register_controller(name: str, design: Callable[..., Controller] | str,
                        kind: ControllerKind | None = None, *, replace: bool = False) -> None:
    """Register a controller kind.

    Parameters
    ----------
    name : str
        Name used in scenarios (``controller.kind``), sweeps and the CLI.
    design : callable or str
        ``design(plant, **spec) -> Controller`` on one design plant (command
        -1..1 to grip force, N), or its ``"package.module:attribute"`` reference.
    kind : ControllerKind, optional
        What the kind declares: its specification options and their defaults, and how
        its bank is scheduled (default: ``ControllerKind()``, loop shaping only).
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, bad ``blend`` or ``warm``, defaults outside the options,
        or ``name`` already registered.
    """
    kind = ControllerKind() if kind is None else kind
    if kind.blend not in ("switch", "interpolate") or \
            kind.warm not in ("neighbours", "all", "none"):
        raise RegistrationError(f"controller {name}: expected blend 'switch' or 'interpolate' "
                                f"and warm 'neighbours', 'all' or 'none', found {kind.blend!r}, "
                                f"{kind.warm!r}")
    options = tuple(kind.options)
    accepted = (*LOOP_SHAPING_OPTIONS, *options) if kind.shaping else options
    unknown = sorted(set(kind.defaults) - set(accepted))
    if unknown:
        raise RegistrationError(f"controller {name}: defaults {unknown} are not among its "
                                f"options {list(accepted)}")
    kind = dataclasses.replace(
        kind, shaping=bool(kind.shaping), options=options, accepted=accepted,
        defaults=dict(kind.defaults), fixed=dict(kind.fixed),
        slip_sensing=bool(kind.slip_sensing),
        specified_by=kind.specified_by or " and ".join(accepted) or "no options")
    _REGISTRY.register_record(name, design, kind, replace=replace)


unregister_controller, controller_names = _REGISTRY.functions(__name__, "controller")


def controller_info(name: str) -> Mapping[str, Any]:
    """Metadata of a controller kind (see :func:`register_controller`).

    Raises
    ------
    UnknownControllerError
        ``name`` is not registered; the message lists the valid names.
    """
    return _REGISTRY.info(name)


def default_spec(name: str) -> dict[str, Any]:
    """A fresh copy of the default specification of ``name``."""
    return dict(controller_info(name)["defaults"])


def check_options(name: str, given: Mapping[str, Any]) -> None:
    """Refuse specification options that ``name`` does not take.

    Parameters
    ----------
    name : str
        Controller kind.
    given : mapping
        Options the user set (``None`` values count as not set).

    Raises
    ------
    UnknownControllerError
        Unknown kind.
    SpecificationError
        An option outside the kind's accepted ones; the message says how the
        kind is specified and lists the refused options.
    """
    from controllers.errors import SpecificationError

    info = controller_info(name)
    refused = sorted(k for k, v in given.items() if v is not None and k not in info["accepted"])
    if refused:
        what = "loop-shaping options" if set(refused) <= set(LOOP_SHAPING_OPTIONS) else "options"
        raise SpecificationError(f"{name} is specified by {info['specified_by']}, "
                                 f"found {what} {refused}")


def design_controller(name: str, plant: control.LTI, **spec: Any) -> Controller:
    """Design the controller registered as ``name`` for ``plant`` from ``spec``.

    Parameters
    ----------
    name : str
        One of :func:`controller_names` (``"pid"``, ``"lead_lag"``, ``"mpc"``, ...).
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N).
    **spec
        Keyword arguments of the kind's design function, e.g.
        :func:`~controllers.pid.design_pid`, :func:`~controllers.lead_lag.design_lead_lag`
        or :func:`~controllers.mpc.design_mpc`.

    Returns
    -------
    Controller
        With ``reset()``, ``act(observation)``, ``loop(plant)``, and ``track``
        and ``handover`` (the design's own, or the defaults of
        :func:`controllers.base.complete_controller`).

    Raises
    ------
    UnknownControllerError
        If ``name`` is not registered; the message lists the valid names.
    SpecificationError
        The design returned something without ``reset``, ``act`` or ``loop``.
    """
    from controllers.base import complete_controller

    return complete_controller(_REGISTRY.get(name)(plant, **spec), _plant_dt(plant), kind=name)


def _plant_dt(plant: Any) -> float:
    """Sampling period of a discrete design plant, s (0 if it has none)."""
    dt = getattr(plant, "dt", None)
    return float(dt) if isinstance(dt, (int, float)) and not isinstance(dt, bool) else 0.0


def bank_designer(name: str) -> Callable[..., Controller]:
    """What builds each design of a scheduled bank of ``name`` (imported on first use).

    The returned function completes what it builds as :func:`design_controller` does.
    """
    from controllers.base import complete_controller

    entry = _REGISTRY.entry(name)
    bank = entry.info["bank_design"]
    if bank is None:
        build = entry.resolve()
    else:
        from sim.registry import Entry

        build = Entry(name, bank).resolve()

    def design(plant: control.LTI, **spec: Any) -> Controller:
        return complete_controller(build(plant, **spec), _plant_dt(plant), kind=name)

    return design


def design_modules(name: str) -> tuple[str, ...]:
    """Modules that define ``name``'s design functions (for cache keys and stored classes)."""
    info = controller_info(name)
    out = []
    for target in (_REGISTRY.entry(name).target, info["bank_design"]):
        if target is None:
            continue
        module = target.partition(":")[0] if isinstance(target, str) else getattr(
            target, "__module__", None)
        if module and module not in out:
            out.append(module)
    return tuple(out)


def __getattr__(attr: str) -> Any:
    if attr == "CONTROLLER_NAMES":  # the kinds registered so far
        return controller_names()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


register_controller("pid", "controllers.pid:design_pid", ControllerKind(
    fixed={"structure": "pi"}, defaults={"phase_margin_deg": 60.0, "crossover_rad_s": 30.0},
    blend="interpolate", warm="neighbours"))
register_controller("lead_lag", "controllers.lead_lag:design_lead_lag", ControllerKind(
    options=("lag_ratio",),
    defaults={"phase_margin_deg": 60.0, "crossover_rad_s": 30.0, "lag_ratio": 2.0},
    blend="switch", warm="none"))
register_controller("mpc", "controllers.mpc:design_mpc", ControllerKind(
    shaping=False, options=("horizon", "solver"), defaults={"horizon": 20, "solver": "daqp"},
    bank_design="controllers.mpc:MPC", blend="switch", warm="all", slip_sensing=True,
    specified_by="horizon and weights"))
