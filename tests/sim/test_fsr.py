"""FSR 402 through a divider and a 10-bit ADC, read back with the nominal calibration."""

from __future__ import annotations

import numpy as np
import pytest

from sim.user.fsr import FSR402, FSRError


def quiet(**kw) -> FSR402:
    return FSR402(adc_noise_lsb=0.0, **kw)


def test_nominal_device_reads_true_force_within_one_adc_step():
    fsr = quiet()
    f = np.linspace(1.0, 45.0, 200)
    measured = fsr.measure(f, np.random.default_rng(0))
    # one count of the divider is dV = 1/1023; dF/dV from F = 10 (r_ref/r_meas) v/(1-v)
    v = fsr.r_meas_ohm / (fsr.r_meas_ohm + 1e3 * 10.0 / f)
    step_n = 10.0 * (fsr.r_meas_ohm / 1e3) / (1 - v) ** 2 / 1023.0
    assert np.all(np.abs(measured - f) <= 0.5 * step_n * 1.05 + 0.05 * f * (f / 60.0) ** 8)


def test_device_spread_gives_the_closed_form_nonlinearity_error():
    fsr = quiet(alpha=1.05, r_ref_ohm=1.1e3)
    f = np.array([2.0, 10.0, 30.0])
    expected = 10.0 * (f / 10.0) ** 1.05 / 1.1  # nominal inverse of the device law
    np.testing.assert_allclose(fsr.measure(f, np.random.default_rng(0)), expected, rtol=0.03)


def test_saturation_and_range():
    fsr = FSR402()
    rng = np.random.default_rng(1)
    codes = fsr.adc_codes(np.array([0.0, 0.1, 60.0, 500.0]), rng)
    assert codes.min() >= 0 and codes.max() <= 1023
    measured = fsr.measure(np.array([80.0, 200.0, 1000.0]), rng)
    np.testing.assert_allclose(measured, 50.0)  # clipped at the 50 N range
    assert fsr.measure(np.zeros(10), rng).max() < 0.05  # open below turn-on


def test_adc_quantizes_the_reading():
    fsr = quiet()
    f = np.linspace(20.0, 21.0, 500)
    measured = fsr.measure(f, np.random.default_rng(0))
    codes = fsr.adc_codes(f, np.random.default_rng(0))
    v = fsr.r_meas_ohm / (fsr.r_meas_ohm + 1e3 * 10.0 / np.array([20.0, 21.0]))
    span = 1023 * (v[1] - v[0])  # about 6 counts per newton here
    assert np.unique(measured).size == np.unique(codes).size
    assert abs(np.unique(codes).size - (span + 1)) <= 1
    assert np.all(np.diff(measured) >= 0)  # monotone


def test_noise_is_reproducible_and_rejects_nan():
    fsr = FSR402()
    f = np.linspace(0, 40, 100)
    a = fsr.measure(f, np.random.default_rng(5))
    np.testing.assert_array_equal(a, fsr.measure(f, np.random.default_rng(5)))
    with pytest.raises(FSRError, match="NaN or inf"):
        fsr.measure(np.array([1.0, np.nan]), np.random.default_rng(0))
    with pytest.raises(ValueError, match="adc_bits: expected 1..16, found 20"):
        FSR402(adc_bits=20)


def test_sampled_devices_differ_and_stay_near_nominal():
    rng = np.random.default_rng(0)
    devices = [FSR402.sample(rng) for _ in range(20)]
    alphas = [d.alpha for d in devices]
    assert len(set(alphas)) == 20 and 0.93 <= min(alphas) and max(alphas) <= 1.07
