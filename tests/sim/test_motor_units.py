"""Fuglevand motor-unit pools: thresholds, rate coding, discharge statistics, twitches, sEMG."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from sim.user.armband import FrontEnd
from sim.user.emg import EmgGenerator
from sim.user.motor_units import MotorUnitEmgGenerator, MotorUnitError, saturating_gain
from sim.user.subjects import make_population

FS = 200.0


@pytest.fixture(scope="module")
def muscles():
    return make_population(1, 0)[0].muscles


def test_pool_follows_fuglevand_1993():
    g = MotorUnitEmgGenerator()
    rte = g.thresholds()
    assert rte.size == 120 and rte[-1] == pytest.approx(30.0)
    assert rte[0] == pytest.approx(np.exp(np.log(30.0) / 120))
    assert g.peak_rates_hz()[[0, -1]] == pytest.approx([35.0, 25.0])
    assert g.twitch_forces()[-1] / g.twitch_forces()[0] == pytest.approx(100.0 ** (119 / 120))
    t = g.contraction_times_s()
    assert t.max() == pytest.approx(0.090) and t.min() == pytest.approx(0.030)
    assert np.all(np.diff(t) <= 0)  # bigger units twitch faster
    assert g.max_excitation == pytest.approx(30.0 + (25.0 - 8.0))
    e = rte[10] + 2.0
    rates = g.rates_hz(np.array([e]))[0]
    on = rte <= e
    np.testing.assert_allclose(rates[on], 8.0 + 1.0 * (e - rte[on]))  # 8 Hz + 1 Hz/unit
    assert rates[10] == pytest.approx(10.0) and np.all(rates[~on] == 0.0)


def test_saturating_gain_closed_form():
    ref = (1 - np.exp(-2 * 0.4**3)) / 0.4
    assert saturating_gain(np.array([0.1, 0.4]))[0] == 1.0
    assert saturating_gain(np.array([0.4]))[0] == pytest.approx(1.0)
    assert saturating_gain(np.array([1.0]))[0] == pytest.approx((1 - np.exp(-2.0)) / ref)


def test_discharge_rate_and_isi_variability_at_constant_excitation():
    g = MotorUnitEmgGenerator(isi_cv=0.15)
    e = np.full(int(60 * FS), 12.0)
    unit, t, isi = g._discharges(e, FS, np.random.default_rng(0))
    expected = g.rates_hz(np.array([12.0]))[0]
    for u in (0, 20, 50):
        mine = t[unit == u]
        assert mine.size / 60.0 == pytest.approx(expected[u], rel=0.03)
        intervals = np.diff(mine)
        assert 0.12 <= intervals.std() / intervals.mean() <= 0.18
    assert not np.any(unit > np.flatnonzero(g.thresholds() <= 12.0).max())


def test_single_twitch_matches_the_closed_form():
    g = MotorUnitEmgGenerator()
    u, t_spk = 60, 0.0123
    n = 100
    f = g._twitch_sum(np.array([u]), np.array([t_spk]), np.array([np.inf]), n, FS)
    p, big_t = g.twitch_forces()[u], g.contraction_times_s()[u]
    tau = np.arange(n) / FS - t_spk
    expected = np.where(tau > 0, p * tau / big_t * np.exp(1 - tau / big_t), 0.0)
    np.testing.assert_allclose(f, expected, atol=1e-9 * p)
    assert f.max() <= p


def test_steady_force_and_emg_are_normalized_at_full_drive(muscles):
    g = MotorUnitEmgGenerator()
    assert isinstance(g, EmgGenerator)
    out = g.generate(np.full((int(8 * FS), 8), 1.0), muscles, FrontEnd(), fs_hz=FS,
                     rng=np.random.default_rng(1))
    steady = slice(int(2 * FS), None)
    np.testing.assert_allclose(out.force[steady].mean(axis=0), 1.0, rtol=0.05)
    np.testing.assert_allclose(out.emg[steady].std(axis=0), 1.0, rtol=0.15)
    mid = g.steady_force(np.full(8, 0.5), muscles)
    half = g.generate(np.full((int(8 * FS), 8), 0.5), muscles, FrontEnd(), fs_hz=FS,
                      rng=np.random.default_rng(2))
    np.testing.assert_allclose(half.force[steady].mean(axis=0), mid, rtol=0.05)


def test_emg_spectrum_after_decimation_is_myo_like(muscles):
    g = MotorUnitEmgGenerator()
    out = g.generate(np.full((int(20 * FS), 8), 0.6), muscles, FrontEnd(), fs_hz=FS,
                     rng=np.random.default_rng(3))
    f, p = signal.welch(out.emg[400:], fs=FS, nperseg=256, axis=0)
    p = p.sum(axis=1)
    median = f[np.searchsorted(np.cumsum(p) / p.sum(), 0.5)]
    assert 45.0 <= median <= 80.0


def test_force_and_emg_come_from_the_same_units(muscles):
    drive = np.zeros((int(10 * FS), 8))
    drive[int(2 * FS): int(7 * FS)] = 0.7
    out = MotorUnitEmgGenerator().generate(drive, muscles, FrontEnd(), fs_hz=FS,
                                           rng=np.random.default_rng(4))
    # silent before the drive (MUAPs are centred on their discharge: allow 50 ms)
    assert np.all(out.force[: int(2 * FS)] == 0.0)
    assert np.abs(out.emg[: int(1.95 * FS)]).max() < 1e-9
    assert out.info["spikes_per_muscle"][0] > 0
    env = np.convolve(np.abs(out.emg[:, 6]), np.ones(40) / 40, mode="same")
    assert np.corrcoef(env, out.force[:, 6])[0, 1] > 0.8


def test_determinism_and_settings_validation(muscles):
    g = MotorUnitEmgGenerator(n_units=40)
    drive = np.full((400, 8), 0.4)
    a = g.generate(drive, muscles, FrontEnd(), fs_hz=FS, rng=np.random.default_rng(5))
    b = g.generate(drive, muscles, FrontEnd(), fs_hz=FS, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a.emg, b.emg)
    with pytest.raises(MotorUnitError, match="must be a positive integer, found 2000.0 / 300.0"):
        g.generate(drive, muscles, FrontEnd(), fs_hz=300.0, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="isi_cv must be in"):
        MotorUnitEmgGenerator(isi_cv=0.7)
