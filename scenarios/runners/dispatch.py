"""Dispatch of a scenario to the runner of its kind.

:func:`run_scenario` is the default task of a sweep. It looks the scenario's
``kind`` (``reproduction``, ``calibration`` or ``episode``) up in a registry
and calls the function registered for it, which returns a ``ResultRow``:
a flat mapping of result names to scalars (``bool``, ``int``, ``float``,
``str`` or ``None``) and, optionally, under the key ``"traces"``, a mapping of
trace names to numeric arrays of shape ``(n_samples,)`` or
``(n_samples, n_channels)``.

A scenario kind is registered once with :func:`register_kind`: its runner and
the protocols (``protocol.name``) it runs; the scenario schema, sweeps and the
CLI take the kinds from here, and the schema refuses other protocols for the
kind. The runner is a callable or a ``"package.module:function"`` reference
imported on first use, so that registering a kind never imports its simulation
stack. A kind may be known without a runner (a build without its backend):
:func:`register_runner` and :func:`unregister_runner` change only the runner.

Registered here, by reference so that importing this module imports neither the
simulation nor the estimators: ``reproduction`` (:mod:`scenarios.runners.reproduction`),
``calibration`` (:mod:`scenarios.runners.calibration`), ``episode``
(:mod:`scenarios.runners.episode`) and the feedback benchmarks ``eggs``,
``slip_recovery`` and ``force_matching`` (:mod:`scenarios.runners.feedback_tasks`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sim.errors import GriploopError
from sim.registry import (
    Capabilities,
    RegistrationError,
    Registry,
    UnresolvableEntryError,
    import_reference,
)

ResultRow = Mapping[str, Any]
"""Flat mapping of result names to scalars, plus optional ``"traces"``."""

Runner = Callable[[Any], ResultRow]
"""``runner(scenario) -> ResultRow`` for a :class:`scenarios.schema.Scenario` of its kind
(typed ``Any`` here: the schema reads the kinds from this module, so this one does not
import the schema)."""


class RunnerUnavailableError(GriploopError, LookupError):
    """No runner is registered for a scenario kind, or its backend cannot be imported."""


class UnsupportedScenarioError(GriploopError, ValueError):
    """A runner cannot honour a field of the scenario (e.g. a mode its estimator lacks)."""


class DivergedError(GriploopError, RuntimeError):
    """A scenario ran but its result diverged (e.g. an unstable identified model)."""


@dataclass(frozen=True)
class ScenarioKind(Capabilities):
    """What a scenario kind declares when it registers (:func:`register_kind`).

    Attributes
    ----------
    protocols : tuple of str
        The ``protocol.name`` values the kind runs; empty: any.
    """

    protocols: tuple[str, ...]


_KINDS = Registry("scenario kind", RunnerUnavailableError, capabilities=ScenarioKind)
_REGISTRY: dict[str, Runner | str] = {}


def register_kind(kind: str, runner: Runner | str | None = None, *,
                  protocols: Sequence[str] = (), replace: bool = False) -> None:
    """Register a scenario kind, the protocols it runs and its runner.

    Parameters
    ----------
    kind : str
        Scenario kind (``scenario.kind``).
    runner : callable or str, optional
        ``runner(scenario) -> ResultRow``, or its ``"package.module:function"``
        reference, imported when first used (see :func:`register_runner`).
    protocols : sequence of str
        The ``protocol.name`` values the kind runs; empty: any.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed runner reference, or kind already registered (a ``ValueError``).
    """
    _KINDS.register(kind, None, replace=replace, protocols=tuple(protocols))
    if runner is not None:
        register_runner(kind, runner, replace=True)


def unregister_kind(kind: str) -> None:
    """Remove a scenario kind and its runner (no effect if absent)."""
    _KINDS.unregister(kind)
    _REGISTRY.pop(kind, None)


def scenario_kinds() -> tuple[str, ...]:
    """Registered scenario kinds, in registration order."""
    return _KINDS.names()


def kind_info(kind: str) -> Mapping[str, Any]:
    """Metadata of a registered kind (``protocols``).

    Raises
    ------
    RunnerUnavailableError
        ``kind`` is not registered; the message lists the registered kinds.
    """
    return _KINDS.info(kind)


def register_runner(kind: str, runner: Runner | str, *, replace: bool = False) -> None:
    """Register the runner of a registered scenario kind.

    Parameters
    ----------
    kind : str
        A kind of :func:`scenario_kinds`.
    runner : callable or str
        ``runner(scenario) -> ResultRow``, or its ``"package.module:function"``
        reference, imported when first used.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Unknown kind, malformed reference, or kind already registered (a ``ValueError``).
    """
    if kind not in _KINDS:
        raise RegistrationError(
            f"scenario kind must be one of {scenario_kinds()} (found {kind!r})")
    if isinstance(runner, str) and runner.count(":") != 1:
        raise RegistrationError(
            f"runner reference must be 'package.module:function' (found {runner!r})")
    if kind in _REGISTRY and not replace:
        raise RegistrationError(
            f"a runner for kind {kind!r} is already registered ({_REGISTRY[kind]!r})")
    _REGISTRY[kind] = runner


def unregister_runner(kind: str) -> None:
    """Remove the runner of ``kind`` (no effect if none is registered); the kind stays."""
    _REGISTRY.pop(kind, None)


def registered_kinds() -> tuple[str, ...]:
    """Scenario kinds that have a runner registered."""
    return tuple(k for k in scenario_kinds() if k in _REGISTRY)


def get_runner(kind: str) -> Runner:
    """The runner of ``kind``, importing it if it was registered by reference.

    Raises
    ------
    RunnerUnavailableError
        Nothing is registered for ``kind``, or its module cannot be imported.
    """
    entry = _REGISTRY.get(kind)
    if entry is None:
        have = ", ".join(registered_kinds()) or "none"
        raise RunnerUnavailableError(
            f"no runner registered for scenario kind {kind!r} (registered: {have}); "
            "its simulation backend is not installed in this version of griploop"
        )
    if callable(entry):
        return entry
    try:
        return import_reference(entry)
    except UnresolvableEntryError as exc:
        raise RunnerUnavailableError(
            f"runner {entry!r} of scenario kind {kind!r}: {exc}"
        ) from None


def require_runners(kinds: set[str] | frozenset[str] | tuple[str, ...]) -> None:
    """Check that every kind in ``kinds`` has an importable runner (before a sweep starts).

    Raises
    ------
    RunnerUnavailableError
        For the first kind, in sorted order, that has none.
    """
    for kind in sorted(kinds):
        get_runner(kind)


def run_scenario(scenario: Any) -> ResultRow:
    """Run one scenario with the runner registered for its kind.

    Parameters
    ----------
    scenario : scenarios.schema.Scenario
        A validated scenario with its seed set.

    Returns
    -------
    ResultRow
        Flat mapping of scalars plus optional ``"traces"``; the scenario kind
        and estimator mode are added as ``kind`` and ``mode`` when absent.

    Raises
    ------
    RunnerUnavailableError
        No runner for ``scenario.kind``.
    """
    row = dict(get_runner(scenario.kind)(scenario))
    row.setdefault("kind", scenario.kind)
    row.setdefault("mode", scenario.estimator.mode)
    return row


register_kind("reproduction", "scenarios.runners.reproduction:run_reproduction_scenario",
              protocols=("paper_calibration",))
register_kind("calibration", "scenarios.runners.calibration:run_calibration_scenario",
              protocols=("paper_calibration",))
register_kind("episode", "scenarios.runners.episode:run_episode_scenario",
              protocols=("grasp_lift_hold", "fragile_handling"))
register_kind("eggs", "scenarios.runners.feedback_tasks:run_eggs_scenario",
              protocols=("virtual_eggs",))
register_kind("slip_recovery", "scenarios.runners.feedback_tasks:run_slip_recovery_scenario",
              protocols=("slip_recovery",))
register_kind("force_matching", "scenarios.runners.feedback_tasks:run_force_matching_scenario",
              protocols=("force_matching",))
register_kind("transfers", "scenarios.runners.transfers:run_transfers_scenario",
              protocols=("timed_transfers",))
