"""Every checker for plugin authors, over what is registered (``griploop check``).

The four checked families and their checkers:

=================  ===========================================================
family             checker
=================  ===========================================================
``controller``     :func:`controllers.checks.check_controller`
``estimator``      :func:`estimation.checks.check_estimator`
``object``         :func:`sim.hand.checks.check_object`
``scenario kind``  :func:`scenarios.runners.kind_checks.check_scenario_kind`
=================  ===========================================================

:func:`registered_names` lists what the registries hold now;
:func:`load_recorded` loads plugin modules (:func:`scenarios.plugins.load_plugins`) and
records what each added, which :func:`plugin_registrations` returns (the command line
loads its ``--plugin`` modules so); :func:`check_all` runs the checkers on either.
Importing this module imports the registries only when :func:`registered_names` is
called, and the checkers only when :func:`check_all` runs them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence

from scenarios.plugins import load_plugins
from sim.checks import CheckFailure, raised
from sim.registry import import_reference

#: ``family -> "module:checker"`` of every checked family, in the order they run.
CHECKERS: dict[str, str] = {
    "controller": "controllers.checks:check_controller",
    "estimator": "estimation.checks:check_estimator",
    "object": "sim.hand.checks:check_object",
    "scenario kind": "scenarios.runners.kind_checks:check_scenario_kind",
}


def registered_names() -> dict[str, tuple[str, ...]]:
    """What each checked family has registered now, in registration order.

    Returns
    -------
    dict
        ``family -> names`` for every family of :data:`CHECKERS`.
    """
    from controllers.registry import controller_names
    from estimation.registry import estimator_names
    from scenarios.runners.dispatch import scenario_kinds
    from sim.hand.objects import object_names

    return {"controller": controller_names(), "estimator": estimator_names(),
            "object": object_names(), "scenario kind": scenario_kinds()}


def added_names(before: Mapping[str, Sequence[str]],
                after: Mapping[str, Sequence[str]]) -> dict[str, tuple[str, ...]]:
    """The names of ``after`` that ``before`` lacks, family by family.

    Parameters
    ----------
    before, after : mapping
        ``family -> names`` (:func:`registered_names` at two moments).

    Returns
    -------
    dict
        ``family -> names added``, every family of ``after`` present.
    """
    return {family: tuple(n for n in names if n not in set(before.get(family, ())))
            for family, names in after.items()}


#: ``module -> family -> names`` each plugin module added when :func:`load_recorded`
#: loaded it.
_ADDED: dict[str, dict[str, tuple[str, ...]]] = {}


def load_recorded(modules: Iterable[str]) -> tuple[str, ...]:
    """:func:`scenarios.plugins.load_plugins`, recording what each module added.

    Parameters
    ----------
    modules : iterable of str
        Dotted module names, loaded in order.

    Returns
    -------
    tuple of str
        The modules, as loaded.

    Raises
    ------
    scenarios.plugins.PluginError
        As :func:`~scenarios.plugins.load_plugins`.
    """
    modules = list(modules)
    if not modules:  # no registry imported: ``griploop --help`` stays light
        return ()
    loaded = []
    for module in modules:
        before = registered_names()
        (name,) = load_plugins([module])
        added = added_names(before, registered_names())
        if any(added.values()) or name not in _ADDED:  # a module loaded before added nothing
            _ADDED[name] = added
        loaded.append(name)
    return tuple(loaded)


def plugin_registrations(modules: Iterable[str]) -> dict[str, tuple[str, ...]]:
    """What the plugin modules added to the checked families when they were loaded.

    Parameters
    ----------
    modules : iterable of str
        Modules loaded by :func:`load_recorded`.

    Returns
    -------
    dict
        ``family -> names`` (every family of :data:`CHECKERS`), in registration order,
        still registered; a module imported before :func:`load_recorded` loaded it added
        nothing this process saw.
    """
    now = registered_names()
    out: dict[str, list[str]] = {family: [] for family in now}
    for module in modules:
        for family, names in _ADDED.get(module.strip(), {}).items():
            out[family] += [n for n in names if n in now[family] and n not in out[family]]
    return {family: tuple(names) for family, names in out.items()}


def check_all(names: Mapping[str, Sequence[str]] | None = None,
              progress: Callable[[str, str], None] | None = None) -> list[CheckFailure]:
    """Run the checker of each family on each name.

    Parameters
    ----------
    names : mapping, optional
        ``family -> names`` to check (families of :data:`CHECKERS`); default
        :func:`registered_names`, everything registered.
    progress : callable, optional
        Called as ``progress(family, name)`` before each name is checked.

    Returns
    -------
    list of CheckFailure
        Every failed check, in the order checked; empty when all pass. A checker
        that itself raises is one failure, check ``checker``.

    Raises
    ------
    KeyError
        A family that has no checker.
    """
    names = registered_names() if names is None else names
    unknown = sorted(set(names) - set(CHECKERS))
    if unknown:
        raise KeyError(f"no checker for {unknown}; expected families among {list(CHECKERS)}")
    failures: list[CheckFailure] = []
    for family, reference in CHECKERS.items():
        if not names.get(family):
            continue
        checker = import_reference(reference)
        for name in names[family]:
            if progress is not None:
                progress(family, name)
            try:
                failures += checker(name)
            except Exception as exc:  # a plugin can break a checker's own steps
                failures.append(CheckFailure(family, name, "checker",
                                             "the checks to run to the end", raised(exc)))
    return failures
