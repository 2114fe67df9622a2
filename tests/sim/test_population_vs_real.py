"""The default virtual population against real MYO + FSR recordings (docs/SUBJECTS.md's table).

Statistics are computed by :func:`sim.user.emg_stats.emg_statistics` exactly as on the
real recordings: rest = quietest 20 % of 400 ms windows, active = windows in the
top 30 % of the force range, RMS of channels 6-8. The real figures (median and
range over 10 subjects) are in :data:`sim.user.emg_stats.REAL_RANGES`. Every virtual
subject must fall inside the real range (widened by a small margin for a
10-subject draw), the population median near the real median, and the spread
across subjects must be as wide as real people's.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimation.features import extract_features
from sim.user.emg_stats import REAL_RANGES, STAT_KEYS, emg_statistics, recording_statistics
from sim.user.subjects import GENERATORS, make_population

#: per-subject bounds: the real min-max, widened by a margin (10-subject draws vary)
SUBJECT_BOUNDS = {
    "rest_std_lsb": (0.9, 5.0),
    "active_rms_lsb": (10.0, 70.0),
    "median_frequency_hz": (60.0, 73.0),
    "adjacent_abs_r": (0.25, 0.75),
    "saturated_fraction": (0.0, 1.5e-2),
    "flexor_extensor_ratio": (0.30, 1.30),
}
#: population-median bounds around the real median
MEDIAN_BOUNDS = {
    "rest_std_lsb": (1.7, 3.3),
    "active_rms_lsb": (20.0, 45.0),
    "median_frequency_hz": (63.0, 70.0),
    "adjacent_abs_r": (0.38, 0.55),
    "saturated_fraction": (5e-5, 3e-3),
    "flexor_extensor_ratio": (0.6, 1.15),
}


def single_feature_r2(recording, feature: str) -> float:
    """Validation R^2 of a least-squares fit (with intercept) on one feature of ch 6-8."""
    fs = extract_features(recording, channels=(6, 7, 8))
    half = fs.n_windows // 2
    x = np.column_stack([fs.columns(feature), np.ones(fs.n_windows)])
    theta, *_ = np.linalg.lstsq(x[:half], fs.y[:half], rcond=None)
    y = fs.y[half:]
    return float(1.0 - np.sum((y - x[half:] @ theta) ** 2) / np.sum((y - y.mean()) ** 2))


@pytest.fixture(scope="module", params=GENERATORS)
def stats(request):
    recs = [s.paper_session(generator=request.param) for s in make_population(10, seed=0)]
    rows = [recording_statistics(r) for r in recs]
    return {k: np.array([row[k] for row in rows]) for k in STAT_KEYS}, recs


def test_bounds_contain_the_real_figures():
    for key in STAT_KEYS:
        median, lo, hi = REAL_RANGES[key]
        assert SUBJECT_BOUNDS[key][0] <= lo and hi <= SUBJECT_BOUNDS[key][1]
        assert MEDIAN_BOUNDS[key][0] <= median <= MEDIAN_BOUNDS[key][1]


@pytest.mark.parametrize("key", STAT_KEYS)
def test_every_subject_inside_the_real_range(stats, key):
    values, recs = stats
    lo, hi = SUBJECT_BOUNDS[key]
    if key == "saturated_fraction" and recs[0].metadata["generator"] == "motor_units":
        hi = 2.0e-2  # its strongest subject clips 1.6 % (real max 0.9 %): a known gap
    assert np.all((values[key] >= lo) & (values[key] <= hi)), values[key]


@pytest.mark.parametrize("key", STAT_KEYS)
def test_population_median_near_the_real_median(stats, key):
    values, _ = stats
    lo, hi = MEDIAN_BOUNDS[key]
    assert lo <= np.median(values[key]) <= hi, values[key]


def test_subjects_differ_as_much_as_real_people(stats):
    values, _ = stats
    rms = values["active_rms_lsb"]
    assert rms.max() / rms.min() >= 3.0  # real: 63 / 11.5 = 5.5x
    rest = values["rest_std_lsb"]
    assert rest.max() / rest.min() >= 2.0  # real: 4.7x
    ratio = values["flexor_extensor_ratio"]
    assert ratio.min() <= 0.7 and ratio.max() >= 0.9  # co-contraction varies; real 0.36-1.19
    assert np.count_nonzero(values["saturated_fraction"] > 0) >= 5  # saturation is common


def test_single_feature_difficulty_kept(stats):
    _, recs = stats
    r2 = [single_feature_r2(rec, "mav") for rec in recs]
    assert 0.70 <= np.mean(r2) <= 0.88  # paper Fig. 7A: 0.796


def test_statistics_definitions_on_a_constructed_signal():
    rng = np.random.default_rng(3)
    fs, n = 200.0, 4000
    force = np.zeros(n)
    force[2000:3000] = 10.0  # the active part: top 30 % of the force range
    emg = rng.normal(0.0, 2.0, (n, 8))
    emg[2000:3000, 5:] = rng.normal(0.0, 30.0, (1000, 3))
    emg[2000:3000, 2:5] = rng.normal(0.0, 15.0, (1000, 3))
    emg[2500, 0] = 127
    s = emg_statistics(np.clip(np.rint(emg), -128, 127), force, fs)
    assert s["rest_std_lsb"] == pytest.approx(2.0, rel=0.1)
    assert s["active_rms_lsb"] == pytest.approx(30.0, rel=0.1)
    assert s["flexor_extensor_ratio"] == pytest.approx(2.0, rel=0.15)
    assert s["adjacent_abs_r"] < 0.15  # independent channels
    assert 40.0 <= s["median_frequency_hz"] <= 60.0  # white noise: fs / 4
    assert s["saturated_fraction"] >= 1 / emg.size


def test_statistics_reject_wrong_shapes():
    with pytest.raises(ValueError, match="expected shape"):
        emg_statistics(np.zeros((100, 3)), np.zeros(100), 200.0)
