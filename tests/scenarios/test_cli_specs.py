"""The CLI designs with the library's default specifications: Python and CLI agree."""

from __future__ import annotations

import argparse

import pytest

from controllers.design import DEFAULT_SPECS, design_for_object
from controllers.design_plant import object_for
from controllers.design_spec import DesignSpec
from controllers.registry import CONTROLLER_NAMES
from scenarios.cli.commands.episode import scenario_from_args
from scenarios.cli.commands.margins import design_from_args
from scenarios.runners.episode import EpisodeSpec, controller_spec


def _margins_args(controller: str) -> argparse.Namespace:
    return argparse.Namespace(controller=controller, object="can", mass_kg=0.4, friction=0.5,
                              phase_margin_deg=None, crossover_rad_s=None, fixed_at_n=None,
                              dt_s=0.01)


def _episode_args(controller: str) -> argparse.Namespace:
    return argparse.Namespace(controller=controller, estimator="ss_kf", mode="free_run",
                              object="can", mass_kg=0.4, friction=0.5, subject=1,
                              population_seed=0, seed=0, episode_s=None, hold_s=2.0,
                              user="reacting", feedback="none", practice=5, window_ms=400.0,
                              step_ms=125.0, drive="backdrivable", paradigm="force",
                              auto_grip=False, decoder=None)


def test_every_controller_has_default_specs():
    assert set(DEFAULT_SPECS) == set(CONTROLLER_NAMES)


@pytest.mark.parametrize("controller", sorted(DEFAULT_SPECS))
def test_cli_and_library_designs_agree(controller):
    obj = object_for("can", mass_kg=0.4, friction=0.5)
    library = design_for_object(obj, controller, DesignSpec.from_mapping(DEFAULT_SPECS[controller]))
    plain = design_for_object(obj, controller)  # the function's own defaults
    margins_cli = design_from_args(_margins_args(controller))
    episode_cli = design_for_object(obj, controller, DesignSpec.from_mapping(
        controller_spec(scenario_from_args(_episode_args(controller)))))
    for design in (plain, margins_cli, episode_cli):
        assert design.spec == library.spec  # includes lag_ratio, horizon, the design forces


def test_compare_references_defaults_to_the_library_specs(monkeypatch):
    import scenarios.runners.compare as compare

    seen = []

    def fake_run_episode(subject, obj, spec, **kwargs):
        seen.append(spec.controller_spec)
        raise compare.UnsupportedScenarioError("stop here")

    monkeypatch.setattr(compare, "run_episode", fake_run_episode)
    obj = object_for("can", mass_kg=0.4, friction=0.5)
    compare.compare_references(obj, EpisodeSpec(controller="lead_lag"),
                               estimators=["oracle"], subject_ids=[1])
    assert seen == [DEFAULT_SPECS["lead_lag"]]
