"""Controllers by name, each designed from a specification."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import control

from controllers.errors import UnknownControllerError
from controllers.lead_lag import design_lead_lag
from controllers.mpc import design_mpc
from controllers.pid import design_pid

DESIGNS: dict[str, Callable[..., Any]] = {
    "pid": design_pid,
    "lead_lag": design_lead_lag,
    "mpc": design_mpc,
}
CONTROLLER_NAMES = tuple(DESIGNS)


def design_controller(name: str, plant: control.LTI, **spec: Any) -> Any:
    """Design the controller registered as ``name`` for ``plant`` from ``spec``.

    Parameters
    ----------
    name : {"pid", "lead_lag", "mpc"}
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N).
    **spec
        Keyword arguments of :func:`~controllers.pid.design_pid`,
        :func:`~controllers.lead_lag.design_lead_lag` or :class:`~controllers.mpc.MPC`.

    Returns
    -------
    controller
        With ``reset()``, ``act(observation)``, ``loop(plant)`` and ``report_``.

    Raises
    ------
    UnknownControllerError
        If ``name`` is not registered; the message lists the valid names.
    """
    if name not in DESIGNS:
        raise UnknownControllerError(
            f"controller: expected one of {list(CONTROLLER_NAMES)}, found {name!r}"
        )
    return DESIGNS[name](plant, **spec)
