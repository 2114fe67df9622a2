"""Evaluation protocol: split, scoring on validation only, aggregation, unstable flags."""

from __future__ import annotations

import json

import numpy as np
import pytest
from est_synthetic import toy_recording

from estimation.errors import InsufficientDataError
from estimation.evaluation import aggregate, evaluate_subject, split_index
from estimation.features import extract_features
from estimation.metrics import r2_score
from estimation.registry import make_estimator
from estimation.reproduce import to_jsonable


def test_split_index() -> None:
    assert split_index(205) == 102
    assert split_index(10, 0.3) == 3
    with pytest.raises(InsufficientDataError):
        split_index(3)


def test_scores_are_computed_on_the_validation_half_only() -> None:
    fs = extract_features(toy_recording(seed=2), channels=(6, 7, 8))
    res = evaluate_subject(fs.X, fs.y, ["ss_kf", "persistence"], dt_s=fs.dt_s)
    n_id = split_index(fs.n_windows)
    pipe = make_estimator("ss_kf").fit(fs.X[:n_id], fs.y[:n_id])
    y_hat = pipe.predict(fs.X, fs.y, mode="free_run")[n_id:]
    assert res["ss_kf"]["modes"]["free_run"]["r2"] == pytest.approx(
        r2_score(fs.y[n_id:], y_hat), abs=1e-12)
    pers = res["persistence"]["modes"]["one_step"]
    assert pers["r2"] == pytest.approx(r2_score(fs.y[n_id:], fs.y[n_id - 1:-1]), abs=1e-12)
    assert set(res["persistence"]["modes"]) == {"one_step"}
    assert res["ss_kf"]["step_mode"] == "one_step" and res["ss_kf"]["step_us"] > 0
    assert res["ss_kf"]["info"]["order"] == 4


def test_aggregate_mean_and_sample_sd() -> None:
    subjects = []
    for seed in (3, 4, 5):
        fs = extract_features(toy_recording(seed=seed, duration_s=24.0), channels=(6, 7, 8))
        subjects.append(evaluate_subject(fs.X, fs.y, ["features_mav", "persistence"],
                                         dt_s=fs.dt_s, time_steps=False))
    agg = aggregate(subjects)
    r2 = [s["features_mav"]["modes"]["free_run"]["r2"] for s in subjects]
    entry = agg["estimators"]["features_mav"]["free_run"]
    assert entry["r2_mean"] == pytest.approx(np.mean(r2))
    assert entry["r2_sd"] == pytest.approx(np.std(r2, ddof=1))
    assert entry["n_ok"] == 3 and len(entry["per_subject"]) == 3
    assert agg["timing"]["persistence"]["step_us_median"] is None
    json.dumps(to_jsonable(agg))


def test_unstable_free_run_is_flagged_and_excluded() -> None:
    rng = np.random.default_rng(6)
    n = 160
    U = rng.uniform(0, 1, size=(n, 3))
    y = np.zeros(n)
    for k in range(1, n):  # explosive force: an order-1 model identifies a pole > 1
        y[k] = 1.04 * y[k - 1] + U[k - 1] @ [0.5, 0.2, 0.1] + 0.01 * rng.normal()
    res = evaluate_subject(U, y, {"ss_kf": {"order": 1}}, dt_s=0.125)
    free = res["ss_kf"]["modes"]["free_run"]
    assert free["status"] == "unstable" and free["r2"] is None
    assert res["ss_kf"]["modes"]["one_step"]["status"] == "ok"
    assert res["ss_kf"]["info"]["stable"] is False
    agg = aggregate([res])
    assert agg["estimators"]["ss_kf"]["free_run"]["n_ok"] == 0
    assert agg["estimators"]["ss_kf"]["free_run"]["r2_mean"] is None


def test_failed_kalman_design_is_reported_not_hidden(monkeypatch) -> None:
    import estimation.state_space as ss_module
    from estimation.errors import RiccatiError

    def no_solution(*args, **kwargs):
        raise RiccatiError("the Riccati equation has no stabilizing solution (forced)")

    monkeypatch.setattr(ss_module, "design_kalman", no_solution)
    fs = extract_features(toy_recording(seed=7), channels=(6, 7, 8))
    res = evaluate_subject(fs.X, fs.y, ["ss_kf", "ss"], dt_s=fs.dt_s, time_steps=False)
    assert {m["status"] for m in res["ss_kf"]["modes"].values()} == {"riccati_failed"}
    assert res["ss"]["modes"]["one_step"]["status"] == "ok"  # no Kalman design needed
    agg = aggregate([res])
    assert agg["estimators"]["ss_kf"]["one_step"]["n_ok"] == 0
    assert agg["timing"]["ss_kf"]["train_ms_median"] is None


def test_an_estimator_that_cannot_take_the_inputs_is_reported_and_the_rest_run() -> None:
    from estimation.errors import EstimationInputError

    fs = extract_features(toy_recording(seed=2), channels=(7, 8))  # 6 inputs
    res = evaluate_subject(fs.X, fs.y, ["ridge", "transfer_mlp"], dt_s=fs.dt_s,
                           time_steps=False)
    assert res["ridge"]["modes"]["free_run"]["status"] == "ok"
    bad = res["transfer_mlp"]["modes"]["free_run"]
    assert bad["status"] == "unsupported" and bad["r2"] is None
    assert "24 inputs" in bad["message"] and "found 6 inputs" in bad["message"]
    agg = aggregate([res])
    assert agg["estimators"]["transfer_mlp"]["free_run"]["n_ok"] == 0
    json.dumps(to_jsonable(agg))
    # when no estimator can take the inputs, the reason is raised once
    with pytest.raises(EstimationInputError, match="found 6 inputs"):
        evaluate_subject(fs.X, fs.y, ["transfer_mlp"], dt_s=fs.dt_s, time_steps=False)
