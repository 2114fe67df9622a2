"""Registries with typed capabilities: declared fields only, read as records and as mappings."""

from __future__ import annotations

from dataclasses import FrozenInstanceError, dataclass

import pytest

from controllers.registry import ControllerKind, controller_info
from estimation.registry import EstimatorKind, estimator_info
from scenarios.runners.dispatch import ScenarioKind, kind_info
from sim.registry import Capabilities, RegistrationError, Registry


@dataclass(frozen=True)
class Tool(Capabilities):
    """A toy family's capabilities."""

    sharp: bool
    sizes: tuple[int, ...] = ()


def test_a_registration_is_a_typed_record_that_reads_as_a_mapping():
    tools = Registry("tool", capabilities=Tool)
    tools.register("knife", object(), sharp=True, sizes=(1, 2))
    info = tools.info("knife")
    assert isinstance(info, Tool) and info.sharp and info["sizes"] == (1, 2)
    assert dict(info) == {"sharp": True, "sizes": (1, 2)} and len(info) == 2
    assert info.get("colour") is None and "sharp" in info
    assert tools.where(sharp=True) == ("knife",)
    with pytest.raises(FrozenInstanceError):
        info.sharp = False  # type: ignore[misc]


def test_a_capability_the_family_does_not_declare_is_refused_in_one_line():
    tools = Registry("tool", capabilities=Tool)
    with pytest.raises(RegistrationError) as info:
        tools.register("saw", object(), sharp=True, teeth=40)
    assert str(info.value) == "tool saw: no capabilities ['teeth'] (a tool declares sharp, sizes)"
    assert "saw" not in tools


def test_the_main_families_declare_their_capabilities():
    assert isinstance(controller_info("mpc"), ControllerKind)
    assert controller_info("mpc").slip_sensing and controller_info("pid").blend == "interpolate"
    assert isinstance(estimator_info("ss_kf"), EstimatorKind)
    assert estimator_info("ss_kf").paper and "one_step" in estimator_info("ss_kf").modes
    assert isinstance(kind_info("episode"), ScenarioKind)
    assert "grasp_lift_hold" in kind_info("episode").protocols


def test_a_registry_makes_its_modules_unregister_and_names_functions():
    import pickle

    from sim.user import generators

    tools = Registry("tool", capabilities=Tool)
    unregister_tool, tool_names = tools.functions(__name__, "tool")
    assert (unregister_tool.__name__, tool_names.__name__) == ("unregister_tool", "tool_names")
    assert tool_names.__module__ == __name__ and "tool" in tool_names.__doc__
    tools.register("knife", object(), sharp=True)
    tools.register_record("saw", object(), Tool(sharp=True, sizes=(3,)))
    assert tool_names() == ("knife", "saw") and tools.info("saw").sizes == (3,)
    unregister_tool("knife")
    unregister_tool("knife")  # no effect when absent
    assert tool_names() == ("saw",)
    with pytest.raises(RegistrationError, match="expected Tool, found dict"):
        tools.register_record("axe", object(), {"sharp": True})  # type: ignore[arg-type]
    with pytest.raises(RegistrationError, match="already registered"):
        tools.register_record("saw", object(), Tool(sharp=False))
    # the module's public functions are plain functions of that module
    assert generators.generator_names.__module__ == "sim.user.generators"
    assert pickle.loads(pickle.dumps(generators.generator_names)) is generators.generator_names
