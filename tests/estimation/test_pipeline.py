"""Registry and pipeline: every estimator streams what it predicts, in newtons."""

from __future__ import annotations

import numpy as np
import pytest
from est_synthetic import toy_recording

from estimation.errors import ConstantInputError
from estimation.features import extract_features
from estimation.pipeline import ForcePipeline
from estimation.registry import ESTIMATOR_NAMES, UnknownEstimatorError, make_estimator
from estimation.state_space import SSEstimator

FAST = {"mlp": {"max_epochs": 20, "random_state": 0},
        "narx": {"max_epochs": 20, "random_state": 0}}


@pytest.fixture(scope="module")
def features():
    return extract_features(toy_recording(seed=1), channels=(6, 7, 8))


def test_registry_names_and_unknown_name() -> None:
    assert set(ESTIMATOR_NAMES) == {"ss_kf", "ss", "mlp", "narx", "lda_qpf", "latent_kf",
                                    "persistence", "features_mav", "features_rms",
                                    "features_wl", "ridge", "gbt", "ss_sim", "transfer_mlp",
                                    "adaptive_mlp"}
    with pytest.raises(UnknownEstimatorError, match="ss_kf, ss, mlp"):
        make_estimator("kalman")
    assert isinstance(make_estimator("ss_kf", normalize=False), SSEstimator)
    assert make_estimator("ss", normalize=False).kalman is False


@pytest.mark.parametrize("name", ESTIMATOR_NAMES)
def test_stream_in_newtons_equals_batch_prediction(features, name: str) -> None:
    X, y = features.X, features.y
    n_id = len(y) // 2
    pipe = make_estimator(name, **FAST.get(name, {})).fit(X[:n_id], y[:n_id])
    assert isinstance(pipe, ForcePipeline)
    for mode in pipe.modes:
        batch = pipe.predict(X, y, mode=mode)
        stream = pipe.streaming(mode)
        stream.reset()
        out = [stream.step(X[0])] + [stream.step(X[k], float(y[k - 1])) for k in range(1, len(y))]
        np.testing.assert_allclose(out, batch, rtol=0, atol=1e-9 * np.abs(batch).max(),
                                   err_msg=f"{name} {mode}")


def test_free_run_never_needs_the_force(features) -> None:
    X, y = features.X, features.y
    for name in ("ss_kf", "latent_kf", "lda_qpf", "features_mav"):
        pipe = make_estimator(name).fit(X, y)
        stream = pipe.streaming("free_run")
        values = [stream.step(u) for u in X]
        np.testing.assert_allclose(values, pipe.predict(X, mode="free_run"), atol=1e-9)


def test_outputs_are_in_newtons(features) -> None:
    X, y = features.X, features.y
    pipe = make_estimator("ss_kf").fit(X, y)
    assert pipe.scaling_.y_min_n == pytest.approx(y.min())
    assert pipe.scaling_.y_span_n == pytest.approx(np.ptp(y))
    y_hat = pipe.predict(X, y, mode="one_step")
    # a fitted one-step estimate follows the measured force in newtons
    assert np.sqrt(np.mean((y_hat - y) ** 2)) < 0.2 * np.ptp(y)


def test_constant_feature_is_rejected_at_fit(features) -> None:
    X = features.X.copy()
    X[:, 4] = 2.0
    with pytest.raises(ConstantInputError, match="column 4"):
        make_estimator("ss_kf").fit(X, features.y)
