"""``scenarios.stats``: the closed-form Student t quantile and chi-square tail against scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from scenarios.stats import chi2_sf, mean_interval, t_quantile


@pytest.mark.parametrize("df", [1, 2, 3, 4, 5, 8, 17, 30, 101])
@pytest.mark.parametrize("p", [0.025, 0.5, 0.8, 0.975, 0.995])
def test_t_quantile_matches_scipy(p, df):
    assert t_quantile(p, df) == pytest.approx(stats.t.ppf(p, df), rel=1e-10, abs=1e-12)


@pytest.mark.parametrize("dof", [1, 2, 3, 4, 6, 9, 12, 31])
@pytest.mark.parametrize("x", [0.0, 0.05, 1.0, 3.84, 10.0, 40.0, 150.0])
def test_chi2_sf_matches_scipy(x, dof):
    assert chi2_sf(x, dof) == pytest.approx(stats.chi2.sf(x, dof), rel=1e-10, abs=1e-300)


def test_mean_interval_is_the_student_t_interval():
    values = [1.0, 2.5, 2.0, 4.0, 3.5]
    mean, low, high = mean_interval(values)
    half = stats.t.ppf(0.975, 4) * np.std(values, ddof=1) / np.sqrt(5)
    assert (mean, low, high) == pytest.approx((np.mean(values), np.mean(values) - half,
                                               np.mean(values) + half), rel=1e-12)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: t_quantile(1.0, 3), "0 < p < 1"),
    (lambda: t_quantile(0.5, 0), "df >= 1"),
    (lambda: chi2_sf(1.0, 0), "dof >= 1"),
])
def test_bad_arguments_say_what_was_expected(call, message):
    with pytest.raises(ValueError, match=message):
        call()
