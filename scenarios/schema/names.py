"""Names a scenario may use, read from the registries at validation time, and kind options.

Names of the extensible families (scenario kinds, sEMG generators, objects,
estimators, controllers, user kinds, feedback modes) are not listed anywhere
in the schema: each field is checked, when a scenario is validated, against
the registry that owns the family, so a registration made later (in a plugin
or a test) is accepted at once. The registries are imported on first
validation; each imports only its names.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sim.errors import GriploopError

#: Reference source that is not an estimator: the user's true intent (a perfect estimate).
ORACLE = "oracle"
#: The intact hand: a human-speed hand (pre-shaped to the object, closing in human time:
#: :mod:`sim.hand.human`) that follows the user's true grip force at every control step, no
#: sEMG path, planned with the anticipatory coupling of grip to load
#: (:mod:`sim.user.grip_load`); its user feels through touch (feedback ``touch``).
INTACT = "intact"
#: The ideal interface: the prosthesis's own hand driven by the user's true grip force at every
#: control step (no window, no estimator); its user feels through touch. Called the
#: intact-hand reference (``intact``) before issue 37.
IDEAL_INTERFACE = "ideal_interface"
#: References whose hand follows the user's own force at every control step.
OWN_FORCE = (INTACT, IDEAL_INTERFACE)
#: Reference sources that fit no estimator.
NO_ESTIMATOR = (ORACLE, *OWN_FORCE)
#: Feature windows a scenario may use, ms (``estimator.window_ms``, ``--window-ms``).
WINDOW_RANGE_MS = (50.0, 1000.0)
#: Window increments a scenario may use, ms (``estimator.step_ms``, ``--step-ms``).
STEP_RANGE_MS = (10.0, 500.0)
#: Practice lifts a scenario may ask for (``user.practice``, ``--practice``).
PRACTICE_RANGE = (0, 50)


def scenario_kinds() -> tuple[str, ...]:
    """Scenario kinds registered in :mod:`scenarios.runners.dispatch`."""
    from scenarios.runners.dispatch import scenario_kinds as kinds

    return kinds()


def kind_protocols(kind: str) -> tuple[str, ...]:
    """Protocols a scenario kind runs (empty: any), from its registration."""
    from scenarios.runners.dispatch import kind_info

    return tuple(kind_info(kind)["protocols"])


def generator_names() -> tuple[str, ...]:
    """sEMG generators registered in :mod:`sim.user.generators`."""
    from sim.user.generators import generator_names as names

    return names()


def object_names() -> tuple[str, ...]:
    """Objects registered in :mod:`sim.hand.objects`."""
    from sim.hand.objects import object_names as names

    return names()


def estimator_choices() -> tuple[str, ...]:
    """Estimators registered in :mod:`estimation.registry`, then
    :data:`~scenarios.schema.names.ORACLE`, :data:`~scenarios.schema.names.INTACT` and
    :data:`~scenarios.schema.names.IDEAL_INTERFACE`."""
    from estimation.registry import estimator_names

    return (*estimator_names(), *NO_ESTIMATOR)


def controller_names() -> tuple[str, ...]:
    """Controller kinds registered in :mod:`controllers.registry`."""
    from controllers.registry import controller_names as names

    return names()


def user_kinds() -> tuple[str, ...]:
    """User kinds (operator models) registered in :mod:`sim.user.operators`."""
    from sim.user.operators import operator_names

    return operator_names()


def feedback_modes() -> tuple[str, ...]:
    """Feedback modes registered in :mod:`sim.user.operators`."""
    from sim.user.operators import feedback_names

    return feedback_names()


def drive_names() -> tuple[str, ...]:
    """Hand transmissions registered in :mod:`sim.hand.drive`."""
    from sim.hand.drive import drive_names as names

    return names()


def paradigm_names() -> tuple[str, ...]:
    """Paradigms registered in :mod:`controllers.paradigms`."""
    from controllers.paradigms import paradigm_names as names

    return names()


def decoder_names() -> tuple[str, ...]:
    """Open/close decoders registered in :mod:`estimation.decoding`."""
    from estimation.decoding import decoder_names as names

    return names()


#: Module attributes of :mod:`scenarios.schema.models` that list what is registered now.
REGISTRY_LISTS = {"ESTIMATORS": estimator_choices, "OBJECTS": object_names,
          "GENERATORS": generator_names, "CONTROLLERS": controller_names,
          "SCENARIO_KINDS": scenario_kinds, "USER_KINDS": user_kinds,
          "FEEDBACK_MODES": feedback_modes, "DRIVES": drive_names,
          "PARADIGMS": paradigm_names, "DECODERS": decoder_names}


def check_registered(value: str, names: tuple[str, ...]) -> str:
    """``value`` if it is one of ``names``; else the one-line error listing them."""
    if value not in names:
        raise ValueError(f"expected one of {', '.join(names)} (found {value!r})")
    return value


#: Options with a field of their own in :class:`ControllerConfig`.
_CONTROLLER_FIELDS = ("horizon", "solver")


def controller_own_options(kind: str) -> dict[str, Any]:
    """A controller kind's registered options without a field of their own, with defaults.

    ``{name: default or None}``.
    """
    from controllers.registry import controller_info

    info = controller_info(kind)
    return {k: info["defaults"].get(k) for k in info["options"] if k not in _CONTROLLER_FIELDS}


class OptionError(GriploopError, ValueError):
    """An option the component does not declare; ``key`` names it (for the file line)."""

    def __init__(self, message: str, key: str) -> None:
        super().__init__(message)
        self.key = key


def check_declared_options(what: str, given: dict[str, Any],
                           declared: dict[str, Any]) -> dict[str, Any]:
    """``given`` if every key is declared and has the type of its declared default.

    Parameters
    ----------
    what : str
        The component, for messages (``"controller lead_lag"``).
    given : dict
        Options from the scenario.
    declared : dict
        ``{name: default}``; a ``None`` default accepts any value.

    Raises
    ------
    OptionError
        An undeclared option (the message names the declared ones) or a value
        of another type than the default's.
    """
    for key, value in given.items():
        if key not in declared:
            has = ", ".join(sorted(declared)) or "none"
            raise OptionError(f"{what} has no option {key!r} (its options: {has})", key)
        default = declared[key]
        if default is None:
            continue
        if isinstance(default, tuple) and isinstance(value, list):  # YAML has lists only
            given[key] = value = tuple(value)
            continue
        numeric = isinstance(default, (int, float)) and not isinstance(default, bool)
        ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
              and (isinstance(default, float) or isinstance(value, int))) if numeric else (
            isinstance(value, type(default)))
        if not ok or (numeric and not np.isfinite(value)):
            raise OptionError(f"{what} option {key}: expected a {type(default).__name__} "
                              f"like its default {default!r} (found {value!r})", key)
    return given


def estimator_own_options(name: str) -> dict[str, Any]:
    """An estimator's own hyperparameters a scenario may set, with their defaults.

    What the estimator declares (scikit-learn's ``get_params``), less what its
    registration fixes and what an evaluation sets (order, seed, feature period).
    The oracle, the intact hand and the ideal interface have none.
    """
    if name in NO_ESTIMATOR:
        return {}
    from estimation.registry import estimator_info, make_estimator

    est = make_estimator(name, normalize=False)
    declared = est.get_params(deep=False) if hasattr(est, "get_params") else {}
    info = estimator_info(name)
    reserved = {*info["params"], *info["order_params"], "random_state", "dt_s"}
    return {k: v for k, v in declared.items() if k not in reserved}
