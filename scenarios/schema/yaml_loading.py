"""Reading sweep files: YAML with line numbers, size guards, and one-line errors.

:func:`load_sweep` reads a file, :func:`parse_sweep` and :func:`parse_scenario`
validate mappings. The YAML loader reads ``1e5`` as a float (YAML 1.2), refuses
nesting deeper than :data:`MAX_YAML_DEPTH` and more than :data:`MAX_YAML_NODES`
nodes (aliases counted as copies, never expanded), and records the line of every
key so that a validation error becomes one line of the form
``FILE:LINE: FIELD.PATH: reason (found VALUE)`` (:class:`~scenarios.schema.models.ScenarioError`).
"""

from __future__ import annotations

import difflib
import re
import typing
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from scenarios.schema.models import Scenario, ScenarioError
from scenarios.schema.paths import field_paths, with_value_at
from scenarios.schema.sweep_file import SweepConfig

MAX_YAML_DEPTH = 32
"""Deepest nesting of mappings and lists a sweep file may have (aliases followed)."""
MAX_YAML_NODES = 100_000
"""Most YAML nodes a sweep file may hold, counting every alias as a copy of its target."""


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


def short_repr(value: Any, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters with ``...``."""
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
    loc, text = describe_error(exc, root)
    line = _line_of(loc, lines) if lines else None
    where = f"{source}:{line}" if line is not None else source
    return f"{where}: {text}"


def describe_error(exc: ValidationError, root: type[BaseModel] | None) -> tuple[tuple, str]:
    """Location and ``field.path: reason (found VALUE)`` of the first error."""
    err = exc.errors(include_url=False)[0]
    loc = tuple(p for p in err["loc"] if p not in _DIST_TAGS)
    key = getattr(err.get("ctx", {}).get("error"), "key", None)
    if key is not None:  # an option error names its key: point at that key's line
        loc = (*loc, key)
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
            reason += f" (found {kind}{short_repr(found)})"
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
        values are checked too (see :func:`~scenarios.schema.expansion.expand_sweep`).

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
    _load_plugins_of(data, source, lines)
    spec = _validate(SweepConfig, data, source, lines)
    if spec.name is None:
        spec = spec.model_copy(update={"name": path.stem})
    _check_design(spec, source, lines)
    return spec


def _load_plugins_of(data: Mapping[str, Any], source: str, lines: Mapping[tuple, int]) -> None:
    """Import the sweep's ``plugins`` before validation: they register the names it uses."""
    from scenarios.plugins import PluginError, load_plugins

    plugins = data.get("plugins", [])
    if not isinstance(plugins, list) or not all(isinstance(p, str) for p in plugins):
        return  # the schema reports the malformed field
    for i, module in enumerate(plugins):
        try:
            load_plugins([module])
        except PluginError as exc:
            line = _line_of(("plugins", i), lines)
            where = f"{source}:{line}" if line else source
            raise ScenarioError(f"{where}: plugins[{i}]: {exc}") from None


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
        if path not in known and not path.startswith("estimator.options."):  # values checked below
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
                Scenario.model_validate(with_value_at(base, path, value), strict=True)
            except ValidationError as exc:
                if not any(tuple(e["loc"])[: len(field_loc)] == field_loc for e in exc.errors()):
                    continue
                reason = describe_error(exc, Scenario)[1]
                line = _line_of(("grid", path, i), lines)
                where = f"{source}:{line}" if line else source
                raise ScenarioError(f"{where}: grid.{path}[{i}]: {reason}") from None
