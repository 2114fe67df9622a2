"""Planning a sweep: content hashes of expanded scenarios, and the task that runs them.

Tasks are importable callables ``task(scenario) -> ResultRow`` given as a
callable or as ``"package.module:function"``; the default is
:func:`scenarios.runners.dispatch.run_scenario`. A task's name is part of every
scenario's content hash (:func:`scenarios.store.content_hash`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from scenarios.schema import ExpandedScenario, Scenario
from scenarios.store import content_hash, package_version
from sim.errors import GriploopError
from sim.registry import UnresolvableEntryError, import_reference

DEFAULT_TASK = "scenarios.runners.dispatch:run_scenario"
Task = str | Callable[[Scenario], Mapping[str, Any]]


class SweepError(GriploopError, ValueError):
    """A sweep cannot run as asked (bad task reference, worker count, options)."""


@dataclass(frozen=True)
class PlannedScenario:
    """An expanded scenario with its store key.

    Attributes
    ----------
    hash : str
        :func:`scenarios.store.content_hash` of config, version and task.
    index : int
        Position in the sweep.
    scenario : Scenario
        The scenario (seed set).
    config_json : str
        Its canonical JSON.
    overrides : dict
        Design values of this point.
    """

    hash: str
    index: int
    scenario: Scenario
    config_json: str
    overrides: dict[str, Any]


def task_name(task: Task) -> str:
    """``"package.module:function"`` of a task (part of every content hash).

    Raises
    ------
    SweepError
        A callable that cannot be imported by name (lambda, nested function).
    """
    if isinstance(task, str):
        if task.count(":") != 1 or not all(task.split(":")):
            raise SweepError(f"task must be 'package.module:function' (found {task!r})")
        return task
    module, qualname = getattr(task, "__module__", None), getattr(task, "__qualname__", "")
    if not module or "<" in qualname:
        raise SweepError(f"task must be an importable module-level function (found {task!r})")
    return f"{module}:{qualname}"


def resolve_task(task: Task) -> Callable[[Scenario], Mapping[str, Any]]:
    """The callable behind a task reference.

    Raises
    ------
    SweepError
        The module cannot be imported or has no such callable.
    """
    if not isinstance(task, str):
        return task
    try:
        return import_reference(task_name(task))
    except UnresolvableEntryError as exc:
        raise SweepError(f"task {task!r}: {exc}") from None


def plan(
    expanded: Iterable[ExpandedScenario], task: Task = DEFAULT_TASK, version: str | None = None
) -> list[PlannedScenario]:
    """Attach content hashes to expanded scenarios.

    Raises
    ------
    SweepError
        Two scenarios have the same hash (the expansion produced duplicates).
    """
    return list(iter_plan(expanded, task, version))


def iter_plan(
    expanded: Iterable[ExpandedScenario], task: Task = DEFAULT_TASK, version: str | None = None
) -> Iterator[PlannedScenario]:
    """:func:`plan` one scenario at a time (the task is named eagerly)."""
    name = task_name(task)
    version = package_version() if version is None else version
    return _iter_plan(expanded, name, version)


def _iter_plan(
    expanded: Iterable[ExpandedScenario], name: str, version: str
) -> Iterator[PlannedScenario]:
    seen: dict[str, int] = {}
    for item in expanded:
        config = item.scenario.canonical_json()
        key = content_hash(config, version, name)
        if key in seen:
            raise SweepError(
                f"scenarios {seen[key]} and {item.index} are identical "
                "(expected distinct scenarios)"
            )
        seen[key] = item.index
        yield PlannedScenario(key, item.index, item.scenario, config, dict(item.overrides))
