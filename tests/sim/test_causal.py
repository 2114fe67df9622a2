"""The causal sEMG path: chunk by chunk it gives VirtualSubject.record's recording.

Floats agree to ``PATH_RTOL`` and the int8 sEMG sample for sample but where a float fell
within its last bits of a rounding boundary (``tests/portable.py``): the chunks are other
array shapes, which numpy's vector loops may round differently on some CPUs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from portable import assert_close_across_paths, assert_rounded_close_across_paths

from sim.user.causal import CausalSession, NotCausalError
from sim.user.intent import GraspLiftTiming, grasp_lift_hold, paper_protocol
from sim.user.muscles import CausalActivation, CausalDelay, activation_dynamics, fractional_delay
from sim.user.subjects import VirtualSubject, make_population

pytestmark = pytest.mark.portable


def _chunks(n: int, rng: np.random.Generator, largest: int = 40):
    i = 0
    while i < n:
        k = int(rng.integers(1, largest))
        yield i, min(i + k, n)
        i += k


@pytest.mark.parametrize("subject_id, scenario", [
    (1, {}),
    (2, {"fatigue_per_min": 0.2}),
    (3, {"electrode_shift": 0.4, "extra_noise_lsb": 3.0}),
])
def test_chunked_session_equals_record(subject_id, scenario) -> None:
    subject = VirtualSubject.sample(0, subject_id).with_scenario(**scenario)
    profile = grasp_lift_hold(np.random.default_rng(5), hold_level=0.45,
                              timing=GraspLiftTiming(hold_s=5.0))
    recording = subject.record(profile, rng=np.random.default_rng(9))
    session = CausalSession(subject, profile.n_samples, rng=np.random.default_rng(9))
    rng = np.random.default_rng(subject_id)
    emg = []
    for i0, i1 in _chunks(profile.n_samples, rng):
        emg.append(session.advance(profile.intent[i0:i1]))
        if rng.random() < 0.3:  # forces read now and then: the same numbers
            session.read_forces()
    grip_n, force_n = session.read_forces()
    assert_rounded_close_across_paths(np.concatenate(emg), recording.emg)
    assert_close_across_paths(grip_n, recording.intent_force_n)
    assert_close_across_paths(force_n, recording.force_n)


def test_co_contraction_growing_with_grip_is_the_same_in_both_paths() -> None:
    # a subject of the wide population (sim.user.populations): cocontraction_power > 1
    subject = make_population(4, 2, variant="wide")[3]
    subject = dataclasses.replace(subject, muscles=dataclasses.replace(
        subject.muscles, cocontraction_power=2.7))
    profile = paper_protocol(np.random.default_rng(3))
    recording = subject.record(profile, rng=np.random.default_rng(4))
    session = CausalSession(subject, profile.n_samples, rng=np.random.default_rng(4))
    emg = np.concatenate([session.advance(profile.intent[i:i + 30])
                          for i in range(0, profile.n_samples, 30)])
    assert_rounded_close_across_paths(emg, recording.emg)
    assert_close_across_paths(session.read_forces()[1], recording.force_n)
    # and it changes the sEMG: the muscles that do not grip are quieter in light squeezes
    plain = dataclasses.replace(subject, muscles=dataclasses.replace(
        subject.muscles, cocontraction_power=1.0)).record(profile, rng=np.random.default_rng(4))
    light = (profile.intent > 0.05) & (profile.intent < 0.4)
    assert np.abs(recording.emg[light]).mean() < np.abs(plain.emg[light]).mean()


def test_a_longer_session_matches_the_paper_protocol_too() -> None:
    subject = VirtualSubject.sample(7, 4)
    profile = paper_protocol(np.random.default_rng(1))
    recording = subject.record(profile, rng=np.random.default_rng(2))
    session = CausalSession(subject, profile.n_samples, rng=np.random.default_rng(2))
    emg = np.concatenate([session.advance(profile.intent[i:i + 25])
                          for i in range(0, profile.n_samples, 25)])
    assert_rounded_close_across_paths(emg, recording.emg)
    assert_close_across_paths(session.read_forces()[1], recording.force_n)


def test_causal_filters_equal_the_batch_ones() -> None:
    rng = np.random.default_rng(0)
    x = np.abs(rng.standard_normal((500, 8))).cumsum(axis=0) / 100
    delay_s = rng.uniform(0.0, 0.14, 8)
    delay_s[0] = 0.0
    delay_s[1] = 0.05  # a whole number of samples at 200 Hz
    cutoff = np.array([3.0] * 4 + [2.5] * 4)
    delayed, filtered = CausalDelay(delay_s, 200.0), CausalActivation(cutoff, 200.0)
    out_d, out_f = [], []
    for i0, i1 in _chunks(500, rng, 30):
        out_d.append(delayed.step(x[i0:i1]))
        out_f.append(filtered.step(x[i0:i1]))
    assert_close_across_paths(np.concatenate(out_d), fractional_delay(x, delay_s, 200.0))
    assert_close_across_paths(np.concatenate(out_f), activation_dynamics(x, 200.0, cutoff))


def test_session_refuses_to_run_past_its_length() -> None:
    session = CausalSession(VirtualSubject.sample(0, 1), 50, rng=np.random.default_rng(0))
    session.advance(np.zeros(50))
    with pytest.raises(ValueError, match="50 samples"):
        session.advance(np.zeros(1))


def test_motor_units_cannot_run_causally_and_say_so() -> None:
    with pytest.raises(NotCausalError, match="motor_units .*scripted user"):
        CausalSession(VirtualSubject.sample(0, 1), 100, generator="motor_units",
                      rng=np.random.default_rng(0))
