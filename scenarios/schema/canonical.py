"""Fields added to the scenario schema after seeds were first derived from its canonical JSON.

A scenario's seed and content hash come from its canonical JSON
(:meth:`scenarios.schema.models.Scenario.canonical_dict`). A field added later is made
with :func:`added_field`: left at its default it stays out of that JSON
(:func:`omit_added_defaults`), so adding it moves no existing scenario's seed or figure.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field
from pydantic_core import PydanticUndefined


def added_field(default: Any = PydanticUndefined, **kwargs: Any) -> Any:
    """A field added after scenario seeds were first derived from the canonical JSON.

    Left at its default it stays out of
    :meth:`scenarios.schema.models.Scenario.canonical_dict`, so adding it
    moves no existing scenario's content hash, seed or figure; set to anything else it
    is part of the scenario as any field is. Every field added to the schema is made
    with this (``tests/scenarios/test_seeds.py`` holds the canonical form of a default
    scenario).
    """
    extra = {**kwargs.pop("json_schema_extra", {}), "canonical": "omit_default"}
    return Field(default, json_schema_extra=extra, **kwargs)


def omit_added_defaults(model: BaseModel, data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (``model`` dumped as JSON) without the :func:`added_field` fields at their
    defaults, in ``model`` and every section below it."""
    for name, field in type(model).model_fields.items():
        value = getattr(model, name)
        extra = field.json_schema_extra
        if (isinstance(extra, dict) and extra.get("canonical") == "omit_default"
                and value == field.get_default(call_default_factory=True)):
            data.pop(name, None)
        elif isinstance(value, BaseModel) and isinstance(data.get(name), dict):
            omit_added_defaults(value, data[name])
    return data
