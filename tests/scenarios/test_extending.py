"""Extending griploop: one module plus one registration per extension.

This module registers a toy estimator, controller, sEMG generator, object,
scenario kind and report section -- here, without editing any other file --
and checks that the scenario schema, the CLI's choices, a sweep and the report
pick them up. A fixture removes the registrations afterwards. The last tests
check that every registered kind satisfies its protocol.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import control
import numpy as np
import pytest

from controllers.base import Controller, as_observation
from controllers.registry import (
    check_options,
    controller_names,
    default_spec,
    design_controller,
    register_controller,
    unregister_controller,
)
from estimation.base import ForceEstimator
from estimation.protocols import Estimator, Stream
from estimation.registry import (
    estimator_info,
    estimator_names,
    make_estimator,
    register_estimator,
    unregister_estimator,
)
from scenarios.cli.main import build_parser
from scenarios.execution.sweep import DEFAULT_TASK, plan, run_sweep
from scenarios.report import build_report
from scenarios.report.html import Section
from scenarios.report.sections import register_section, section_names, unregister_section
from scenarios.runners.dispatch import register_kind, scenario_kinds, unregister_kind
from scenarios.schema import ScenarioError, expand_sweep, load_sweep, parse_scenario
from scenarios.store import ResultStore
from sim.hand.objects import (
    ObjectSpec,
    make_object,
    object_names,
    register_object,
    unregister_object,
)
from sim.registry import RegistrationError
from sim.user.emg import EmgGenerator, MuscleSignals
from sim.user.emg_noise import NoiseEmgGenerator
from sim.user.generators import (
    generator_names,
    make_generator,
    register_generator,
    unregister_generator,
)
from sim.user.intent import ramp_profile
from sim.user.subjects import VirtualSubject

# ------------------------------------------------------------------ the toy extensions


class MeanForce(ForceEstimator):
    """Toy estimator: the mean calibration force, scaled by ``shrink``."""

    modes = ("free_run",)

    def __init__(self, *, shrink: float = 1.0) -> None:
        self.shrink = shrink

    def fit(self, U: np.ndarray, y: np.ndarray) -> MeanForce:
        self.mean_ = float(np.mean(y)) * self.shrink
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        self._mode(mode, y)
        return np.full(np.asarray(U).shape[0], self.mean_)

    def streaming(self, mode: str = "free_run", *, scaling=None, **options) -> MeanStream:
        if scaling is None:
            return MeanStream(self.mean_)
        return MeanStream(float(scaling.inverse_y(np.array([self.mean_]))[0]))


class MeanStream:
    """Stream of :class:`MeanForce`: a constant."""

    def __init__(self, value: float) -> None:
        self.value = value

    def reset(self) -> None:
        pass

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        return self.value


class Proportional:
    """Toy controller: ``u = kp (reference - grip)``, clipped to -1..1."""

    computation_delay_samples = 0

    def __init__(self, kp: float, dt_s: float) -> None:
        self.kp, self.dt_s = kp, dt_s

    def reset(self, u0: float = 0.0) -> None:
        self.u = u0

    def act(self, observation) -> float:
        obs = as_observation(observation)
        self.u = float(np.clip(self.kp * (obs.reference_n - obs.grip_force_n), -1.0, 1.0))
        return self.u

    def loop(self, plant: control.LTI) -> control.LTI:
        return control.tf([self.kp], [1.0], self.dt_s) * plant


def design_proportional(plant: control.LTI, *, phase_margin_deg: float = 60.0,
                        crossover_rad_s: float = 20.0, gain_scale: float = 1.0) -> Proportional:
    """Gain that puts the loop's crossover at ``crossover_rad_s`` (times ``gain_scale``)."""
    response = abs(complex(control.evalfr(plant, np.exp(1j * crossover_rad_s * plant.dt))))
    return Proportional(gain_scale / response, float(plant.dt))


@dataclass(frozen=True)
class HalfNoise:
    """Toy sEMG generator: the noise generator at half amplitude."""

    name: str = "half_noise"

    def generate(self, drive, muscles, front_end, *, fs_hz, rng) -> MuscleSignals:
        signals = NoiseEmgGenerator().generate(drive, muscles, front_end, fs_hz=fs_hz, rng=rng)
        return MuscleSignals(0.5 * signals.emg, signals.force, signals.info)

    def steady_force(self, drive, muscles) -> np.ndarray:
        return NoiseEmgGenerator().steady_force(drive, muscles)

    def params(self) -> dict:
        return {"amplitude_scale": 0.5}


def mug() -> ObjectSpec:
    """Toy object: a 0.3 kg ceramic mug, 80 mm wide."""
    return ObjectSpec("mug", "cylinder", (0.04, 0.05), 0.3, friction=0.7)


def toy_runner(scenario) -> dict:
    """Toy scenario kind: builds the scenario's estimator, object, generator and controller."""
    rng = np.random.default_rng(scenario.seed)
    U, y = rng.normal(size=(40, 3)), 5.0 + rng.normal(size=40)
    estimate = make_estimator(scenario.estimator.name).fit(U, y).predict(U, mode="free_run")
    obj = make_object(scenario.object.name, mass_kg=scenario.object.mass_kg)
    generator = make_generator(scenario.subject.generator)
    plant = control.c2d(control.ss(control.tf([50.0], [0.05, 1.0])), 0.01)
    controller = design_controller(scenario.controller.kind, plant)
    return {"estimate_n": float(estimate[0]), "mean_force_n": float(np.mean(y)),
            "mass_kg": obj.mass_kg,
            "generator": generator.name, "controller": type(controller).__name__}


def toy_section(context) -> Section:
    """Toy report section: counts the rows of the toy kind."""
    n = sum(1 for row in context.rows if row.get("result", {}).get("kind") == "toy_kind")
    return Section("toy", "Toy section", f"<p>{n} toy rows</p>")


@pytest.fixture
def toys():
    """Register every toy, and remove the registrations afterwards."""
    register_estimator("toy_mean", MeanForce, modes=("free_run",), params={"shrink": 0.5})
    register_controller("toy_p", design_proportional, options=("gain_scale",),
                        defaults={"phase_margin_deg": 60.0, "crossover_rad_s": 20.0,
                                  "gain_scale": 1.0})
    register_generator("half_noise", HalfNoise)
    register_object("mug", mug)
    register_kind("toy_kind", toy_runner, protocols=("grasp_lift_hold",))
    register_section("toy_section", toy_section, order=95)
    yield
    unregister_estimator("toy_mean")
    unregister_controller("toy_p")
    unregister_generator("half_noise")
    unregister_object("mug")
    unregister_kind("toy_kind")
    unregister_section("toy_section")


TOY_SCENARIO = {"kind": "toy_kind", "object": {"name": "mug"},
                "estimator": {"name": "toy_mean"}, "controller": {"kind": "toy_p"},
                "subject": {"generator": "half_noise"}}

# ------------------------------------------------------------------ schema


def test_unregistered_names_are_refused_with_the_valid_ones():
    for data, field in [({"estimator": {"name": "toy_mean"}}, "estimator.name"),
                        ({"controller": {"kind": "toy_p"}}, "controller.kind"),
                        ({"object": {"name": "mug"}}, "object.name"),
                        ({"subject": {"generator": "half_noise"}}, "subject.generator"),
                        ({"kind": "toy_kind"}, "kind")]:
        with pytest.raises(ScenarioError) as info:
            parse_scenario(data, source="opts")
        message = str(info.value)
        assert message.startswith(f"opts: {field}: expected one of "), message
        assert "\n" not in message


def test_schema_accepts_the_registered_toys(toys):
    scenario = parse_scenario({**TOY_SCENARIO, "protocol": {"name": "grasp_lift_hold"}})
    assert (scenario.kind, scenario.object.name, scenario.estimator.name,
            scenario.controller.kind, scenario.subject.generator) == (
        "toy_kind", "mug", "toy_mean", "toy_p", "half_noise")
    assert scenario.controller.horizon is None  # toy_p takes no horizon
    with pytest.raises(ScenarioError, match="kind toy_kind needs protocol.name grasp_lift_hold"):
        parse_scenario({**TOY_SCENARIO, "protocol": {"name": "paper_calibration"}})
    with pytest.raises(ScenarioError, match="horizon applies to controller kind mpc only"):
        parse_scenario({**TOY_SCENARIO, "controller": {"kind": "toy_p", "horizon": 5}})


def test_sweep_file_line_numbers_with_registered_names(toys, tmp_path):
    path = tmp_path / "toy.yaml"
    path.write_text("base:\n  kind: toy_kind\n  object: {name: mug}\ngrid:\n"
                    "  estimator.name: [toy_mean, nope]\n")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert str(info.value).startswith(
        f"{path}:5: grid.estimator.name[1]: estimator.name: expected one of ")
    assert "toy_mean" in str(info.value)


def test_registrations_are_checked():
    with pytest.raises(RegistrationError, match="already registered"):
        register_estimator("ss_kf", MeanForce)
    with pytest.raises(RegistrationError, match="'package.module:attribute'"):
        register_object("jar", "not-a-reference")
    with pytest.raises(RegistrationError, match="not among its options"):
        register_controller("bad", design_proportional, shaping=False, defaults={"gain": 1})
    assert "bad" not in controller_names() and "jar" not in object_names()


# ------------------------------------------------------------------ library and CLI


def test_the_registries_build_the_toys(toys):
    U, y = np.random.default_rng(0).normal(size=(10, 2)), np.linspace(2.0, 4.0, 10)
    bare = make_estimator("toy_mean", normalize=False).fit(U, y)
    assert bare.predict(U)[0] == pytest.approx(1.5)  # shrink 0.5 from the registered params
    est = make_estimator("toy_mean").fit(U, y)  # min-max normalized: mean 0.5 -> 0.25 -> 2.5 N
    assert est.predict(U)[0] == pytest.approx(2.5)
    assert est.streaming("free_run").step(U[0]) == pytest.approx(2.5)
    assert estimator_info("toy_mean")["modes"] == ("free_run",)
    assert make_object("mug", friction=0.9).friction == 0.9
    subject = VirtualSubject.sample(0, 1)
    profile = ramp_profile(0, peaks=(0.6,))
    half = subject.record(profile, generator="half_noise", rng=1)
    full = subject.record(profile, generator="noise", rng=1)
    assert half.metadata["generator"] == "half_noise"
    assert np.std(half.emg.astype(float)) < 0.75 * np.std(full.emg.astype(float))
    with pytest.raises(Exception, match="toy_p is specified by .*gain_scale"):
        check_options("toy_p", {"horizon": 10})
    check_options("toy_p", {"gain_scale": 2.0, "crossover_rad_s": 10.0})


def _subparser(command: str) -> argparse.ArgumentParser:
    parser = build_parser(command)
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices[command]


def _option(parser: argparse.ArgumentParser, flag: str) -> argparse.Action:
    return next(a for a in parser._actions if flag in a.option_strings)


def test_cli_choices_and_help_list_the_toys(toys):
    episode = _subparser("episode")
    for flag, name in [("--estimator", "toy_mean"), ("--controller", "toy_p"),
                       ("--object", "mug")]:
        assert name in _option(episode, flag).help, flag
    assert "toy_mean" in episode.format_help()
    assert "toy_p" in _subparser("margins").format_help()
    assert "half_noise" in _option(_subparser("subjects"), "--generator").choices
    assert "half_noise" in _option(_subparser("reproduce"), "--generator").choices


def test_cli_choices_without_the_toys():
    assert "toy_mean" not in _option(_subparser("episode"), "--estimator").help
    assert "half_noise" not in _option(_subparser("subjects"), "--generator").choices


# ------------------------------------------------------------------ sweep and report


def test_a_sweep_runs_the_toys_and_the_report_shows_the_toy_section(toys, tmp_path):
    path = tmp_path / "toy.yaml"
    path.write_text("name: toys\nseed: 3\nbase:\n  kind: toy_kind\n  object: {name: mug}\n"
                    "  estimator: {name: toy_mean}\n  controller: {kind: toy_p}\n"
                    "  subject: {generator: half_noise}\n"
                    "grid:\n  object.mass_kg: [0.2, 0.4]\n")
    items = plan(expand_sweep(load_sweep(path)), DEFAULT_TASK)
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        summary = run_sweep(items, store, workers=1, sweep_name="toys", progress=False)
        rows = store.rows()
    assert (summary.ok, summary.failed) == (2, 0)
    results = sorted((r["result"] for r in rows), key=lambda r: r["mass_kg"])
    assert [r["mass_kg"] for r in results] == [0.2, 0.4]
    assert {r["kind"] for r in results} == {"toy_kind"}
    assert {(r["generator"], r["controller"]) for r in results} == {("half_noise", "Proportional")}
    assert all(r["estimate_n"] < r["mean_force_n"] - 0.5 for r in results)  # shrink 0.5
    assert section_names()[-2:] == ("toy_section", "provenance")
    report = build_report(db, tmp_path / "report", render_frame=False)
    html = report.path.read_text()
    assert "Toy section" in html and "2 toy rows" in html
    assert [s.title for s in report.sections].index("Toy section") == len(report.sections) - 2


# ------------------------------------------------------------------ protocols


def test_every_registered_estimator_satisfies_the_protocol():
    rng = np.random.default_rng(0)
    U, y = rng.normal(size=(60, 3)), 5.0 + np.cumsum(rng.normal(size=60)) * 0.1
    for name in estimator_names():
        est = make_estimator(name, normalize=False)
        assert isinstance(est, Estimator), name
        assert tuple(est.modes) == estimator_info(name)["modes"], name
    pipeline = make_estimator("ridge", dt_s=0.125).fit(U, y)
    assert isinstance(pipeline, Estimator)
    assert isinstance(pipeline.streaming("free_run"), Stream)


def test_every_registered_controller_satisfies_the_protocol():
    plant = control.c2d(control.ss(control.tf([50.0], [0.05, 1.0])), 0.01)
    for name in controller_names():
        controller = design_controller(name, plant, **default_spec(name))
        assert isinstance(controller, Controller), name
        controller.reset()
        u = controller.act({"time_s": 0.0, "reference_n": 5.0, "grip_force_n": 0.0})
        assert -1.0 <= u <= 1.0, name


def test_every_registered_generator_object_and_kind_satisfies_its_contract():
    for name in generator_names():
        assert isinstance(make_generator(name), EmgGenerator), name
    for name in object_names():
        assert make_object(name).name == name
    assert set(scenario_kinds()) >= {"reproduction", "calibration", "episode"}
