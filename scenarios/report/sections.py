"""Report sections by name: :func:`~scenarios.report.sections.register_section` and the data
every section reads.

A section is a function ``section(context) -> Section`` of a
:class:`ReportContext` (the rows of the results store, split by kind, with
their traces, swept factors and loop designs) returning one
:class:`~scenarios.report.html.Section` (a section without data returns one
with ``omitted=True`` and a one-line note). The report shows the registered
sections in ascending ``order``; the built-in ones (:mod:`scenarios.report.build`)
use 5 (what the sweep found, first), 10, 20, ..., 100, provenance last. A new
section is a module with such a function plus one call::

    register_section("energy", "mypackage.energy:energy_section", order=95)
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scenarios.report.html import Section
from sim.errors import GriploopError
from sim.registry import Registry


class UnknownSectionError(GriploopError, LookupError):
    """A report section name that is not registered."""


@dataclass(frozen=True)
class ReportContext:
    """What the report's sections are built from.

    Attributes
    ----------
    results : Path
        The results store.
    sweep : str or None
        The sweep the report is restricted to (``None``: every sweep).
    rows : list of dict
        Every row of the store (or of ``sweep``).
    split : scenarios.report.data.StoreRows
        The rows split by kind: ``reproduction``, ``episodes``, ``failed``, ``other``.
    traces : dict
        Episode hash to its traces (name to ndarray, shape (n_samples,)).
    members : dict
        Sweep name to its rows.
    sources : list of (str, ScoreTable)
        Reproduction scores by source (store rows, reproduction JSON).
    factors : list of str
        Dotted scenario paths that vary across the episodes.
    designs : list of LoopDesign
        Distinct controller designs of the episodes.
    reproduction : Path or None
        The reproduction JSON, if given.
    json_config : dict
        Its ``config`` entry.
    created : datetime
        Creation time of the report (UTC).
    options : dict
        Build options: ``render_frame``, ``max_designs``, ``max_traces``,
        ``recheck_margins``, and ``frame`` (the grasp frame being rendered, or None).
    reproduction_data : dict or None
        The reproduction JSON as read (once), if given.
    """

    results: Path
    sweep: str | None
    rows: Sequence[dict[str, Any]]
    split: Any
    traces: Mapping[str, Mapping[str, np.ndarray]]
    members: Mapping[str, Sequence[dict[str, Any]]]
    sources: Sequence[tuple[str, Any]]
    factors: Sequence[str]
    designs: Sequence[Any]
    reproduction: Path | None
    json_config: Mapping[str, Any]
    created: _dt.datetime
    options: Mapping[str, Any] = field(default_factory=dict)
    reproduction_data: Mapping[str, Any] | None = None


SectionBuilder = Callable[[ReportContext], Section]

_REGISTRY = Registry("report section", UnknownSectionError)


def register_section(name: str, builder: SectionBuilder | str, *, order: float | None = None,
                     replace: bool = False) -> None:
    """Register a report section.

    Parameters
    ----------
    name : str
        Section name (unique).
    builder : callable or str
        ``builder(context: ReportContext) -> Section``, or its
        ``"package.module:function"`` reference, imported when the report is built.
    order : float, optional
        Position on the page (ascending); default: after every registered section.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, or ``name`` already registered.
    """
    if order is None:
        order = max((float(_REGISTRY.info(n)["order"]) for n in _REGISTRY), default=0.0) + 10.0
    _REGISTRY.register(name, builder, replace=replace, order=float(order))


unregister_section = _REGISTRY.functions(__name__, "section").unregister


def section_names() -> tuple[str, ...]:
    """Registered sections in page order."""
    return tuple(sorted(_REGISTRY, key=lambda n: float(_REGISTRY.info(n)["order"])))


def build_sections(context: ReportContext) -> list[Section]:
    """Every registered section built from ``context``, in page order."""
    return [_REGISTRY.get(name)(context) for name in section_names()]
