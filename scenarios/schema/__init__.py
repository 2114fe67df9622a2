"""Scenario and sweep schema: pydantic models, YAML loading and sweep expansion.

:mod:`~scenarios.schema.models` holds the scenario's models,
:mod:`~scenarios.schema.sweep_file` the sweep file's, :mod:`~scenarios.schema.yaml_loading`
reads and validates files and mappings, :mod:`~scenarios.schema.expansion` expands a
sweep into scenarios; every public name is re-exported here.

A *scenario* names everything one experiment needs: the virtual subject, the
protocol and its durations, the object in the hand, the force estimator and
its mode, the force controller and its specification, and a seed. A *sweep
file* holds a ``base`` scenario and at most one design over dotted field
paths::

    name: grasp_mass_friction
    seed: 7
    base:
      kind: episode
      object: {name: cup}
    grid:                      # cartesian product, in the order written
      object.mass_kg: [0.1, 0.3]
      controller.kind: [pid, mpc]

or ``random: {n: 50, seed: 3, params: {object.friction: {dist: uniform,
low: 0.2, high: 1.2}}}`` for a seeded random design.

Every model forbids unknown keys and checks ranges. Errors from a file are
raised as :class:`ScenarioError` with one line of the form
``FILE:LINE: FIELD.PATH: reason (found VALUE)``.

Seeds: a scenario whose ``seed`` is not given gets one derived from the
sweep seed and the scenario's own content -- or only the fields listed in
``seed_by``, for paired comparisons (:func:`derive_seed`) -- so it depends
neither on the order of expansion nor on the number of workers.

Names of estimators, objects, sEMG generators, controllers and scenario kinds
come from their registries (see :mod:`scenarios.schema.models`), checked when a
scenario is validated.
"""

from typing import Any

from scenarios.schema.expansion import (
    DEFAULT_MAX_SCENARIOS,
    ExpandedScenario,
    check_size,
    derive_seed,
    design_points,
    design_size,
    expand_sweep,
    iter_design,
    iter_expanded,
)
from scenarios.schema.models import (
    DEFAULT_TIME_LIMIT_S,
    INTACT,
    NO_ESTIMATOR,
    ORACLE,
    SIZE_LENGTHS,
    ControllerConfig,
    EstimatorConfig,
    HandConfig,
    ObjectConfig,
    OperatorParamsConfig,
    ProtocolConfig,
    Scenario,
    ScenarioError,
    SlipReflexConfig,
    SubjectConfig,
    UserConfig,
    controller_names,
    estimator_choices,
    feedback_modes,
    generator_names,
    kind_protocols,
    object_names,
    scenario_kinds,
    user_kinds,
)
from scenarios.schema.paths import field_paths
from scenarios.schema.sweep_file import (
    Choice,
    Distribution,
    Integers,
    LogUniform,
    Normal,
    RandomDesign,
    SweepConfig,
    Uniform,
)
from scenarios.schema.yaml_loading import (
    MAX_YAML_DEPTH,
    MAX_YAML_NODES,
    load_sweep,
    parse_scenario,
    parse_sweep,
)

__all__ = [
    "DEFAULT_MAX_SCENARIOS", "DEFAULT_TIME_LIMIT_S", "MAX_YAML_DEPTH", "MAX_YAML_NODES",
    "INTACT", "NO_ESTIMATOR", "ORACLE", "SIZE_LENGTHS", "Choice", "ControllerConfig",
    "Distribution", "EstimatorConfig",
    "ExpandedScenario", "Integers", "LogUniform", "Normal", "ObjectConfig",
    "OperatorParamsConfig", "ProtocolConfig", "RandomDesign", "Scenario", "ScenarioError",
    "HandConfig", "SlipReflexConfig", "SubjectConfig", "SweepConfig", "Uniform", "UserConfig",
    "check_size",
    "controller_names", "derive_seed", "design_points", "design_size", "estimator_choices",
    "expand_sweep", "feedback_modes", "field_paths", "generator_names", "iter_design",
    "iter_expanded", "kind_protocols", "load_sweep", "object_names", "parse_scenario",
    "parse_sweep", "scenario_kinds", "user_kinds",
]


def __getattr__(attr: str) -> Any:
    """``ESTIMATORS``, ``OBJECTS``, ``GENERATORS``, ``CONTROLLERS``, ``SCENARIO_KINDS``,
    ``USER_KINDS``, ``FEEDBACK_MODES``:
    the names registered at the time of reading."""
    from scenarios.schema import models

    return getattr(models, attr)
