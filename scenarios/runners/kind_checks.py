"""Behavioural checks of a registered scenario kind, for plugin authors.

A scenario kind (:func:`scenarios.runners.dispatch.register_kind`) is what a sweep
dispatches on: its registration (the protocols it runs) and its runner. Running a
runner is an experiment (minutes for the shipped kinds), so the checks stop short of
it; :func:`check_scenario_kind` checks, in order:

``protocols``
    The registration's ``protocols`` is a tuple of protocol names (strings).
``schema``
    For each declared protocol (the default protocol when it declares none), the
    scenario ``{kind: NAME, protocol: {name: PROTOCOL}}`` validates with every other
    field at its default (:func:`scenarios.schema.yaml_loading.parse_scenario`): the
    schema knows the protocol and accepts the kind with it.
``sweep``
    A sweep of that scenario expands to one scenario of the kind with its seed set
    (:func:`scenarios.schema.expansion.expand_sweep`).
``runner``
    A runner is registered and imports (:func:`~scenarios.runners.dispatch.get_runner`).
``runner_signature``
    The runner is called as ``runner(scenario)``: one positional argument binds.

Each returns :class:`sim.checks.CheckFailure` records, one line each.
"""

from __future__ import annotations

import inspect

from scenarios.runners.dispatch import get_runner, kind_info
from sim.checks import CheckFailure, raised

_FAMILY = "scenario kind"


def check_scenario_kind(name: str) -> list[CheckFailure]:
    """Check the registered scenario kind ``name`` (the checks of the module docstring).

    Parameters
    ----------
    name : str
        A registered scenario kind (:func:`scenarios.runners.dispatch.scenario_kinds`).

    Returns
    -------
    list of CheckFailure
        One per failed check; empty when the kind passes.

    Raises
    ------
    scenarios.runners.dispatch.RunnerUnavailableError
        ``name`` is not registered.
    """
    protocols = kind_info(name)["protocols"]  # raises for an unknown name, before any check
    failures = []
    if not isinstance(protocols, tuple) or not all(isinstance(p, str) for p in protocols):
        failures.append(_failure(name, "protocols", "a tuple of protocol names",
                                 repr(protocols)))
    else:
        failures += _check_schema(name, protocols)
    return failures + _check_runner(name)


def _failure(name: str, check: str, expected: str, found: str) -> CheckFailure:
    return CheckFailure(_FAMILY, name, check, expected, found)


def _check_schema(name: str, protocols: tuple[str, ...]) -> list[CheckFailure]:
    """``schema`` for every declared protocol, then ``sweep`` on the first."""
    from scenarios.schema import expand_sweep, parse_scenario, parse_sweep

    bases = [{"kind": name, "protocol": {"name": p}} for p in protocols] or [{"kind": name}]
    for base in bases:
        try:
            parse_scenario(base, source=f"kind {name}")
        except Exception as exc:
            return [_failure(name, "schema", f"the scenario {base} to validate",
                             raised(exc))]
    try:
        expanded = expand_sweep(parse_sweep({"name": f"check_{name}", "base": bases[0]}))
    except Exception as exc:
        return [_failure(name, "sweep", "a sweep of its scenario to expand", raised(exc))]
    kinds = [e.scenario.kind for e in expanded]
    if kinds != [name] or expanded[0].scenario.seed is None:
        seeds = [e.scenario.seed for e in expanded]
        return [_failure(name, "sweep", f"one scenario of kind {name} with its seed set",
                         f"kinds {kinds}, seeds {seeds}")]
    return []


def _check_runner(name: str) -> list[CheckFailure]:
    """``runner`` and ``runner_signature``."""
    try:
        runner = get_runner(name)
    except Exception as exc:
        return [_failure(name, "runner", "a registered runner that imports", raised(exc))]
    try:
        inspect.signature(runner).bind(object())
    except TypeError as exc:
        return [_failure(name, "runner_signature", "runner(scenario): one positional argument",
                         raised(exc))]
    except ValueError:  # no signature to read (a builtin): nothing to check
        pass
    return []
