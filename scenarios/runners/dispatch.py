"""Dispatch of a scenario to the runner of its kind.

:func:`run_scenario` is the default task of a sweep. It looks the scenario's
``kind`` (``reproduction``, ``calibration`` or ``episode``) up in a registry
and calls the function registered for it, which returns a :data:`ResultRow`:
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

Registered here: ``reproduction`` (:func:`run_reproduction_scenario`), and by reference
``episode`` and ``calibration`` (:mod:`scenarios.runners.episode`) and the feedback
benchmarks ``eggs``, ``slip_recovery`` and ``force_matching``
(:mod:`scenarios.runners.feedback_tasks`), so that importing this module does not
import MuJoCo.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from sim.errors import GriploopError
from sim.registry import RegistrationError, Registry, UnresolvableEntryError, import_reference

if TYPE_CHECKING:
    from estimation.features import FeatureSet
    from scenarios.schema import Scenario

ResultRow = Mapping[str, Any]
"""Flat mapping of result names to scalars, plus optional ``"traces"``."""

Runner = Callable[["Scenario"], ResultRow]


class RunnerUnavailableError(GriploopError, LookupError):
    """No runner is registered for a scenario kind, or its backend cannot be imported."""


class UnsupportedScenarioError(GriploopError, ValueError):
    """A runner cannot honour a field of the scenario (e.g. a mode its estimator lacks)."""


class DivergedError(GriploopError, RuntimeError):
    """A scenario ran but its result diverged (e.g. an unstable identified model)."""


_KINDS = Registry("scenario kind", RunnerUnavailableError)
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


def run_scenario(scenario: Scenario) -> ResultRow:
    """Run one scenario with the runner registered for its kind.

    Parameters
    ----------
    scenario : Scenario
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


def run_reproduction_scenario(scenario: Scenario) -> ResultRow:
    """One subject x estimator x mode of the paper's evaluation (kind ``reproduction``).

    The virtual subject ``VirtualSubject.sample(population_seed, subject_id)``
    (with the scenario's electrode shift, extra noise and fatigue) performs the
    paper's squeeze session with the FSR; features are extracted on the paper's
    channels; the estimator is fitted on the first ``identification_fraction``
    of the windows and scored on the rest (``estimation.evaluation``), as
    ``griploop reproduce`` does for a whole population.

    Parameters
    ----------
    scenario : Scenario
        Kind ``reproduction``, seed set. ``seed`` drives the session (protocol
        timing, levels, noise) and the networks' initialization.

    Returns
    -------
    ResultRow
        ``r2``, ``nrmse``, ``rmse_n``, ``volatility_n_per_s`` on the validation
        part, ``train_ms``, ``step_us``, ``order``, ``n_windows``,
        ``n_identification``, ``session_s``, and traces ``t_s``, ``force_n``
        (measured) and ``force_hat_n`` (estimated), shape (n_validation,).

    Raises
    ------
    UnsupportedScenarioError
        ``protocol.calibration_s`` set (the paper session has its own length)
        or a mode the estimator does not have.
    DivergedError
        The identified model is unstable in the requested mode.
    """
    from scenarios.runners.subject import calibration_session, subject_for

    if scenario.protocol.calibration_s is not None:
        raise UnsupportedScenarioError(
            "the paper session has its own length (about 25-36 s): leave "
            f"protocol.calibration_s unset (found {scenario.protocol.calibration_s:g})"
        )
    session_seq, estimator_seq = np.random.SeedSequence(scenario.seed).spawn(2)
    subject = subject_for(scenario)
    recording, features = calibration_session(subject, np.random.default_rng(session_seq),
                                              generator=scenario.subject.generator)
    result = _evaluate_estimator(scenario, features, np.random.default_rng(estimator_seq))
    return _reproduction_row(scenario, result, features, recording.duration_s)


def _evaluate_estimator(scenario: Scenario, features: FeatureSet,
                        rng: np.random.Generator) -> dict[str, Any]:
    """Fit the scenario's estimator on the first part of the session, score it on the rest.

    Returns
    -------
    dict
        :func:`estimation.evaluation.evaluate_subject`'s entry of the estimator,
        with its fitted ``"_pipeline"``.

    Raises
    ------
    UnsupportedScenarioError
        The estimator has no such mode.
    DivergedError
        The identified model is unstable in the requested mode.
    """
    from estimation.evaluation import evaluate_subject
    from estimation.paper import PAPER_ORDER
    from estimation.reproduce import estimator_params
    from estimation.threads import one_blas_thread

    est = scenario.estimator
    order = PAPER_ORDER if est.order is None else est.order
    params = estimator_params([est.name], rng, order, dt_s=features.dt_s)
    with one_blas_thread():
        result = evaluate_subject(features.X, features.y, params, dt_s=features.dt_s,
                                  fraction=scenario.protocol.identification_fraction)[est.name]
    if est.mode not in result["modes"]:
        raise UnsupportedScenarioError(
            f"estimator {est.name} has modes {tuple(result['modes'])} (found mode {est.mode})"
        )
    scores = result["modes"][est.mode]
    if scores["status"] != "ok":
        raise DivergedError(f"{est.name} {est.mode}: {scores.get('message', scores['status'])}")
    return result


def _reproduction_row(scenario: Scenario, result: Mapping[str, Any], features: FeatureSet,
                      session_s: float) -> ResultRow:
    """The result row of :func:`run_reproduction_scenario`, with its validation traces."""
    from estimation.evaluation import split_index
    from estimation.paper import PAPER_ORDER

    est = scenario.estimator
    scores = result["modes"][est.mode]
    n_id = split_index(features.n_windows, scenario.protocol.identification_fraction)
    force_hat_n = result["_pipeline"].predict(features.X, features.y, mode=est.mode)[n_id:]
    return {
        "subject_id": scenario.subject.subject_id,
        "estimator": est.name,
        "mode": est.mode,
        "order": PAPER_ORDER if est.order is None else est.order,
        "r2": float(scores["r2"]),
        "nrmse": float(scores["nrmse"]),
        "rmse_n": float(scores["rmse_n"]),
        "volatility_n_per_s": float(scores["volatility_n_per_s"]),
        "train_ms": float(result["train_ms"]),
        "step_us": None if result["step_us"] is None else float(result["step_us"]),
        "n_windows": int(features.n_windows),
        "n_identification": int(n_id),
        "session_s": float(session_s),
        "traces": {
            "t_s": features.t_s[n_id:],
            "force_n": features.y[n_id:],
            "force_hat_n": np.asarray(force_hat_n, dtype=float),
        },
    }


register_kind("reproduction", run_reproduction_scenario, protocols=("paper_calibration",))
register_kind("calibration", "scenarios.runners.episode:run_calibration_scenario",
              protocols=("paper_calibration",))
register_kind("episode", "scenarios.runners.episode:run_episode_scenario",
              protocols=("grasp_lift_hold", "fragile_handling"))
register_kind("eggs", "scenarios.runners.feedback_tasks:run_eggs_scenario",
              protocols=("virtual_eggs",))
register_kind("slip_recovery", "scenarios.runners.feedback_tasks:run_slip_recovery_scenario",
              protocols=("slip_recovery",))
register_kind("force_matching", "scenarios.runners.feedback_tasks:run_force_matching_scenario",
              protocols=("force_matching",))
