"""Amplitude-modulated noise generator: spectrum after aliasing, amplitude law, force, fatigue."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import signal

from sim.user.armband import FrontEnd
from sim.user.emg import EmgGenerator
from sim.user.emg_noise import NoiseEmgGenerator, fatigue_profile, shaped_noise
from sim.user.muap import muap_psd
from sim.user.subjects import make_population

FS = 200.0


def median_frequency(f: np.ndarray, p: np.ndarray) -> float:
    c = np.cumsum(p) / np.sum(p)
    return float(f[np.searchsorted(c, 0.5)])


@pytest.fixture(scope="module")
def muscles():
    return make_population(1, 0)[0].muscles


def test_shaped_noise_has_unit_variance_and_the_folded_spectrum():
    fe = FrontEnd()
    x = shaped_noise(100_000, FS, np.array([1.5e-3]), fe, np.random.default_rng(0))[:, 0]
    assert x.var() == pytest.approx(1.0, rel=0.03)
    f, p = signal.welch(x, fs=FS, nperseg=512)
    expected = fe.folded_psd(lambda g: muap_psd(g, 1.5e-3), f, FS)
    assert median_frequency(f, p) == pytest.approx(median_frequency(f, expected), abs=2.0)
    # real MYO: median about 64 Hz, under 10 Hz about 5 % of the power (CALIBRATION.md)
    assert 55.0 <= median_frequency(f, p) <= 72.0
    assert p[f < 10].sum() / p.sum() < 0.08


def test_rms_follows_the_amplitude_law_and_force_follows_drive(muscles):
    gen = NoiseEmgGenerator()
    assert isinstance(gen, EmgGenerator)
    drive = np.full((40_000, 8), 0.5)
    out = gen.generate(drive, muscles, FrontEnd(), fs_hz=FS, rng=np.random.default_rng(1))
    expected = 0.5 ** muscles.array("amplitude_exponent")
    np.testing.assert_allclose(out.emg.std(axis=0), expected, rtol=0.04)
    np.testing.assert_allclose(out.force[1000:], 0.5, atol=1e-9)
    np.testing.assert_allclose(gen.steady_force(np.array([0.3]), muscles), [0.3])


def test_force_lags_the_emg_onset(muscles):
    drive = np.zeros((600, 8))
    drive[200:] = 0.6
    out = NoiseEmgGenerator().generate(drive, muscles, FrontEnd(), fs_hz=FS,
                                       rng=np.random.default_rng(2))
    assert np.all(out.emg[:200] == 0.0) and np.all(out.emg[200:210] != 0.0)
    onset = np.argmax(out.force > 0.01, axis=0)
    lag_s = (onset - 200) / FS
    assert np.all(lag_s >= muscles.array("emd_s") - 0.5 / FS)


def test_fatigue_lowers_median_frequency_and_raises_amplitude(muscles):
    # Checked at 1 kHz: at the MYO's 200 Hz, aliasing folds the compressed spectrum
    # back and can hide the fall of the median frequency (see docs/SUBJECTS.md).
    fs = 1000.0
    # a Gaussian carrier: the Laplace mixture adds a white part that would blur the shift
    tired = dataclasses.replace(muscles, fatigue_per_min=0.2, carrier_laplace=0.0)
    n = int(120 * fs)
    drive = np.full((n, 8), 0.5)
    out = NoiseEmgGenerator().generate(drive, tired, FrontEnd(), fs_hz=fs,
                                       rng=np.random.default_rng(3))
    early, late = out.emg[: n // 6, 6], out.emg[-n // 6:, 6]
    mf = [median_frequency(*signal.welch(x, fs=fs, nperseg=1024)) for x in (early, late)]
    freq, amp = fatigue_profile(n, fs, 0.2)
    assert freq[-1] == pytest.approx(0.6, abs=1e-3) and amp[-1] == pytest.approx(1.8, abs=1e-3)
    assert mf[1] / mf[0] == pytest.approx(np.mean(freq[-n // 6:]), rel=0.12)
    assert late.std() / early.std() == pytest.approx(
        np.mean(amp[-n // 6:]) / np.mean(amp[: n // 6]), rel=0.1)


def test_same_rng_gives_identical_output(muscles):
    drive = np.random.default_rng(0).random((2000, 8))
    a = NoiseEmgGenerator().generate(drive, muscles, FrontEnd(), fs_hz=FS,
                                     rng=np.random.default_rng(9))
    b = NoiseEmgGenerator().generate(drive, muscles, FrontEnd(), fs_hz=FS,
                                     rng=np.random.default_rng(9))
    np.testing.assert_array_equal(a.emg, b.emg)
    np.testing.assert_array_equal(a.force, b.force)


def test_laplace_mixture_keeps_the_power_and_makes_the_amplitude_heavy_tailed(muscles):
    drive = np.full((100_000, 8), 0.6)
    rng = np.random.default_rng(5)
    gauss = NoiseEmgGenerator().generate(
        drive, dataclasses.replace(muscles, carrier_laplace=0.0), FrontEnd(), fs_hz=200.0,
        rng=rng).emg[:, 6]
    laplace = NoiseEmgGenerator().generate(
        drive, dataclasses.replace(muscles, carrier_laplace=1.0), FrontEnd(), fs_hz=200.0,
        rng=rng).emg[:, 6]
    assert laplace.std() == pytest.approx(gauss.std(), rel=0.03)

    def kurtosis(x):
        return float(np.mean((x - x.mean()) ** 4) / x.var() ** 2)

    assert kurtosis(gauss) == pytest.approx(3.0, abs=0.15)  # Gaussian
    assert kurtosis(laplace) == pytest.approx(6.0, abs=0.6)  # Laplacian: 6
    # RMS over MAV: sqrt(pi / 2) = 1.25 for a Gaussian, sqrt(2) = 1.41 for a Laplacian
    assert gauss.std() / np.abs(gauss).mean() == pytest.approx(np.sqrt(np.pi / 2), rel=0.02)
    assert laplace.std() / np.abs(laplace).mean() == pytest.approx(np.sqrt(2.0), rel=0.03)
