"""The default population against real MYO statistics and the paper's Fig. 7A (CALIBRATION.md).

Every figure is measured on ``make_population(10, seed=0)``'s paper sessions and
recomputed here independently of the generators (Welch spectra, correlations,
a least-squares fit with intercept, R^2 = 1 - SSE/SST on the validation half).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from estimation.features import extract_features
from sim.user.subjects import GENERATORS, make_population

FLEXORS = [5, 6, 7]  # channels 6, 7, 8 (0-based)


@pytest.fixture(scope="module", params=GENERATORS)
def sessions(request):
    return [s.paper_session(generator=request.param) for s in make_population(10, seed=0)]


def rest_mask(rec) -> np.ndarray:
    return (rec.intent == 0.0) & (rec.intent_force_n < 1e-3)


def active_mask(rec) -> np.ndarray:
    return rec.intent > 0.15


def test_rest_noise_matches_the_myo(sessions):
    for rec in sessions:
        rest = rec.emg[rest_mask(rec)].astype(float)
        assert 1.0 <= rest.std() <= 4.7  # real recordings: 1.0-4.7 LSB (docs/SUBJECTS.md)
    within = [np.mean(np.abs(rec.emg[rest_mask(rec)]) <= 1) for rec in sessions]
    assert 0.30 <= np.median(within) <= 0.75  # one real MYO at 1.9 LSB: 55 %


def test_active_rms_at_medium_force_on_flexor_channels(sessions):
    per_channel = []
    for rec in sessions:
        levels = np.array(rec.metadata["profile"]["levels"])
        medium = levels[np.argmin(np.abs(levels - 0.5))]  # the squeeze nearest 50 % MVC
        hold = np.abs(rec.intent - medium) < 1e-9
        rms = np.sqrt(np.mean(rec.emg[hold][:, FLEXORS].astype(float) ** 2, axis=0))
        per_channel.append(rms)
    per_channel = np.array(per_channel)
    # subjects differ about 5x in sEMG size (real active RMS 11.5-63 LSB, docs/SUBJECTS.md)
    assert np.all(per_channel.mean(axis=1) >= 5.0) and np.all(per_channel.mean(axis=1) <= 45.0)
    assert np.median(per_channel) <= 30.0 and per_channel.min() >= 4.0
    assert per_channel.max() <= 60.0


def test_spectrum_after_aliasing(sessions):
    for rec in sessions:
        x = rec.emg[active_mask(rec)].astype(float)
        f, p = signal.welch(x, fs=rec.fs_hz, nperseg=256, axis=0)
        p = p.sum(axis=1)
        share = {band: p[(f >= band[0]) & (f < band[1])].sum() / p.sum()
                 for band in ((0, 10), (20, 50), (50, 80), (80, 101))}
        median = f[np.searchsorted(np.cumsum(p) / p.sum(), 0.5)]
        assert 45.0 <= median <= 80.0  # real about 64 Hz
        assert share[(0, 10)] <= 0.10  # real 5 %
        assert 0.15 <= share[(20, 50)] <= 0.35  # real 25 %
        assert 0.27 <= share[(50, 80)] <= 0.47  # real 37 %
        assert 0.16 <= share[(80, 101)] <= 0.40  # real 26 %


#: Largest share of samples at a rail: real recordings 9e-5 to 9e-3. The motor-unit
#: generator's strongest subject reaches 1.6 % (its spiky sum of large late-recruited
#: units clips more than real sEMG of the same RMS): a known gap of that generator.
RAIL_LIMIT = {"noise": 0.015, "motor_units": 0.02}


def test_saturation_and_snr(sessions):
    for rec in sessions:
        at_rail = int(np.count_nonzero((rec.emg == 127) | (rec.emg == -128)))
        assert at_rail / rec.emg.size < RAIL_LIMIT[rec.metadata["generator"]]
        assert rec.metadata["n_saturated"] <= at_rail  # clipped samples sit on a rail
        active = rec.emg[active_mask(rec)][:, FLEXORS].astype(float)
        rest = rec.emg[rest_mask(rec)][:, FLEXORS].astype(float)
        snr_db = 10 * np.log10(np.mean(active**2) / np.mean(rest**2))
        assert 8.0 <= snr_db <= 32.0  # real active RMS 11.5-63 LSB over rest 1.0-4.7 LSB


def test_crosstalk_correlation_between_channels(sessions):
    adjacent, two_apart = [], []
    for rec in sessions:
        c = np.corrcoef(rec.emg[active_mask(rec)].astype(float).T)
        adjacent.append(np.mean([c[i, (i + 1) % 8] for i in range(8)]))
        two_apart.append(np.mean([c[i, (i + 2) % 8] for i in range(8)]))
    assert np.all((np.array(adjacent) >= 0.2) & (np.array(adjacent) <= 0.6))  # real 0.38
    assert np.all(np.array(two_apart) < np.array(adjacent))  # real 0.20


def single_feature_r2(recording, feature: str) -> float:
    """Validation R^2 of a least-squares fit (with intercept) on one feature of ch 6-8."""
    fs = extract_features(recording, channels=(6, 7, 8))
    n = fs.n_windows
    half = n // 2
    x = np.column_stack([fs.columns(feature), np.ones(n)])
    theta, *_ = np.linalg.lstsq(x[:half], fs.y[:half], rcond=None)
    y = fs.y[half:]
    sse = np.sum((y - x[half:] @ theta) ** 2)
    return float(1.0 - sse / np.sum((y - y.mean()) ** 2))


@pytest.mark.parametrize("feature", ["mav", "rms", "wl"])
def test_single_feature_linear_fit_is_as_hard_as_in_the_paper(sessions, feature):
    r2 = [single_feature_r2(rec, feature) for rec in sessions]
    # paper Fig. 7A: 0.796 +/- 0.061; the two-round sessions of the real recordings (docs/results/)
    # put the strongest squeeze in both halves, which the virtual channels 6-8 exploit more
    # than real ones (0.86-0.89 here): a known gap, see docs/SUBJECTS.md
    assert 0.70 <= np.mean(r2) <= 0.90
    assert np.median(r2) >= 0.6


@pytest.mark.parametrize("feature", ["mav", "wl"])
def test_single_feature_difficulty_holds_over_session_draws(feature):
    # One draw of 10 sessions varies by about 0.04 in mean R^2 (noise generator);
    # the band must hold for the expected value, estimated over several draws.
    population = make_population(10, seed=0)
    means = []
    for draw in range(4):
        rngs = np.random.SeedSequence([draw, 17]).spawn(len(population))
        sessions = [s.paper_session(rng=np.random.default_rng(g))
                    for s, g in zip(population, rngs, strict=True)]
        means.append(np.mean([single_feature_r2(rec, feature) for rec in sessions]))
    assert 0.72 <= np.mean(means) <= 0.86, means
