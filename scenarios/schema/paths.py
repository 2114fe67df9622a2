"""Dotted field paths of a scenario: what a grid or a random design may set, and setting one."""

from __future__ import annotations

import copy
from typing import Any

from pydantic import BaseModel

from scenarios.schema.models import ControllerConfig, Scenario
from scenarios.schema.names import controller_names, controller_own_options


def field_paths(model: type[BaseModel] = Scenario, prefix: str = "") -> list[str]:
    """Every dotted leaf field path of ``model`` (what a grid or random design may set)."""
    out: list[str] = []
    for name, field in model.model_fields.items():
        sub = field.annotation
        if isinstance(sub, type) and issubclass(sub, BaseModel):
            out.extend(field_paths(sub, f"{prefix}{name}."))
        elif model is ControllerConfig and name == "options":
            out.extend(f"{prefix}options.{k}" for k in sorted(
                {k for kind in controller_names() for k in controller_own_options(kind)}))
        else:
            out.append(prefix + name)
    return out


def with_value_at(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    """A deep copy of ``data`` with ``value`` at the dotted ``path`` (``"object.mass_kg"``)."""
    out = copy.deepcopy(data)
    node = out
    parts = path.split(".")
    for part in parts[:-1]:
        node = node[part]
    node[parts[-1]] = value
    return out
