"""The paper's SS / SS_KF estimator: recovery of known systems, AIC, modes, failures."""

from __future__ import annotations

import control
import numpy as np
import pytest
from est_synthetic import arx_state_space, simulate_arx

from estimation.errors import (
    ConstantInputError,
    EstimationInputError,
    InsufficientDataError,
    ModeError,
    UnstableModelError,
)
from estimation.order import select_order
from estimation.state_space import SSEstimator

DT = 0.125
SYSTEMS = {
    2: (np.array([1.5, -0.6]), np.array([0.3, 0.1, -0.2])),
    3: (np.array([2.2, -1.6, 0.38]), np.array([0.3, -0.2])),
    4: (np.array([2.0, -1.46, 0.5, -0.07]), np.array([0.2, 0.1])),
}


@pytest.mark.parametrize("order", [2, 3, 4])
def test_known_system_is_recovered(order: int) -> None:
    a, b = SYSTEMS[order]
    U, y = simulate_arx(a, b, 4000, noise_std=1e-3, rng=np.random.default_rng(order))
    est = SSEstimator(order=order, dt_s=DT).fit(U, y)
    A_true, B_true = arx_state_space(a, b, DT)
    # the first row (the force equation) is the identified dynamics; compare the
    # models through their step responses, which are scale-free across states
    assert np.sort_complex(np.linalg.eigvals(est.A_)) == pytest.approx(
        np.sort_complex(np.linalg.eigvals(A_true)), abs=2e-2)
    np.testing.assert_allclose(est.B_[0], B_true[0], atol=5e-3)
    np.testing.assert_allclose(est.A_[0], A_true[0], atol=2e-2 * np.abs(A_true[0]).max())
    true_dc = control.dcgain(control.ss(A_true, B_true, np.eye(1, order), 0, DT))
    np.testing.assert_allclose(control.dcgain(est.model_), true_dc, rtol=2e-2)
    assert est.stable_ and est.controllable_ and est.observable_


def test_noise_free_second_order_system_is_recovered_exactly() -> None:
    a, b = SYSTEMS[2]
    U, y = simulate_arx(a, b, 3000, noise_std=0.0, rng=np.random.default_rng(0))
    # a large P(0) makes the prior's pull towards theta(0) = 0.3 negligible
    est = SSEstimator(order=2, dt_s=DT, noise_regressor=False, p0=1e6).fit(U, y)
    A_true, B_true = arx_state_space(a, b, DT)
    np.testing.assert_allclose(est.A_, A_true, atol=1e-7)
    np.testing.assert_allclose(est.B_, B_true, atol=1e-7)


@pytest.mark.parametrize("order", [2, 3])
def test_aic_picks_the_true_order(order: int) -> None:
    a, b = SYSTEMS[order]
    U, y = simulate_arx(a, b, 3000, noise_std=1e-2, rng=np.random.default_rng(10 + order))
    sel = select_order(U, y, orders=range(1, 7), dt_s=DT)
    assert sel.order == order
    assert sel.orders.tolist() == [1, 2, 3, 4, 5, 6]
    # AIC = (1 + 2p/N) SSE with p = 2n + i counted the same way at every order
    np.testing.assert_allclose(sel.n_params, 2 * sel.orders + U.shape[1])
    np.testing.assert_allclose(sel.aic, (1 + 2 * sel.n_params / sel.n_obs) * sel.sse)


def test_model_attributes_and_kalman_quantities() -> None:
    a, b = SYSTEMS[2]
    U, y = simulate_arx(a, b, 1500, noise_std=1e-2, rng=np.random.default_rng(4))
    est = SSEstimator(order=2, dt_s=DT).fit(U, y)
    assert isinstance(est.model_, control.StateSpace) and est.model_.dt == DT
    assert est.Gamma_.shape == (2, 2) and est.C_.tolist() == [[1.0, 0.0]]
    np.testing.assert_allclose(est.Q_, est.Gamma_ @ np.diag(est.sigma_w2_) @ est.Gamma_.T,
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(est.predictor_gain_, est.A_ @ est.filter_gain_, atol=1e-12)
    assert np.max(np.abs(est.kalman_poles_)) < 1


def test_kalman_one_step_equals_the_paper_recursion() -> None:
    a, b = SYSTEMS[3]
    U, y = simulate_arx(a, b, 600, noise_std=1e-2, rng=np.random.default_rng(5))
    est = SSEstimator(order=3, dt_s=DT).fit(U, y)
    A, B, C, L = est.A_, est.B_, est.C_, est.predictor_gain_
    x = np.zeros(3)
    ref = np.zeros(len(y))
    for k in range(1, len(y)):  # eq. (16) and (17)
        x = (A - L @ C) @ x + B @ U[k - 1] + L[:, 0] * y[k - 1]
        ref[k] = (C @ x)[0]
    np.testing.assert_allclose(est.predict(U, y, mode="one_step"), ref, atol=1e-10)
    # free run: L = 0
    x = np.zeros(3)
    ref_free = np.zeros(len(y))
    for k in range(1, len(y)):
        x = A @ x + B @ U[k - 1]
        ref_free[k] = x[0]
    np.testing.assert_allclose(est.predict(U, mode="free_run"), ref_free, atol=1e-10)


def test_plain_ss_one_step_uses_measured_states() -> None:
    a, b = SYSTEMS[2]
    U, y = simulate_arx(a, b, 400, noise_std=1e-2, rng=np.random.default_rng(6))
    est = SSEstimator(order=2, kalman=False, dt_s=DT).fit(U, y)
    y_hat = est.predict(U, y, mode="one_step")
    k = np.arange(5, 400)
    x_prev = np.stack([y[k - 1], (y[k - 1] - y[k - 2]) / DT], axis=1)
    np.testing.assert_allclose(y_hat[k], x_prev @ est.A_[0] + U[k - 1] @ est.B_[0], atol=1e-10)


@pytest.mark.portable
@pytest.mark.parametrize("kalman", [True, False])
@pytest.mark.parametrize("mode", ["one_step", "free_run"])
def test_batch_prediction_equals_streaming(kalman: bool, mode: str) -> None:
    a, b = SYSTEMS[4]
    U, y = simulate_arx(a, b, 3000, noise_std=1e-2, rng=np.random.default_rng(7))
    est = SSEstimator(order=4, kalman=kalman, dt_s=DT).fit(U[:1500], y[:1500])
    batch = est.predict(U, y, mode=mode)
    stream = est.streaming(mode)
    out = [stream.step(U[0])] + [stream.step(U[k], y[k - 1]) for k in range(1, len(y))]
    np.testing.assert_allclose(out, batch, rtol=0, atol=1e-10 * max(1.0, np.abs(batch).max()))
    stream.reset()
    assert stream.step(U[0]) == out[0]


def test_one_step_stream_requires_the_force() -> None:
    a, b = SYSTEMS[2]
    U, y = simulate_arx(a, b, 300, noise_std=1e-2, rng=np.random.default_rng(8))
    stream = SSEstimator(order=2).fit(U, y).streaming("one_step")
    stream.step(U[0])
    with pytest.raises(ModeError, match="y_prev"):
        stream.step(U[1])
    with pytest.raises(ModeError, match="needs the measured force"):
        SSEstimator(order=2).fit(U, y).predict(U, mode="one_step")


def test_unstable_model_is_flagged_and_refused_open_loop() -> None:
    a = np.array([1.05])
    U, y = simulate_arx(a, np.array([0.5, 0.2]), 120, noise_std=1e-3,
                        rng=np.random.default_rng(9))
    est = SSEstimator(order=1).fit(U, y)
    assert not est.stable_
    with pytest.raises(UnstableModelError, match="unstable"):
        est.predict(U, mode="free_run")
    with pytest.raises(UnstableModelError):
        est.streaming("free_run")
    assert np.all(np.isfinite(est.predict(U, y, mode="one_step")))


def test_bad_inputs_raise_named_errors() -> None:
    rng = np.random.default_rng(11)
    U = rng.random((40, 3))
    y = rng.random(40)
    with pytest.raises(InsufficientDataError, match="at least"):
        SSEstimator(order=12).fit(U, y)
    U_nan = U.copy()
    U_nan[3, 1] = np.nan
    with pytest.raises(EstimationInputError, match="row 3, column 1"):
        SSEstimator(order=1).fit(U_nan, y)
    U_const = U.copy()
    U_const[:, 2] = 0.5
    with pytest.raises(ConstantInputError, match="column 2"):
        SSEstimator(order=1).fit(U_const, y)
    with pytest.raises(ModeError, match="mode"):
        SSEstimator(order=1).fit(U, y).predict(U, y, mode="two_step")


def test_same_data_gives_bit_identical_models() -> None:
    a, b = SYSTEMS[3]
    U, y = simulate_arx(a, b, 500, noise_std=1e-2, rng=np.random.default_rng(12))
    e1 = SSEstimator(order=3).fit(U, y)
    e2 = SSEstimator(order=3).fit(U, y)
    assert np.array_equal(e1.A_, e2.A_) and np.array_equal(e1.predictor_gain_, e2.predictor_gain_)


@pytest.mark.parametrize("kalman", [True, False])
@pytest.mark.parametrize("mode", ["one_step", "free_run"])
@pytest.mark.parametrize("n_samples", [1, 3, 2000])
def test_folded_scaling_equals_normalized_batch_and_stream(kalman: bool, mode: str,
                                                           n_samples: int) -> None:
    """``predict_scaled`` (scaling folded into the filter) = normalize, predict, rescale."""
    from estimation.normalize import MinMaxScaling

    a, b = SYSTEMS[4]
    U, y = simulate_arx(a, b, 3000, noise_std=1e-2, rng=np.random.default_rng(11))
    # raw units: features with offsets and spans far from 0..1, force in N
    U_raw = 3.0 + 40.0 * U * np.array([1.0, 0.5])
    y_raw = 2.0 + 25.0 * y
    scaling = MinMaxScaling.fit(U_raw[:1500], y_raw[:1500])
    est = SSEstimator(order=4, kalman=kalman, dt_s=DT).fit(
        scaling.transform_u(U_raw[:1500]), scaling.transform_y(y_raw[:1500]))
    U_raw, y_raw = U_raw[1000:1000 + n_samples], y_raw[1000:1000 + n_samples]
    folded = est.predict_scaled(U_raw, y_raw, mode=mode, scaling=scaling)
    normalized = scaling.inverse_y(est.predict(scaling.transform_u(U_raw),
                                               scaling.transform_y(y_raw), mode=mode))
    scale = np.abs(normalized).max()
    np.testing.assert_allclose(folded, normalized, rtol=0, atol=1e-12 * scale)
    stream = est.streaming(mode, scaling=scaling)
    out = [stream.step(U_raw[0])] + [stream.step(U_raw[k], y_raw[k - 1])
                                     for k in range(1, n_samples)]
    np.testing.assert_allclose(folded, out, rtol=0, atol=1e-12 * scale)
