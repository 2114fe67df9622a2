"""Electrode ring, crosstalk, front end with aliasing, noise and int8 quantization."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, signal

from sim.user.armband import Armband, ArmbandError, FrontEnd, ring_distance
from sim.user.muap import muap_psd


def test_ring_distance_wraps_channel_8_to_channel_1():
    assert ring_distance(0, 7) == 1.0
    assert ring_distance(2, 6) == 4.0
    assert ring_distance(7.5, 0) == 0.5
    assert ring_distance(1, 3) == ring_distance(3, 1) == 2.0


def test_crosstalk_falls_with_distance_and_is_one_on_the_diagonal():
    band = Armband(crosstalk_length=0.55)
    m = band.mixing_matrix()
    np.testing.assert_allclose(np.diag(m), 1.0)
    assert m[0, 7] == pytest.approx(np.exp(-1 / 0.55))  # neighbours across the seam
    assert m[0, 1] > m[0, 2] > m[0, 3] > m[0, 4]
    assert 0.10 <= m[0, 1] <= 0.20  # 10-15 % typical neighbour crosstalk (CALIBRATION.md)


def test_electrode_shift_rotates_what_each_channel_sees():
    whole = Armband(electrode_shift=1.0).mixing_matrix()
    np.testing.assert_allclose(whole, np.roll(Armband().mixing_matrix(), 1, axis=1))
    half = Armband(electrode_shift=0.5).mixing_matrix()
    assert half[0, 0] == pytest.approx(half[0, 1])  # halfway between muscles 1 and 2
    assert Armband(electrode_shift=1.0).nearest_muscles() == [1, 2, 3, 4, 5, 6, 7, 0]


def test_digitize_is_int8_with_counted_saturation():
    band = Armband(noise_lsb=0.0)
    x = np.zeros((100, 8))
    x[:10, 0] = 500.0
    x[10:20, 3] = -500.0
    emg, n_sat = band.digitize(x, np.random.default_rng(0))
    assert emg.dtype == np.int8
    assert emg[:10, 0].tolist() == [127] * 10
    # muscle 4 leaks into neighbours: count every clipped sample independently
    expected = int(np.count_nonzero(np.abs(np.rint(x @ band.mixing_matrix().T)) > 127.5))
    assert n_sat == expected >= 20


def test_rest_noise_std_adds_extra_noise_in_quadrature():
    band = Armband(noise_lsb=1.9, extra_noise_lsb=3.0)
    emg, _ = band.digitize(np.zeros((50_000, 8)), np.random.default_rng(1))
    expected = np.sqrt(np.hypot(1.9, 3.0) ** 2 + 1.0 / 12.0)  # plus rounding noise
    assert emg.astype(float).std() == pytest.approx(expected, rel=0.02)


def test_folding_keeps_total_power():
    fe = FrontEnd()
    fs = 200.0
    f = np.linspace(0.0, fs / 2, 4001)
    folded = fe.folded_psd(lambda g: muap_psd(g, 1.5e-3), f, fs)
    one_sided = np.linspace(0.0, 1000.0, 40001)
    total = 2 * integrate.trapezoid(muap_psd(one_sided, 1.5e-3) * fe.power_response(one_sided),
                                    one_sided)
    assert 2 * integrate.trapezoid(folded, f) == pytest.approx(total, rel=1e-3)


def test_digital_front_end_matches_the_analog_response():
    fe = FrontEnd()
    f = np.array([10.0, 15.0, 50.0, 100.0, 200.0])
    _, h = signal.sosfreqz(fe.sos(2000.0), worN=f, fs=2000.0)
    np.testing.assert_allclose(np.abs(h) ** 2, fe.power_response(f), rtol=0.08)
    assert fe.power_response(np.array([15.0, 200.0])) == pytest.approx([0.5, 0.5], rel=0.01)


def test_bad_settings_raise():
    with pytest.raises(ArmbandError, match="highpass_hz < lowpass_hz"):
        FrontEnd(highpass_hz=300.0)
    with pytest.raises(ArmbandError, match="exceed 2 x lowpass_hz"):
        FrontEnd().sos(300.0)
    with pytest.raises(ValueError, match="channel_gain: expected 8 values, found 2"):
        Armband(channel_gain=(1.0, 1.0))
