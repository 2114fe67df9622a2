"""Metrics: hand-computed values, the R^2 / NRMSE identity, scikit-learn equivalence."""

from __future__ import annotations

import numpy as np
import pytest
import sklearn.metrics
from sklearn.preprocessing import MinMaxScaler

from estimation.errors import EstimationInputError
from estimation.metrics import nrmse_fit, r2_score, rmse, total_variation_rate
from estimation.normalize import MinMaxScaling


def test_hand_computed_values() -> None:
    y = np.array([1.0, 2.0, 3.0, 4.0])  # mean 2.5, SST = 5
    y_hat = np.array([1.0, 2.0, 3.0, 5.0])  # SSE = 1
    assert r2_score(y, y_hat) == pytest.approx(1 - 1 / 5)
    assert nrmse_fit(y, y_hat) == pytest.approx(1 - np.sqrt(1 / 5))
    assert rmse(y, y_hat) == pytest.approx(0.5)
    # perfect and mean predictions
    assert r2_score(y, y) == 1.0 and nrmse_fit(y, y) == 1.0
    assert r2_score(y, np.full(4, 2.5)) == pytest.approx(0.0)
    # worse than the mean: negative
    assert r2_score(y, y[::-1]) == pytest.approx(1 - 20 / 5)


def test_explicit_mean_is_used() -> None:
    y = np.array([1.0, 2.0, 3.0, 4.0])
    y_hat = y + 1.0  # SSE = 4; about mean 0: SST = 30
    assert r2_score(y, y_hat, y_mean=0.0) == pytest.approx(1 - 4 / 30)
    assert nrmse_fit(y, y_hat, y_mean=0.0) == pytest.approx(1 - np.sqrt(4 / 30))


def test_nrmse_equals_one_minus_sqrt_of_one_minus_r2() -> None:
    rng = np.random.default_rng(0)
    y = rng.normal(size=500).cumsum()
    y_hat = y + rng.normal(scale=2.0, size=500)
    r2 = r2_score(y, y_hat)
    assert nrmse_fit(y, y_hat) == pytest.approx(1 - np.sqrt(1 - r2), abs=1e-14)


def test_metrics_are_invariant_to_joint_affine_scaling() -> None:
    rng = np.random.default_rng(1)
    y, y_hat = rng.random(100), rng.random(100)
    assert r2_score(40 * y + 3, 40 * y_hat + 3) == pytest.approx(r2_score(y, y_hat), abs=1e-12)
    assert rmse(40 * y, 40 * y_hat) == pytest.approx(40 * rmse(y, y_hat))


def test_total_variation_rate() -> None:
    s = np.array([0.0, 1.0, 0.0, 2.0])  # TV = 1 + 1 + 2 = 4 over 3 intervals of 0.5 s
    assert total_variation_rate(s, 0.5) == pytest.approx(4 / 1.5)
    assert total_variation_rate(np.full(10, 3.0), 0.1) == 0.0


def test_bad_inputs() -> None:
    with pytest.raises(EstimationInputError, match="equal length"):
        r2_score(np.ones(3), np.ones(4))
    with pytest.raises(EstimationInputError, match="constant"):
        r2_score(np.ones(3), np.zeros(3))
    with pytest.raises(EstimationInputError, match="finite"):
        rmse(np.array([1.0, np.nan]), np.ones(2))
    with pytest.raises(EstimationInputError, match="dt_s"):
        total_variation_rate(np.ones(3), 0.0)


def _paper_r2(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Eq. (21) as written, the reference for the scikit-learn computation."""
    return 1.0 - np.sum((y - y_hat) ** 2) / np.sum((y - np.mean(y)) ** 2)


def test_r2_and_rmse_are_scikit_learn_and_equal_the_paper_formula(monkeypatch) -> None:
    rng = np.random.default_rng(7)
    for scale, n in ((1.0, 10), (40.0, 500), (1e-3, 3000)):
        y = scale * rng.random(n).cumsum()
        y_hat = y + scale * rng.normal(scale=0.3, size=n)
        assert abs(r2_score(y, y_hat) - _paper_r2(y, y_hat)) <= 1e-12
        assert abs(rmse(y, y_hat) - np.sqrt(np.mean((y - y_hat) ** 2))) <= 1e-12 * scale
    calls = []
    real = sklearn.metrics.r2_score
    monkeypatch.setattr(sklearn.metrics, "r2_score",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    r2_score(y, y_hat)
    assert calls == [1]
    r2_score(y, y_hat, y_mean=0.0)  # R^2 about a given mean: not in scikit-learn
    assert calls == [1]


def test_min_max_ranges_equal_scikit_learn() -> None:
    rng = np.random.default_rng(3)
    U, y = rng.gamma(2.0, size=(400, 9)), 40 * rng.random(400)
    ours = MinMaxScaling.fit(U, y)
    ref = MinMaxScaler().fit(U)
    np.testing.assert_array_equal(ours.u_min, ref.data_min_)
    np.testing.assert_array_equal(ours.u_span, ref.data_range_)
    np.testing.assert_allclose(ours.transform_u(U), ref.transform(U), rtol=0, atol=1e-12)
    y_ref = MinMaxScaler().fit(y[:, None])
    np.testing.assert_allclose(ours.transform_y(y), y_ref.transform(y[:, None])[:, 0], atol=1e-12)
