"""Seeds stay put: a field added to the schema and left at its default moves no seed.

A scenario's seed (and content hash) derives from its canonical JSON. The canonical form
of a default scenario is written out below: a field added without
:func:`scenarios.schema.canonical.added_field` changes it and fails here, before any figure
moves. The library sweeps' seeds are held by their digest.
"""

from __future__ import annotations

import hashlib
import json
from importlib.resources import files

import pytest
from pydantic import BaseModel, Field

from scenarios.schema import Scenario, expand_sweep, load_sweep
from scenarios.schema.models import added_field, omit_added_defaults
from sim.user.operator import OperatorParams

#: The canonical JSON of ``Scenario()`` (issue 33's schema): every field of the original
#: form, none of the fields added later.
DEFAULT_CANONICAL = (
    '{"controller":{"bandwidth_rad_s":null,"control_hz":100.0,"crossover_rad_s":null,'
    '"horizon":null,"kind":"pid","phase_margin_deg":60.0,"safety_factor":1.5,'
    '"scheduled":true,"slip_reflex":{"enabled":false,"gain":0.3,"latency_s":0.05},'
    '"solver":null},"estimator":{"mode":"free_run","name":"ss_kf","order":null,'
    '"step_ms":125.0,"window_ms":400.0},"kind":"episode","object":{"break_force_n":null,'
    '"friction":null,"mass_kg":null,"name":"ball","shape":null,"size_m":null,'
    '"stiffness_n_per_m":null},"protocol":{"calibration_s":null,"duration_s":60.0,'
    '"episode_s":null,"hold_s":2.0,"identification_fraction":0.5,"load_rate_n_s":1.0,'
    '"name":"grasp_lift_hold","target_fraction":0.4,"trials":3},"seed":null,'
    '"subject":{"electrode_shift":0.0,"extra_noise_lsb":0.0,"fatigue_per_min":0.0,'
    '"generator":"noise","population_seed":0,"subject_id":1},"user":{"feedback":"none",'
    '"kind":"reacting","params":{"anticipation_weight":1.0,"correction_gain":0.3,'
    '"correction_rise_s":0.15,"dwell_s":0.3,"feedback_delay_s":0.15,"force_step":0.1,'
    '"intact_margin":0.25,"lift_s":0.6,"liftoff_height_m":0.01,"liftoff_s":0.5,'
    '"margin_per_uncertainty":2.0,"min_learning_rate":0.2,"motor_noise_cv":0.045,'
    '"motor_noise_time_s":0.25,"novice_margin":0.5,"refractory_s":0.5,"release_s":0.3,'
    '"release_wait_s":3.0,"slip_burst_s":0.1,"slip_sensor_m_s":0.005,"still_rad_s":0.2,'
    '"touch_delay_s":0.074,"touch_dwell_s":0.1,"uncertainty_rate":0.3,'
    '"vibration_levels":5,"vibration_noise_levels":0.15,"visible_slip_m":0.002,'
    '"vision_delay_s":0.2,"vision_noise_m":0.0005,"vision_noise_time_s":0.1},'
    '"practice":5}}')

#: Digest of the seeds of every scenario the library sweeps expand to (the seeds of the
#: figures in docs/results), as they were before the one trial loop.
LIBRARY_SEEDS = {"demo": "f0a5acc3b8771486", "eggs": "67902745dc7786a0",
                 "slip_recovery": "bf2f2358f0e44e9a", "force_matching": "57673dde35e011cb",
                 "transfers": "346846d50bb02a34"}


def test_the_canonical_form_of_a_default_scenario_is_the_original_one() -> None:
    assert Scenario().canonical_json() == DEFAULT_CANONICAL


@pytest.mark.parametrize("name", sorted(LIBRARY_SEEDS))
def test_the_library_sweeps_keep_their_seeds(name) -> None:
    spec = load_sweep(str(files("scenarios") / "library" / f"{name}.yaml"))
    seeds = [e.scenario.seed for e in expand_sweep(spec, name)]
    assert hashlib.sha256(json.dumps(seeds).encode()).hexdigest()[:16] == LIBRARY_SEEDS[name]


class _Section(BaseModel):
    level: float = 1.0
    added_later: str = added_field("off")


class _Toy(BaseModel):
    name: str = "toy"
    section: _Section = Field(default_factory=_Section)
    options: dict = added_field(default_factory=dict)


def test_an_added_field_at_its_default_stays_out_of_the_canonical_form() -> None:
    def canonical(toy: _Toy) -> dict:
        return omit_added_defaults(toy, toy.model_dump(mode="json"))

    assert canonical(_Toy()) == {"name": "toy", "section": {"level": 1.0}}
    # set to anything else, it is part of the scenario, and of its seed
    assert canonical(_Toy(section=_Section(added_later="on"))) == {
        "name": "toy", "section": {"level": 1.0, "added_later": "on"}}
    assert canonical(_Toy(options={"a": 1}))["options"] == {"a": 1}


def test_an_operator_parameter_can_be_added_without_moving_a_seed() -> None:
    # the parameters are of the original form but those added later (issue 36's
    # open_level, issue 37's preload_n and grip_lead_s); one declared added=True is made an
    # added_field of the schema (scenarios.schema.models._operator_params_model)
    assert {name for name, spec in OperatorParams.ranges().items() if spec["added"]} == {
        "open_level", "preload_n", "grip_lead_s"}
