"""Baselines and the latent Kalman decoder: known answers, seeding, batch == stream."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.baselines import LDAQPF, MLPBaseline, NARXBaseline, Persistence, SingleFeatureLinear
from estimation.baselines.narx import narx_regressors
from estimation.errors import ConstantInputError, ModeError
from estimation.latent_kf import LatentKalman
from estimation.metrics import r2_score


def _static_data(seed: int, n: int = 400):
    rng = np.random.default_rng(seed)
    force = np.clip(np.abs(np.sin(np.linspace(0, 12, n))) + 0.02 * rng.normal(size=n), 0, None)
    # 3 channels x (mav, rms, wl), each roughly linear in force
    gains = rng.uniform(0.5, 1.5, size=9)
    U = force[:, None] * gains + 0.02 * rng.normal(size=(n, 9)) + 0.1
    return U, force


def test_single_feature_fit_equals_least_squares_on_its_columns() -> None:
    U, y = _static_data(0)
    est = SingleFeatureLinear(feature="rms").fit(U, y)
    assert est.columns_.tolist() == [1, 4, 7]
    design = np.hstack([np.ones((len(y), 1)), U[:, [1, 4, 7]]])
    ref = design @ np.linalg.lstsq(design, y, rcond=None)[0]
    np.testing.assert_allclose(est.predict(U), ref, atol=1e-12)
    assert np.count_nonzero(est.coef_) == 3


def test_lda_qpf_recovers_a_quadratic_relation() -> None:
    rng = np.random.default_rng(1)
    z = rng.uniform(0, 1, size=600)
    U = np.outer(z, rng.uniform(0.5, 1.0, size=9)) + 0.01 * rng.normal(size=(600, 9))
    y = 0.2 + 0.5 * z + 0.3 * z**2
    est = LDAQPF().fit(U, y)
    assert r2_score(y, est.predict(U)) > 0.99
    assert est.poly_.shape == (3,)


def test_lda_qpf_needs_two_force_levels() -> None:
    U, _ = _static_data(2)
    with pytest.raises(ConstantInputError):
        LDAQPF().fit(U, np.full(len(U), 0.3))


def test_persistence_is_the_previous_sample() -> None:
    U, y = _static_data(3, 20)
    est = Persistence().fit(U, y)
    np.testing.assert_array_equal(est.predict(U, y), np.concatenate([[0.0], y[:-1]]))
    with pytest.raises(ModeError):
        est.predict(U, mode="free_run")


def test_mlp_is_seeded_and_learns() -> None:
    U, y = _static_data(4)
    a = MLPBaseline(max_epochs=200, random_state=np.random.default_rng(5)).fit(U, y)
    b = MLPBaseline(max_epochs=200, random_state=np.random.default_rng(5)).fit(U, y)
    c = MLPBaseline(max_epochs=200, random_state=np.random.default_rng(6)).fit(U, y)
    assert np.array_equal(a.predict(U), b.predict(U))
    assert not np.array_equal(a.predict(U), c.predict(U))
    assert r2_score(y, a.predict(U)) > 0.9
    assert 1 <= a.n_epochs_ <= 200
    net = a.net_
    assert net.activation == "logistic" and net.hidden_layer_sizes == (4,)
    assert net.batch_size == 1 and net.beta_1 == 0.0  # RMSprop-equivalent Adam


def test_narx_regressors_layout() -> None:
    U = np.arange(10.0).reshape(5, 2)
    y = np.arange(5.0) + 100
    R = narx_regressors(U, y, 2)
    # row 3: u(3), u(2), u(1), y(2), y(1)
    np.testing.assert_array_equal(R[3], [6, 7, 4, 5, 2, 3, 102, 101])
    np.testing.assert_array_equal(R[0], [0, 1, 0, 0, 0, 0, 0, 0])


@pytest.mark.parametrize("mode", ["one_step", "free_run"])
def test_narx_batch_equals_stream(mode: str) -> None:
    U, y = _static_data(7, 200)
    est = NARXBaseline(delays=3, max_epochs=30, random_state=1).fit(U, y)
    batch = est.predict(U, y, mode=mode)
    stream = est.streaming(mode)
    out = [stream.step(U[0])] + [stream.step(U[k], y[k - 1]) for k in range(1, len(y))]
    np.testing.assert_allclose(out, batch, atol=1e-10)


def test_latent_kalman_recovers_dynamics_and_tracks_force() -> None:
    rng = np.random.default_rng(8)
    n = 4000
    x = np.zeros(n)
    for k in range(1, n):  # AR(1) latent force
        x[k] = 0.95 * x[k - 1] + 0.05 * rng.normal()
    H = rng.uniform(0.5, 1.5, size=9)
    U = 0.5 + np.outer(x, H) + 0.05 * rng.normal(size=(n, 9))
    y = 0.5 + x
    est = LatentKalman().fit(U, y)
    assert est.a_ == pytest.approx(0.95, abs=0.02)
    np.testing.assert_allclose(est.H_[:, 0], H, rtol=0.05)
    y_hat = est.predict(U)
    assert r2_score(y, y_hat) > 0.95
    # independent: a time-varying Kalman filter converges to the steady-state output
    P, xh, ref = 1.0, 0.0, np.zeros(n)
    Z = U - est.z_mean_
    Hc = est.H_
    for k in range(n):
        xp, Pp = est.a_ * xh, est.a_**2 * P + est.W_
        S = Pp * (Hc @ Hc.T) + est.Qz_
        K = Pp * np.linalg.solve(S, Hc)[:, 0]
        xh = xp + K @ (Z[k] - Hc[:, 0] * xp)
        P = (1 - K @ Hc[:, 0]) * Pp
        ref[k] = xh + est.x_mean_
    np.testing.assert_allclose(y_hat[200:], ref[200:], atol=1e-8)


@pytest.mark.portable
@pytest.mark.parametrize("hidden", [(4,), (8, 5)])
def test_one_forward_pass_serves_a_regressor_and_stored_weights(hidden) -> None:
    # MLPForward is the stream of mlp and narx (a fitted regressor) and of every network of
    # transfer_mlp and adaptive_mlp (stored weights): both give scikit-learn's numbers
    from portable import assert_close_across_paths
    from sklearn.neural_network import MLPRegressor

    from estimation.baselines.mlp import MLPForward, fit_quietly
    from estimation.pretrained_store import Network

    U, y = _static_data(7, n=200)
    net = MLPRegressor(hidden_layer_sizes=hidden, activation="logistic", max_iter=30,
                       random_state=0)
    fit_quietly(net, U, y)
    stored = Network(tuple(net.coefs_), tuple(net.intercepts_))
    batch = net.predict(U)
    for forward in (MLPForward(net), MLPForward(stored)):
        assert_close_across_paths([forward(u) for u in U], batch)
    assert_close_across_paths(stored.predict(U), batch)
