"""Virtual subjects: population, recordings, determinism, generator parity and scenario knobs."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from sim.recording import load_recording
from sim.user.intent import grasp_lift_hold, paper_protocol
from sim.user.subjects import (
    GENERATORS,
    UnknownGeneratorError,
    VirtualSubject,
    make_generator,
    make_population,
)

FS = 200.0


@pytest.fixture(scope="module")
def population():
    return make_population(10, seed=0)


def test_population_is_reproducible_and_distinct(population):
    again = make_population(10, seed=0)
    assert [s.params() for s in population] == [s.params() for s in again]
    assert [s.subject_id for s in population] == list(range(1, 11))
    mvc = [s.mvc_n for s in population]
    assert len(set(mvc)) == 10 and 30.0 <= min(mvc) and max(mvc) <= 50.0
    other = make_population(10, seed=1)
    assert all(a.mvc_n != b.mvc_n for a, b in zip(population, other, strict=True))
    assert VirtualSubject.sample(0, 3) == population[2]
    with pytest.raises(ValueError, match="at least 1, found 0"):
        make_population(0)


def test_grip_synergy_roles(population):
    for s in population:
        syn = s.muscles.array("synergy")
        assert syn[5:].min() > syn[2:5].max() > 0 and syn[2:5].min() > syn[:2].max()
        assert np.all(s.muscles.array("grip_share")[:5] == 0.0)
        assert np.all((s.muscles.array("emd_s") >= 0.04) & (s.muscles.array("emd_s") <= 0.14))


@pytest.mark.parametrize("generator", GENERATORS)
def test_recording_has_every_field_and_json_metadata(population, generator, tmp_path):
    rec = population[0].paper_session(generator=generator)
    n = rec.n_samples
    assert rec.emg.dtype == np.int8 and rec.emg.shape == (n, 8) and rec.fs_hz == FS
    assert rec.channel_names == [f"emg{i}" for i in range(1, 9)]
    assert rec.force_n.shape == rec.intent.shape == rec.intent_force_n.shape == (n,)
    assert 45.0 <= rec.duration_s <= 80.0  # two rounds of the three squeezes
    meta = rec.metadata
    assert meta["subject_id"] == 1 and meta["seed"] == 0 and meta["generator"] == generator
    assert meta["muscles_per_channel"][5] == "flexor_carpi_ulnaris"
    assert meta["mvc_n"] == population[0].mvc_n
    assert [k for k, _ in meta["cues"]] == ["start", "end"] * 6
    assert meta["params"]["muscles"]["synergy"] == list(population[0].muscles.synergy)
    json.dumps(meta)
    back = load_recording(rec.save_npz(tmp_path / "r.npz"))
    np.testing.assert_array_equal(back.emg, rec.emg)
    assert back.metadata == json.loads(json.dumps(meta))


def test_generators_give_recordings_of_the_same_shape(population):
    profile = paper_protocol(4)
    noise = population[1].record(profile, generator="noise", rng=7)
    units = population[1].record(profile, generator="motor_units", rng=7)
    for name in ("emg", "force_n", "intent", "intent_force_n"):
        a, b = getattr(noise, name), getattr(units, name)
        assert a.shape == b.shape and a.dtype == b.dtype, name
    np.testing.assert_array_equal(noise.intent, units.intent)
    assert set(noise.metadata) == set(units.metadata)
    # same intent, same MVC: the hold forces agree within the generators' fluctuations
    hold = noise.intent > 0.9 * noise.intent.max()
    assert units.intent_force_n[hold].mean() == pytest.approx(
        noise.intent_force_n[hold].mean(), rel=0.15)


@pytest.mark.parametrize("generator", GENERATORS)
def test_same_seed_is_bit_identical_and_subjects_differ(population, generator):
    a = population[2].paper_session(generator=generator)
    b = make_population(3, seed=0)[2].paper_session(generator=generator)
    for name in ("emg", "force_n", "intent", "intent_force_n"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    c = population[2].paper_session(rng=123, generator=generator)
    assert not np.array_equal(a.intent, c.intent)
    d = population[3].paper_session(generator=generator)
    assert a.n_samples != d.n_samples or not np.array_equal(a.emg, d.emg)


def test_force_has_muscle_dynamics_and_lags_the_emg(population):
    rec = population[4].paper_session()
    f = rec.intent_force_n
    assert np.corrcoef(f[1:], f[:-1])[0, 1] > 0.99  # smooth, not white
    env = np.convolve(np.abs(rec.emg[:, 6].astype(float)), np.ones(20) / 20, mode="same")
    lags = np.arange(0, 60)
    xc = [np.corrcoef(env[: env.size - k], f[k:])[0, 1] for k in lags]
    best_s = lags[int(np.argmax(xc))] / FS
    assert 0.03 <= best_s <= 0.25  # EMD (40-140 ms) plus activation dynamics


def test_grasp_lift_hold_force_tracks_the_hold_level(population):
    s = population[5]
    rec = s.record(grasp_lift_hold(0, hold_level=0.4), generator="noise")
    hold = rec.intent >= 0.399
    assert rec.intent_force_n[hold][100:].mean() == pytest.approx(0.4 * s.mvc_n, rel=0.1)
    assert rec.force_n[hold][100:].mean() == pytest.approx(0.4 * s.mvc_n, rel=0.2)


def test_scenario_knobs(population):
    s = population[6]
    shifted = s.with_scenario(electrode_shift=1.0)
    assert shifted.channel_muscles()[0] == "brachioradialis"
    rec = shifted.paper_session()
    assert rec.metadata["muscles_per_channel"][7] == "pronator_teres"
    # the extra noise adds in quadrature (a stationary noise floor, no contact bursts and
    # no rig lag, so that the rest samples are known exactly)
    steady = dataclasses.replace(s, rig_lag_s=0.0, armband=dataclasses.replace(
        s.armband, noise_drift_std=0.0, artifact_rate_hz=0.0))
    noisy = steady.with_scenario(extra_noise_lsb=5.0).paper_session()
    rest = noisy.intent == 0.0
    expected = np.sqrt(s.armband.noise_lsb**2 + 25.0 + 1.0 / 12.0)
    assert noisy.emg[rest].astype(float).std() == pytest.approx(expected, rel=0.05)
    tired = s.with_scenario(fatigue_per_min=0.2)
    assert tired.muscles.fatigue_per_min == 0.2 and s.muscles.fatigue_per_min == 0.0


def test_profiles_at_another_rate_are_resampled(population):
    rec = population[0].record(paper_protocol(0, fs_hz=100.0), fs_hz=FS)
    assert rec.fs_hz == FS and rec.n_samples == pytest.approx(paper_protocol(0).n_samples, abs=1)


def test_unknown_generator_is_a_lookup_error(population):
    with pytest.raises(UnknownGeneratorError, match="unknown generator 'spikes'; expected one of"):
        population[0].paper_session(generator="spikes")
    assert make_generator("motor_units", n_units=50).n_units == 50
