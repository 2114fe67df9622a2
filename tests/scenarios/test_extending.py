"""Extending griploop: one module plus one registration per extension.

This module registers a toy estimator, controller, sEMG generator, object,
scenario kind and report section -- here, without editing any other file --
and checks that the scenario schema, the CLI's choices, a sweep and the report
pick them up. A fixture removes the registrations afterwards. The protocol tests
run the checkers for plugin authors (:mod:`scenarios.checks`) on every registered
piece and on the toys.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import control
import numpy as np
import pytest

from controllers.base import as_observation
from controllers.bounds import slip_threshold_n
from controllers.design import design_for_object
from controllers.design_spec import DesignSpec
from controllers.errors import SpecificationError
from controllers.registry import (
    ControllerKind,
    check_options,
    controller_names,
    design_controller,
    register_controller,
    unregister_controller,
)
from estimation.base import ForceEstimator
from estimation.registry import (
    EstimatorKind,
    estimator_info,
    make_estimator,
    register_estimator,
    unregister_estimator,
)
from scenarios.checks import CHECKERS, check_all, registered_names
from scenarios.cli.main import build_parser
from scenarios.execution.sweep import DEFAULT_TASK, SweepExecution, plan, run_sweep
from scenarios.outcomes import OUTCOMES
from scenarios.report import build_report
from scenarios.report.html import Section
from scenarios.report.sections import register_section, section_names, unregister_section
from scenarios.runners.dispatch import register_kind, unregister_kind
from scenarios.runners.episode import (
    EpisodeSpec,
    controller_spec,
    episode_from_scenario,
    run_episode,
)
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


class Integral:
    """Toy controller: ``u_k = u_(k-1) + ki T e_k``, clipped to -1..1; only reset, act and loop.

    No ``track``, ``handover``, ``dt_s`` attribute of the protocol or gains: the
    defaults of :class:`controllers.base.ControllerBase` complete it.
    """

    def __init__(self, ki_per_s: float, period_s: float) -> None:
        self.ki_per_s, self.period_s, self.u = ki_per_s, period_s, 0.0

    def reset(self, u0: float = 0.0) -> None:
        self.u = float(u0)

    def act(self, observation) -> float:
        obs = as_observation(observation)
        step = self.ki_per_s * self.period_s * (obs.reference_n - obs.grip_force_n)
        self.u = float(np.clip(self.u + step, -1.0, 1.0))
        return self.u

    def loop(self, plant: control.LTI) -> control.LTI:
        # the integrator ki T z / (z - 1) and one period of computation delay
        return control.tf([self.ki_per_s * self.period_s], [1.0, -1.0], self.period_s) * plant


def design_integral(plant: control.LTI, *, phase_margin_deg: float = 60.0,
                    crossover_rad_s: float = 20.0, gain_scale: float = 1.0) -> Integral:
    """The fastest crossover up to ``crossover_rad_s`` whose loop keeps ``phase_margin_deg``.

    ``gain_scale`` multiplies the gain found (1: the loop crosses over there).
    """
    dt = float(plant.dt)
    w = np.geomspace(0.05, crossover_rad_s, 400)
    z = np.exp(1j * w * dt)
    shape = np.array([complex(control.evalfr(plant, zi)) for zi in z]) * dt / (z - 1.0)
    phase_deg = np.degrees(np.unwrap(np.angle(shape)))
    ok = np.flatnonzero(phase_deg >= -180.0 + phase_margin_deg)
    i = int(ok[-1]) if ok.size else 0
    return Integral(gain_scale / abs(shape[i]), dt)


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
    register_estimator("toy_mean", MeanForce,
                       EstimatorKind(modes=("free_run",), params={"shrink": 0.5}))
    register_controller("toy_p", design_integral, ControllerKind(
        options=("gain_scale",),
        defaults={"phase_margin_deg": 60.0, "crossover_rad_s": 20.0, "gain_scale": 1.0}))
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
        register_controller("bad", design_integral,
                            ControllerKind(shaping=False, defaults={"gain": 1}))
    with pytest.raises(RegistrationError, match="expected blend"):
        register_controller("bad", design_integral, ControllerKind(blend="average"))
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
        summary = run_sweep(items, store, SweepExecution(workers=1), sweep_name="toys",
                            progress=False)
        rows = store.rows()
    assert (summary.ok, summary.failed) == (2, 0)
    results = sorted((r["result"] for r in rows), key=lambda r: r["mass_kg"])
    assert [r["mass_kg"] for r in results] == [0.2, 0.4]
    assert {r["kind"] for r in results} == {"toy_kind"}
    # completed with the protocol's defaults (track, handover): the toy itself has neither
    assert {(r["generator"], r["controller"]) for r in results} == {
        ("half_noise", "CompletedController")}
    assert all(r["estimate_n"] < r["mean_force_n"] - 0.5 for r in results)  # shrink 0.5
    assert section_names()[-2:] == ("toy_section", "provenance")
    report = build_report(db, tmp_path / "report", render_frame=False)
    html = report.path.read_text()
    assert "Toy section" in html and "2 toy rows" in html
    assert [s.title for s in report.sections].index("Toy section") == len(report.sections) - 2


# ------------------------------------------------------------------ protocols (the checkers)


@pytest.mark.parametrize("family", list(CHECKERS))
def test_every_registered_piece_passes_the_checker_of_its_family(family):
    names = registered_names()[family]
    assert names, family
    assert [f.line() for f in check_all({family: names})] == []


def test_the_toys_pass_the_checkers(toys):
    toys_by_family = {"controller": ("toy_p",), "estimator": ("toy_mean",),
                      "object": ("mug",), "scenario kind": ("toy_kind",)}
    assert [f.line() for f in check_all(toys_by_family)] == []


def test_every_registered_generator_satisfies_its_protocol():
    for name in generator_names():
        assert isinstance(make_generator(name), EmgGenerator), name


# ------------------------------------------------------------------ end to end

CAN = make_object("can")


def test_a_controller_with_only_reset_act_and_loop_holds_the_can(toys):
    scheduled = design_for_object(CAN, "toy_p")  # one design per grid force of the can
    lo, hi = scheduled.family.range_n
    assert len(scheduled.design_forces_n) >= 10 and lo <= 2.0 and hi >= 20.0
    analyses = [scheduled.analyse(f) for f in (lo, 8.0, hi)]
    assert all(a.ok and a.margins.stable for a in analyses)
    assert all(a.controller is None for a in analyses)  # no transfer function: loop() only
    assert min(a.margins.phase_margin_deg for a in analyses) >= 55.0  # the toy's design rule
    for spec in ({"crossover_rad_s": 20.0}, {"crossover_rad_s": 20.0, "scheduled": False}):
        result = run_episode(VirtualSubject.sample(0, 0), CAN, EpisodeSpec(estimator="oracle",
                             controller="toy_p", controller_spec=spec, seed=0))
        row = result.row
        assert row["outcome"] == "held", (spec, row)
        assert row["held_force_n"] > slip_threshold_n(CAN.mass_kg, CAN.friction)
    assert result.design.scheduled is False and len(result.design.design_forces_n) == 1


def test_interpolated_scheduling_is_refused_for_a_controller_without_gains(toys):
    register_controller("toy_interp", design_integral, ControllerKind(blend="interpolate"))
    try:
        with pytest.raises(SpecificationError) as info:
            design_for_object(CAN, "toy_interp")
    finally:
        unregister_controller("toy_interp")
    message = str(info.value)
    assert "blend 'interpolate'" in message and "kp" in message and "\n" not in message


def test_a_design_without_act_is_refused_in_one_line(toys):
    register_controller("toy_broken", lambda plant, **spec: object(),
                        ControllerKind(shaping=False))
    try:
        with pytest.raises(SpecificationError, match=r"toy_broken: .* without reset, act, loop"):
            design_controller("toy_broken", control.c2d(control.tf([1.0], [0.1, 1.0]), 0.01))
    finally:
        unregister_controller("toy_broken")


def test_the_toy_estimator_drives_an_episode(toys):
    result = run_episode(VirtualSubject.sample(0, 0), CAN, EpisodeSpec(estimator="toy_mean",
                         controller="pid", seed=0, episode_s=4.0, hold_s=1.0))
    reference = result.traces["reference_n"]
    assert result.row["estimator"] == "toy_mean"
    estimated = reference[reference > 0]  # zero until the first feature window is full
    assert estimated.size > 0.8 * reference.size
    assert np.ptp(estimated) < 1e-9  # a constant: the shrunk calibration mean
    assert result.row["outcome"] in OUTCOMES


def test_a_controller_option_reaches_the_design_from_yaml(toys, tmp_path):
    path = tmp_path / "opts.yaml"
    path.write_text("base:\n  kind: episode\n  controller:\n    kind: toy_p\n    options:\n"
                    "      gain_scale: 0.5\n")
    scenario = expand_sweep(load_sweep(path))[0].scenario
    spec = controller_spec(scenario)
    assert spec["gain_scale"] == 0.5
    half = design_for_object(CAN, "toy_p", DesignSpec.from_mapping(spec))
    full = design_for_object(CAN, "toy_p", DesignSpec.from_mapping({**spec, "gain_scale": 1.0}))
    ratio = half.core.designs[3].ki_per_s / full.core.designs[3].ki_per_s
    assert ratio == pytest.approx(0.5)


def test_an_undeclared_yaml_option_names_the_line_and_the_declared_options(toys, tmp_path):
    path = tmp_path / "opts.yaml"
    path.write_text("base:\n  kind: episode\n  controller:\n    kind: toy_p\n    options:\n"
                    "      gain_scale: 0.5\n      gain: 2.0\n")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert str(info.value) == (f"{path}:7: base.controller.options.gain: controller toy_p has "
                               "no option 'gain' (its options: gain_scale)")
    path.write_text("base:\n  controller: {kind: toy_p, options: {gain_scale: fast}}\n")
    with pytest.raises(ScenarioError, match=r":2: .*gain_scale: expected a float"):
        load_sweep(path)
    path.write_text("base:\n  controller: {kind: pid}\ngrid:\n  controller.options.gain_scale:"
                    " [0.5]\n")
    with pytest.raises(ScenarioError, match=r"controller pid has no option 'gain_scale' "
                                            r"\(its options: none\)"):
        expand_sweep(load_sweep(path))


def test_an_estimator_option_reaches_the_fit_from_yaml(toys, tmp_path):
    register_estimator("toy_mean_free", MeanForce, EstimatorKind(modes=("free_run",)))
    path = tmp_path / "opts.yaml"
    base = ("base:\n  kind: episode\n  seed: 4\n  protocol: {name: grasp_lift_hold, "
            "episode_s: 4.0, hold_s: 1.0}\n  controller: {kind: pid}\n"
            "  estimator:\n    name: toy_mean_free\n    mode: free_run\n")
    try:
        held = {}
        for shrink in (0.25, 1.0):
            path.write_text(base + f"    options: {{shrink: {shrink}}}\n")
            scenario = expand_sweep(load_sweep(path))[0].scenario
            assert scenario.estimator.options == {"shrink": shrink}
            reference = episode_from_scenario(scenario).traces["reference_n"]
            held[shrink] = float(reference[-1])
        assert 0.0 < held[0.25] < 0.6 * held[1.0]  # the mean calibration force, shrunk
        path.write_text(base + "    options:\n      shrink: 0.5\n      scale: 2.0\n")
        with pytest.raises(ScenarioError) as info:
            load_sweep(path)
        assert str(info.value) == (f"{path}:11: base.estimator.options.scale: estimator "
                                   "toy_mean_free has no option 'scale' (its options: shrink)")
    finally:
        unregister_estimator("toy_mean_free")
