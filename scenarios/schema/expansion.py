"""Sweep expansion: design points, seeds, and the scenarios a sweep runs.

A grid expands in row-major order as written; a random design draws every path
from its distribution with a seeded generator. A scenario whose ``seed`` is
unset gets one derived from the sweep seed and its own content (or its
``seed_by`` fields) by :func:`derive_seed`, so it depends neither on the order
of expansion nor on the number of workers.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import ValidationError

from scenarios.schema.models import Scenario, ScenarioError
from scenarios.schema.paths import with_value_at
from scenarios.schema.sweep_file import SweepConfig
from scenarios.schema.yaml_loading import describe_error, short_repr

DEFAULT_MAX_SCENARIOS = 100_000
"""Default cap on the scenarios a sweep expands to (``griploop sweep --max-scenarios``)."""


@dataclass(frozen=True)
class ExpandedScenario:
    """One scenario of an expanded sweep.

    Attributes
    ----------
    index : int
        Position in the expansion (0-based), for display only.
    scenario : Scenario
        The validated scenario, with its seed filled in.
    overrides : dict
        The dotted paths the design set for this scenario, and their values.
    """

    index: int
    scenario: Scenario
    overrides: dict[str, Any]


def derive_seed(sweep_seed: int, content: str, occurrence: int = 0) -> int:
    """Seed of one scenario from the sweep seed and its content.

    Parameters
    ----------
    sweep_seed : int
        The sweep's seed.
    content : str
        Canonical JSON of the scenario with its seed unset, or of its
        ``seed_by`` fields.
    occurrence : int
        How many identical scenarios precede this one (replicates).

    Returns
    -------
    int
        A 63-bit seed from ``numpy.random.SeedSequence(sweep_seed,
        spawn_key=(sha256(content) words..., occurrence))``.
    """
    digest = hashlib.sha256(content.encode()).digest()
    words = tuple(int.from_bytes(digest[i : i + 4], "little") for i in range(0, 32, 4))
    seq = np.random.SeedSequence(sweep_seed, spawn_key=(*words, occurrence))
    return int(seq.generate_state(1, np.uint64)[0] >> np.uint64(1))


def design_size(spec: SweepConfig) -> int:
    """Number of scenarios the sweep expands to, counted from its axes without expanding."""
    if spec.grid is not None:
        points = math.prod(len(values) for values in spec.grid.values())
    elif spec.random is not None:
        points = spec.random.n
    else:
        points = 1
    return points * spec.replicates


def check_size(
    spec: SweepConfig, max_scenarios: int | None = DEFAULT_MAX_SCENARIOS, source: str | None = None
) -> int:
    """:func:`design_size`, or ScenarioError when it exceeds ``max_scenarios`` (None: no cap)."""
    n = design_size(spec)
    if max_scenarios is not None and n > max_scenarios:
        if spec.grid is not None:
            how = " x ".join(str(len(v)) for v in spec.grid.values()) + " grid points"
        elif spec.random is not None:
            how = f"{spec.random.n} random points"
        else:
            how = "1 point"
        raise ScenarioError(
            f"{source or spec.name or '<sweep>'}: design: expected at most {max_scenarios} "
            f"scenarios, found {n} ({how} x {spec.replicates} replicates); "
            "raise the cap (--max-scenarios) to run it"
        )
    return n


def design_points(spec: SweepConfig) -> list[dict[str, Any]]:
    """The design's override dicts, one per point, before replication (see :func:`iter_design`)."""
    return list(iter_design(spec))


def iter_design(spec: SweepConfig) -> Iterator[dict[str, Any]]:
    """The design's override dicts one at a time, before replication.

    Grid points come in row-major order of the grid as written (the last path
    varies fastest); random points are drawn with
    ``numpy.random.default_rng(random.seed or sweep seed)``, one vectorized
    draw per path in sorted path order (columns of ``n`` values, the dicts
    built one at a time).
    """
    if spec.grid is not None:
        paths = list(spec.grid)
        for combo in itertools.product(*spec.grid.values()):
            yield dict(zip(paths, combo, strict=True))
        return
    if spec.random is not None:
        design = spec.random
        rng = np.random.default_rng(spec.seed if design.seed is None else design.seed)
        columns = {p: design.params[p].draw(rng, design.n) for p in sorted(design.params)}
        for i in range(design.n):
            yield {p: columns[p][i] for p in design.params}
        return
    yield {}


def _seed_key(scenario: Scenario, paths: Sequence[str]) -> str:
    """Canonical JSON of the fields named by ``paths`` (what seeds depend on)."""
    data = scenario.canonical_dict()
    picked = {}
    for path in sorted(set(paths)):
        node: Any = data
        for part in path.split("."):
            node = node.get(part) if isinstance(node, dict) else None  # unset option: None
        picked[path] = node
    return json.dumps(picked, sort_keys=True, separators=(",", ":"))


def expand_sweep(
    spec: SweepConfig,
    source: str | None = None,
    *,
    max_scenarios: int | None = DEFAULT_MAX_SCENARIOS,
) -> list[ExpandedScenario]:
    """Expand a sweep into validated scenarios with their seeds filled in.

    Parameters
    ----------
    spec : SweepConfig
        A validated sweep.
    source : str, optional
        Name used in error messages (defaults to the sweep name).
    max_scenarios : int or None
        Refuse a sweep of more scenarios, counted before expanding
        (:func:`check_size`); ``None``: no cap.

    Returns
    -------
    list of ExpandedScenario
        ``len(design_points(spec)) * spec.replicates`` scenarios. Seeds left
        unset are derived by :func:`derive_seed` from the sweep seed, the
        scenario content (or its ``seed_by`` fields) and its occurrence among
        identical scenarios.

    Raises
    ------
    ScenarioError
        Too many scenarios, or a design point makes an invalid scenario
        (cross-field checks).
    """
    return list(iter_expanded(spec, source, max_scenarios=max_scenarios))


def iter_expanded(
    spec: SweepConfig,
    source: str | None = None,
    *,
    max_scenarios: int | None = DEFAULT_MAX_SCENARIOS,
) -> Iterator[ExpandedScenario]:
    """:func:`expand_sweep` one scenario at a time (the size is checked first, eagerly)."""
    source = source or spec.name or "<sweep>"
    check_size(spec, max_scenarios, source)
    return _expand(spec, source)


def _expand(spec: SweepConfig, source: str) -> Iterator[ExpandedScenario]:
    base = spec.base.model_dump()
    seen: Counter[bytes] = Counter()
    index = 0
    for point in iter_design(spec):
        data = base
        for path, value in point.items():
            data = with_value_at(data, path, value)
        try:
            scenario = Scenario.model_validate(data, strict=True)
        except ValidationError as exc:
            reason = describe_error(exc, Scenario)[1]
            desc = ", ".join(f"{k}={short_repr(v, 30)}" for k, v in point.items())
            raise ScenarioError(f"{source}: design point ({desc}): {reason}") from None
        for _ in range(spec.replicates):
            if scenario.seed is None:
                content = scenario.canonical_json()
                key = content if spec.seed_by is None else _seed_key(scenario, spec.seed_by)
                digest = hashlib.sha256(content.encode()).digest()  # bounded memory per point
                seed = derive_seed(spec.seed, key, seen[digest])
                seen[digest] += 1
                final = scenario.model_copy(update={"seed": seed})
            else:
                final = scenario
            yield ExpandedScenario(index=index, scenario=final, overrides=dict(point))
            index += 1
