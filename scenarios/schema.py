"""Scenario and sweep schema: pydantic models, YAML loading and sweep expansion.

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
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import itertools
import json
import math
import re
import typing
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from sim.errors import GriploopError

ESTIMATORS = (
    "ss_kf",
    "ss",
    "mlp",
    "narx",
    "lda_qpf",
    "latent_kf",
    "persistence",
    "features_mav",
    "features_rms",
    "features_wl",
    "oracle",
    "ridge",
    "gbt",
    "ss_sim",
)
OBJECTS = ("ball", "can", "cup", "egg", "block")
SCENARIO_KINDS = ("reproduction", "calibration", "episode")
SIZE_LENGTHS = {"sphere": 1, "cylinder": 2, "box": 3}
_CALIBRATION_KINDS = ("reproduction", "calibration")
_MAX_SEED = 2**63 - 1
MAX_YAML_DEPTH = 32
"""Deepest nesting of mappings and lists a sweep file may have (aliases followed)."""
MAX_YAML_NODES = 100_000
"""Most YAML nodes a sweep file may hold, counting every alias as a copy of its target."""
DEFAULT_MAX_SCENARIOS = 100_000
"""Default cap on the scenarios a sweep expands to (``griploop sweep --max-scenarios``)."""
DEFAULT_TIME_LIMIT_S = 120.0
"""Default per-scenario time limit, s: 100x a typical episode (1 s), 10x a slow one."""


class ScenarioError(GriploopError, ValueError):
    """A scenario or sweep file is malformed, has unknown keys or bad values."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_default=True, allow_inf_nan=False)


class SubjectConfig(_Model):
    """The virtual subject wearing the armband.

    Attributes
    ----------
    population_seed : int
        Seed of the virtual population the subject is drawn from.
    subject_id : int
        Number of the subject within the population, from 1 (the paper has
        10; ``sim.user.subjects.make_population`` numbers them 1..n).
    generator : {"noise", "motor_units"}
        sEMG generator: amplitude-modulated noise (Hogan and Mann 1980) or a
        Fuglevand (1993) motor-unit pool.
    extra_noise_lsb : float
        Additional sEMG noise std in int8 counts, added in quadrature to the
        rest noise (about 1.9 LSB); ``sim.user.armband`` convention.
    electrode_shift : float
        Rotation of the armband in electrode spacings (positive towards higher
        channel numbers; 0 is the paper's placement); ``sim.user.armband`` convention.
    fatigue_per_min : float
        Fractional fall of the sEMG median frequency per minute (amplitude
        rises twice as fast); ``sim.user.emg_noise`` convention.
    """

    population_seed: int = Field(0, ge=0, le=_MAX_SEED)
    subject_id: int = Field(1, ge=1, le=9999)
    generator: Literal["noise", "motor_units"] = "noise"
    extra_noise_lsb: float = Field(0.0, ge=0.0, le=30.0)
    electrode_shift: float = Field(0.0, ge=-4.0, le=4.0)
    fatigue_per_min: float = Field(0.0, ge=0.0, le=0.5)


class ProtocolConfig(_Model):
    """What the subject does, and for how long.

    Attributes
    ----------
    name : {"paper_calibration", "grasp_lift_hold", "fragile_handling"}
        The paper's three-squeeze FSR session, a Johansson-Westling
        grasp-lift-hold, or handling a breakable object.
    calibration_s : float or None
        Duration of the calibration session used to fit the estimator, s;
        ``None`` keeps the paper protocol's own length (about 25-36 s).
    episode_s : float
        Duration of the closed-loop episode, s.
    hold_s : float
        Duration of the hold phase within the episode, s.
    identification_fraction : float
        Fraction of the calibration session used for identification; the rest
        validates (the paper uses 0.5).
    """

    name: Literal["paper_calibration", "grasp_lift_hold", "fragile_handling"] = "grasp_lift_hold"
    calibration_s: float | None = Field(None, ge=5.0, le=600.0)
    episode_s: float = Field(6.0, ge=0.5, le=120.0)
    hold_s: float = Field(2.0, ge=0.0, le=60.0)
    identification_fraction: float = Field(0.5, gt=0.05, lt=0.95)

    @model_validator(mode="after")
    def _hold_fits(self) -> ProtocolConfig:
        if self.hold_s >= self.episode_s:
            raise ValueError(
                f"hold_s must be shorter than episode_s={self.episode_s:g} s "
                f"(found hold_s={self.hold_s:g} s)"
            )
        return self


class ObjectConfig(_Model):
    """The object to grasp: a library object and optional overrides.

    Fields left at ``None`` keep the library object's value.

    Attributes
    ----------
    name : {"ball", "can", "cup", "egg", "block"}
        Library object.
    shape : {"sphere", "cylinder", "box"} or None
        Geometry override.
    mass_kg : float or None
        Mass, 0.02..2 kg.
    friction : float or None
        Sliding friction coefficient with the finger pads, 0.2..1.5.
    size_m : list of float or None
        Sphere ``[radius]``, cylinder ``[radius, half_height]`` or box
        ``[half_x, half_y, half_z]``, metres.
    stiffness_n_per_m : float or None
        Contact stiffness, N/m (the episode runner maps it to MuJoCo's
        ``solref``).
    break_force_n : float or None
        Grip force at which the object breaks (fragile objects), N.
    """

    name: Literal["ball", "can", "cup", "egg", "block"] = "ball"
    shape: Literal["sphere", "cylinder", "box"] | None = None
    mass_kg: float | None = Field(None, ge=0.02, le=2.0)
    friction: float | None = Field(None, ge=0.2, le=1.5)
    size_m: list[Annotated[float, Field(gt=0.0, le=0.2)]] | None = Field(
        None, min_length=1, max_length=3
    )
    stiffness_n_per_m: float | None = Field(None, gt=0.0, le=1e7)
    break_force_n: float | None = Field(None, gt=0.0, le=500.0)

    @model_validator(mode="after")
    def _size_matches_shape(self) -> ObjectConfig:
        if self.shape is not None and self.size_m is not None:
            expected = SIZE_LENGTHS[self.shape]
            if len(self.size_m) != expected:
                raise ValueError(
                    f"size_m of a {self.shape} needs {expected} value(s) "
                    f"(found {len(self.size_m)})"
                )
        return self


class EstimatorConfig(_Model):
    """The grip-force estimator and how it is evaluated.

    Attributes
    ----------
    name : str
        One of :data:`ESTIMATORS`.
    mode : {"one_step", "free_run"}
        ``one_step`` feeds measured force up to k-1 (the paper's evaluation);
        ``free_run`` uses sEMG only (what a prosthesis can do).
    order : int or None
        State-space order (also NARX delays and hidden units); ``None`` uses
        the paper's n = 4, which its AIC over n = 1..12 selected.
    """

    name: Literal[ESTIMATORS] = "ss_kf"  # type: ignore[valid-type]
    mode: Literal["one_step", "free_run"] = "free_run"
    order: int | None = Field(None, ge=1, le=12)


class SlipReflexConfig(_Model):
    """Slip reflex: raise the grip force when the object slips.

    Attributes
    ----------
    enabled : bool
        Whether the reflex is active.
    latency_s : float
        Delay from slip onset to the force increase, s (biological 0.02-0.3).
    gain : float
        Force increase per slip event as a fraction of the current reference.
    """

    enabled: bool = False
    latency_s: float = Field(0.05, ge=0.0, le=0.5)
    gain: float = Field(0.3, ge=0.0, le=5.0)


class ControllerConfig(_Model):
    """The grip-force controller, designed from a specification.

    Attributes
    ----------
    kind : {"pid", "lead_lag", "mpc"}
        Controller family.
    phase_margin_deg : float
        Required phase margin, degrees.
    crossover_rad_s : float or None
        Required gain-crossover frequency, rad/s (exclusive with bandwidth).
    bandwidth_rad_s : float or None
        Required closed-loop bandwidth, rad/s (exclusive with crossover).
    horizon : int or None
        MPC prediction horizon in control steps (``mpc`` only; default 20).
    safety_factor : float
        Grip force over the slip threshold the reference aims at.
    control_hz : float
        Control-loop rate, Hz: 100 to 500, so that the control period is a
        whole number of the hand's 2 ms physics steps.
    slip_reflex : SlipReflexConfig
        Slip reflex settings.
    scheduled : bool
        Gain-scheduled over grip force (default) or one fixed design at the
        design force (see :mod:`controllers.schedule`).
    """

    kind: Literal["pid", "lead_lag", "mpc"] = "pid"
    phase_margin_deg: float = Field(60.0, ge=10.0, le=90.0)
    crossover_rad_s: float | None = Field(None, gt=0.0, le=5000.0)
    bandwidth_rad_s: float | None = Field(None, gt=0.0, le=5000.0)
    horizon: int | None = Field(None, ge=2, le=500)
    safety_factor: float = Field(1.5, ge=1.0, le=5.0)
    control_hz: float = Field(100.0, ge=100.0, le=500.0)
    slip_reflex: SlipReflexConfig = Field(default_factory=SlipReflexConfig)
    scheduled: bool = True

    @model_validator(mode="after")
    def _consistent(self) -> ControllerConfig:
        if self.crossover_rad_s is not None and self.bandwidth_rad_s is not None:
            raise ValueError(
                "give crossover_rad_s or bandwidth_rad_s, not both "
                f"(found {self.crossover_rad_s:g} and {self.bandwidth_rad_s:g})"
            )
        if self.kind != "mpc" and self.horizon is not None:
            raise ValueError(
                f"horizon applies to controller kind mpc only (found kind {self.kind})"
            )
        if self.kind == "mpc" and self.horizon is None:
            self.horizon = 20
        return self


class Scenario(_Model):
    """One experiment: subject, protocol, object, estimator, controller, seed.

    Attributes
    ----------
    kind : {"reproduction", "calibration", "episode"}
        ``reproduction`` evaluates an estimator on the paper's protocol as the
        paper does; ``calibration`` fits it on a calibration session;
        ``episode`` also runs a closed-loop grasp with the controller.
    seed : int or None
        Seed of every random draw of the scenario; ``None`` in a sweep file
        means "derive it from the sweep seed and the content".
    """

    kind: Literal["reproduction", "calibration", "episode"] = "episode"
    subject: SubjectConfig = Field(default_factory=SubjectConfig)
    protocol: ProtocolConfig = Field(default_factory=ProtocolConfig)
    object: ObjectConfig = Field(default_factory=ObjectConfig)
    estimator: EstimatorConfig = Field(default_factory=EstimatorConfig)
    controller: ControllerConfig = Field(default_factory=ControllerConfig)
    seed: int | None = Field(None, ge=0, le=_MAX_SEED)

    @model_validator(mode="after")
    def _protocol_fits_kind(self) -> Scenario:
        calibration_only = self.protocol.name == "paper_calibration"
        if self.kind in _CALIBRATION_KINDS and not calibration_only:
            raise ValueError(
                f"kind {self.kind} needs protocol.name paper_calibration "
                f"(found {self.protocol.name})"
            )
        if self.kind == "episode" and calibration_only:
            raise ValueError(
                "kind episode needs protocol.name grasp_lift_hold or fragile_handling "
                "(found paper_calibration)"
            )
        return self

    def canonical_json(self) -> str:
        """The scenario as canonical JSON: every field, sorted keys, no spaces."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))


class Uniform(_Model):
    """Uniform on ``[low, high)``."""

    dist: Literal["uniform"]
    low: float
    high: float

    @model_validator(mode="after")
    def _ordered(self) -> Uniform:
        _check_order(self.low, self.high)
        if not np.isfinite(self.high - self.low):
            raise ValueError(
                f"high - low must be a finite span (found low={self.low:g}, high={self.high:g})"
            )
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.uniform(self.low, self.high, n).tolist()


class LogUniform(_Model):
    """Log-uniform on ``[low, high)``, ``0 < low < high``."""

    dist: Literal["loguniform"]
    low: float = Field(gt=0.0)
    high: float = Field(gt=0.0)

    @model_validator(mode="after")
    def _ordered(self) -> LogUniform:
        _check_order(self.low, self.high)
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return np.exp(rng.uniform(np.log(self.low), np.log(self.high), n)).tolist()


class Normal(_Model):
    """Gaussian with mean ``mean`` and standard deviation ``sd``."""

    dist: Literal["normal"]
    mean: float = Field(ge=-1e300, le=1e300)
    sd: float = Field(gt=0.0, le=1e300)

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.normal(self.mean, self.sd, n).tolist()


class Integers(_Model):
    """Integers uniform on ``low..high`` inclusive."""

    dist: Literal["integers"]
    low: int = Field(ge=-(2**62), le=2**62)
    high: int = Field(ge=-(2**62), le=2**62)

    @model_validator(mode="after")
    def _ordered(self) -> Integers:
        if self.high < self.low:
            raise ValueError(f"high must be >= low (found low={self.low}, high={self.high})")
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.integers(self.low, self.high, n, endpoint=True).tolist()


class Choice(_Model):
    """One of ``values`` with equal probability."""

    dist: Literal["choice"]
    values: list[Any] = Field(min_length=1)

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return [self.values[int(i)] for i in rng.integers(0, len(self.values), n)]


Distribution = Annotated[
    Uniform | LogUniform | Normal | Integers | Choice, Field(discriminator="dist")
]


class RandomDesign(_Model):
    """A seeded random design: ``n`` scenarios with fields drawn independently.

    Attributes
    ----------
    n : int
        Number of scenarios.
    seed : int or None
        Seed of the draws; defaults to the sweep seed.
    params : dict of str to Distribution
        Dotted field path to its distribution.
    """

    n: int = Field(ge=1, le=1_000_000)
    seed: int | None = Field(None, ge=0, le=_MAX_SEED)
    params: dict[str, Distribution] = Field(min_length=1)


class SweepConfig(_Model):
    """A sweep file: a base scenario expanded over a grid or a random design.

    Attributes
    ----------
    name : str or None
        Name of the sweep in the results store; defaults to the file stem.
    description : str
        Free text.
    seed : int
        Sweep seed: per-scenario seeds and random designs derive from it.
    replicates : int
        Copies of each design point; copies differ only by their derived seed.
    time_limit_s : float
        Wall-time limit of one scenario, s: a scenario still running after it
        is stopped and recorded as failed with a ``timeout`` error. Not part
        of the scenario's content hash.
    seed_by : list of str or None
        Dotted field paths (or sections, e.g. ``subject``) the derived seeds
        depend on. ``None``: the whole scenario, so every scenario draws
        independently. Listing e.g. ``[subject]`` gives every estimator,
        controller or object of one subject the same seed: common random
        numbers, for paired comparisons as in the paper.
    base : Scenario
        Values of every field the design does not set.
    grid : dict of str to list
        Dotted field path to the values it takes (cartesian product).
    random : RandomDesign or None
        Seeded random design.
    """

    name: str | None = Field(None, min_length=1, max_length=200, pattern=r"^[\w.\-]+$")
    description: str = ""
    seed: int = Field(0, ge=0, le=_MAX_SEED)
    replicates: int = Field(1, ge=1, le=10_000)
    time_limit_s: float = Field(DEFAULT_TIME_LIMIT_S, gt=0.0, le=86_400.0)
    seed_by: list[str] | None = Field(None, min_length=1)
    base: Scenario = Field(default_factory=Scenario)
    grid: dict[str, list[Any]] | None = None
    random: RandomDesign | None = None

    @model_validator(mode="after")
    def _one_design(self) -> SweepConfig:
        if self.grid is not None and self.random is not None:
            raise ValueError("give grid or random, not both (found both)")
        if self.grid is not None:
            for path, values in self.grid.items():
                if not values:
                    raise ValueError(f"grid path {path} needs at least one value (found [])")
        return self


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


# ---------------------------------------------------------------- YAML loading


def _check_order(low: float, high: float) -> None:
    if not high > low:
        raise ValueError(f"high must be > low (found low={low:g}, high={high:g})")


class _Loader(yaml.SafeLoader):
    """SafeLoader that also reads ``1e5`` and ``1e-3`` as floats (YAML 1.2, as users write)."""


_Loader.yaml_implicit_resolvers = {
    first: [r for r in resolvers if r[0] != "tag:yaml.org,2002:float"]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
        |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
        |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
        |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
        re.X,
    ),
    list("-+0123456789."),
)


def _yaml_with_lines(text: str, source: str) -> tuple[Any, dict[tuple, int]]:
    """Parse YAML and map every key path to its 1-based line number.

    Bounded in time and memory whatever the text: nesting and node count are
    checked on the parser's event stream (iteratively, before any node tree is
    built), then on the composed node graph with every alias counted as a copy
    of its target but without expanding it; self-referencing aliases are
    refused. The line map is built over each node once (aliases are not
    walked again).
    """
    try:
        _check_events(text, source)
        loader = _Loader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                raise ScenarioError(f"{source}: empty file (expected a YAML mapping with 'base')")
            _check_graph(node, source)
            data = loader.construct_document(node)
            lines: dict[tuple, int] = {(): node.start_mark.line + 1}
            _walk_marks(node, (), lines, loader, source, set())
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark else source
        problem = " ".join(str(exc.problem or exc.context or "invalid YAML").split())
        raise ScenarioError(f"{where}: malformed YAML: {problem}") from None
    except yaml.YAMLError as exc:
        problem = " ".join(str(exc).split())
        raise ScenarioError(f"{source}: malformed YAML: {problem}") from None
    except (RecursionError, OverflowError, ValueError, TypeError) as exc:
        if isinstance(exc, ScenarioError):
            raise
        problem = " ".join(str(exc).split())[:120] or type(exc).__name__
        raise ScenarioError(f"{source}: malformed YAML: {problem}") from None
    return data, lines


def _check_events(text: str, source: str) -> None:
    """Refuse nesting deeper than MAX_YAML_DEPTH or more than MAX_YAML_NODES events."""
    depth = count = 0
    for event in yaml.parse(text, Loader=_Loader):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_YAML_DEPTH:
                raise ScenarioError(
                    f"{source}:{event.start_mark.line + 1}: <top>: expected nesting of at most "
                    f"{MAX_YAML_DEPTH} levels, found deeper"
                )
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
        if isinstance(event, yaml.NodeEvent):
            count += 1
            if count > MAX_YAML_NODES:
                raise ScenarioError(
                    f"{source}:{event.start_mark.line + 1}: <top>: expected at most "
                    f"{MAX_YAML_NODES} YAML nodes, found more"
                )


def _check_graph(root: yaml.Node, source: str) -> None:
    """Count nodes and depth with aliases expanded, without expanding them.

    Each node's expanded size and depth are computed once (post-order,
    iteratively, memoized by identity); a node reached again while its own
    children are being counted is a self-referencing alias.
    """
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        children = _children(node)
        if done:
            on_path.discard(key)
            size[key] = 1 + sum(size[id(c)] for c in children)
            depth[key] = 1 + max((depth[id(c)] for c in children), default=0)
            line = node.start_mark.line + 1
            if size[key] > MAX_YAML_NODES:
                raise ScenarioError(
                    f"{source}:{line}: <top>: expected at most {MAX_YAML_NODES} YAML nodes "
                    f"with aliases expanded, found {size[key]} (an alias bomb?)"
                )
            if depth[key] > MAX_YAML_DEPTH + 1:
                raise ScenarioError(
                    f"{source}:{line}: <top>: expected nesting of at most {MAX_YAML_DEPTH} "
                    f"levels with aliases expanded, found {depth[key] - 1}"
                )
            continue
        if key in size:
            continue
        on_path.add(key)
        stack.append((node, True))
        for child in children:
            if id(child) in on_path:
                raise ScenarioError(
                    f"{source}:{child.start_mark.line + 1}: <top>: expected a tree, found an "
                    "alias that contains itself"
                )
            if id(child) not in size:
                stack.append((child, False))


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def _walk_marks(
    node: yaml.Node, path: tuple, lines: dict, loader: Any, source: str, seen_nodes: set
) -> None:
    if id(node) in seen_nodes:  # an alias: its lines are those of its anchor
        return
    seen_nodes.add(id(node))
    if isinstance(node, yaml.MappingNode):
        seen: set = set()
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                continue
            key = loader.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if not isinstance(key, (str, int, float, bool)):
                continue
            if key in seen:
                raise ScenarioError(
                    f"{source}:{line}: {_dotted(path) or '<top>'}: duplicate key {key!r} "
                    "(expected each key once)"
                )
            seen.add(key)
            lines[path + (key,)] = line
            _walk_marks(value_node, path + (key,), lines, loader, source, seen_nodes)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            lines[path + (i,)] = item.start_mark.line + 1
            _walk_marks(item, path + (i,), lines, loader, source, seen_nodes)


def _dotted(loc: Sequence[Any]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _line_of(loc: tuple, lines: Mapping[tuple, int]) -> int | None:
    for cut in range(len(loc), -1, -1):
        if loc[:cut] in lines:
            return lines[loc[:cut]]
    return None


def _format_error(
    exc: ValidationError,
    source: str,
    lines: Mapping[tuple, int] | None = None,
    root: type[BaseModel] | None = None,
) -> str:
    """One line: ``SOURCE:LINE: field.path: reason (found VALUE)`` for the first error."""
    loc, text = _describe(exc, root)
    line = _line_of(loc, lines) if lines else None
    where = f"{source}:{line}" if line is not None else source
    return f"{where}: {text}"


def _describe(exc: ValidationError, root: type[BaseModel] | None) -> tuple[tuple, str]:
    """Location and ``field.path: reason (found VALUE)`` of the first error."""
    err = exc.errors(include_url=False)[0]
    loc = tuple(p for p in err["loc"] if p not in _DIST_TAGS)
    field = _dotted(loc) or "<top>"
    if err["type"] == "extra_forbidden":
        reason = f"unknown key {loc[-1]!r}" if loc else "unknown key"
        parent = _model_at(root or SweepConfig, loc[:-1])
        if parent is not None:
            reason += f" (expected one of: {', '.join(parent.model_fields)})"
        field = _dotted(loc[:-1]) or "<top>"
    else:
        reason = err["msg"].removeprefix("Value error, ")
        if reason.startswith("Input should be "):
            reason = "expected " + reason.removeprefix("Input should be ")
        if err["type"] != "value_error" and not isinstance(err.get("input"), dict):
            found = err.get("input")
            kind = f"{type(found).__name__} " if isinstance(found, (bool, str)) else ""
            reason += f" (found {kind}{_short(found)})"
    more = len(exc.errors()) - 1
    tail = f" [+{more} more error{'s' if more > 1 else ''}]" if more else ""
    return loc, f"{field}: {reason}{tail}"


# pydantic puts the discriminator value of a union member into error locations
_DIST_TAGS = frozenset({"uniform", "loguniform", "normal", "integers", "choice"})


def _model_at(root: type[BaseModel], loc: Sequence[Any]) -> type[BaseModel] | None:
    """The pydantic model reached from ``root`` along field names ``loc``, if any."""
    model = root
    for part in loc:
        field = model.model_fields.get(part) if isinstance(part, str) else None
        if field is None:
            return None
        candidates = (field.annotation, *typing.get_args(field.annotation))
        subs = [c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)]
        if not subs:
            return None
        model = subs[0]
    return model


def field_paths(model: type[BaseModel] = Scenario, prefix: str = "") -> list[str]:
    """Every dotted leaf field path of ``model`` (what a grid or random design may set)."""
    out: list[str] = []
    for name, field in model.model_fields.items():
        sub = field.annotation
        if isinstance(sub, type) and issubclass(sub, BaseModel):
            out.extend(field_paths(sub, f"{prefix}{name}."))
        else:
            out.append(prefix + name)
    return out


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and validate a sweep file.

    Parameters
    ----------
    path : str or Path
        YAML sweep file.

    Returns
    -------
    SweepConfig
        Validated sweep; ``name`` defaults to the file stem. Design paths and
        values are checked too (see :func:`expand_sweep`).

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    ScenarioError
        Malformed YAML, unknown key, out-of-range value, or a design that sets
        an unknown field or produces an invalid scenario.
    """
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise FileNotFoundError(f"{source}: no such scenario file (expected a YAML sweep file)")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{source}: not UTF-8 text ({exc.reason})") from None
    data, lines = _yaml_with_lines(text, source)
    if not isinstance(data, dict):
        raise ScenarioError(
            f"{source}:1: <top>: expected a mapping with 'base' (found {type(data).__name__})"
        )
    spec = _validate(SweepConfig, data, source, lines)
    if spec.name is None:
        spec = spec.model_copy(update={"name": path.stem})
    _check_design(spec, source, lines)
    return spec


def parse_scenario(data: Mapping[str, Any], source: str = "<scenario>") -> Scenario:
    """Validate one scenario given as a mapping (e.g. built from command-line options).

    Raises
    ------
    ScenarioError
        One line: ``SOURCE: field.path: reason (found VALUE)``.
    """
    return _validate(Scenario, data, source, {}, strict=False)


def parse_sweep(data: Mapping[str, Any], source: str = "<sweep>") -> SweepConfig:
    """Validate a sweep given as a mapping (as :func:`load_sweep`, without line numbers)."""
    spec = _validate(SweepConfig, dict(data), source, {})
    _check_design(spec, source, {})
    return spec


def _validate(
    model: type[BaseModel], data: Any, source: str, lines: Mapping, *, strict: bool = True
) -> Any:
    """Validate ``data``; strict: no coercion of booleans or strings into numbers."""
    try:
        return model.model_validate(data, strict=strict)
    except ValidationError as exc:
        raise ScenarioError(_format_error(exc, source, lines, model)) from None


def _check_design(spec: SweepConfig, source: str, lines: Mapping[tuple, int]) -> None:
    """Check every design path exists and every grid value is valid on the base."""
    known = set(field_paths())
    design: Mapping[str, Any] = {}
    where_in_file: tuple = ()
    if spec.grid is not None:
        design, where_in_file = spec.grid, ("grid",)
    elif spec.random is not None:
        design, where_in_file = spec.random.params, ("random", "params")
    for path in design:
        loc = (*where_in_file, path)
        if path not in known:
            line = _line_of(loc, lines)
            where = f"{source}:{line}" if line else source
            near = difflib.get_close_matches(path, sorted(known), n=1)
            hint = f" (did you mean {near[0]}?)" if near else " (expected a dotted scenario field)"
            raise ScenarioError(f"{where}: {_dotted(loc[:-1])}: unknown field path {path!r}{hint}")
        if path == "seed" and spec.replicates > 1:
            raise ScenarioError(f"{source}: replicates: a design over seed needs replicates 1")
    for i, path in enumerate(spec.seed_by or ()):
        if path == "seed" or not any(k == path or k.startswith(path + ".") for k in known):
            line = _line_of(("seed_by", i), lines)
            where = f"{source}:{line}" if line else source
            raise ScenarioError(
                f"{where}: seed_by[{i}]: unknown field path {path!r} "
                "(expected a scenario field or section other than seed)"
            )
    if spec.base.seed is not None and spec.replicates > 1 and "seed" not in design:
        raise ScenarioError(
            f"{source}: base.seed: replicates {spec.replicates} need base.seed unset "
            f"(found {spec.base.seed}); replicate seeds are derived from the sweep seed"
        )
    if spec.grid is None:
        return
    # Values are checked one at a time on the base for errors of the field itself
    # (type, range); cross-field checks depend on the other paths and are left to
    # expand_sweep, which validates every combination.
    base = spec.base.model_dump()
    for path, values in spec.grid.items():
        field_loc = tuple(path.split("."))
        for i, value in enumerate(values):
            try:
                Scenario.model_validate(_set_path(base, path, value), strict=True)
            except ValidationError as exc:
                if not any(tuple(e["loc"])[: len(field_loc)] == field_loc for e in exc.errors()):
                    continue
                reason = _describe(exc, Scenario)[1]
                line = _line_of(("grid", path, i), lines)
                where = f"{source}:{line}" if line else source
                raise ScenarioError(f"{where}: grid.{path}[{i}]: {reason}") from None


def _set_path(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    out = copy.deepcopy(data)
    node = out
    parts = path.split(".")
    for part in parts[:-1]:
        node = node[part]
    node[parts[-1]] = value
    return out


# ---------------------------------------------------------------- expansion


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
    data = scenario.model_dump(mode="json")
    picked = {}
    for path in sorted(set(paths)):
        node: Any = data
        for part in path.split("."):
            node = node[part]
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
            data = _set_path(data, path, value)
        try:
            scenario = Scenario.model_validate(data, strict=True)
        except ValidationError as exc:
            reason = _describe(exc, Scenario)[1]
            desc = ", ".join(f"{k}={_short(v, 30)}" for k, v in point.items())
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
