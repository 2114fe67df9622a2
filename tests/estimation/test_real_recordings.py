"""The real recordings' figures and the agreement of a virtual table with them."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import spearmanr

from estimation.real_recordings import (
    FREE_RUN_MEAN,
    FREE_RUN_PER_SUBJECT,
    ONE_STEP_MEAN,
    ONE_STEP_PER_SUBJECT,
    RECORDING_STATISTICS,
    SUBJECTS,
    real_free_run,
    transfer_agreement,
)
from estimation.recommendation import recommend


def test_published_means_agree_with_their_per_subject_values():
    # the means have three decimals, the subjects two: they agree within rounding
    for table, means in ((FREE_RUN_PER_SUBJECT, FREE_RUN_MEAN),
                         (ONE_STEP_PER_SUBJECT, ONE_STEP_MEAN)):
        assert set(table) == set(means)
        for name, values in table.items():
            assert len(values) == len(SUBJECTS)
            assert np.mean(values) == pytest.approx(means[name], abs=0.006), name
    assert all(len(v) == len(SUBJECTS) for v in RECORDING_STATISTICS.values())


def test_real_free_run_gives_mean_worst_and_subjects():
    mlp = real_free_run("mlp")
    assert mlp["r2_mean"] == 0.898 and mlp["r2_min"] == 0.78 and len(mlp["per_subject"]) == 10
    assert real_free_run("transfer_mlp") is None


def test_agreement_of_the_real_table_with_itself_is_perfect():
    a = transfer_agreement(FREE_RUN_MEAN)
    # the estimators reaching 0.5: all but ss_sim (0.227) and ss_kf (0.359)
    assert a["n"] == 9 and "ss_sim" not in a["names"] and "ss_kf" not in a["names"]
    assert a["spearman"] == pytest.approx(1.0) and a["mean_abs_diff"] == 0.0
    assert a["agrees"]


def test_agreement_counts_an_estimator_that_reaches_the_floor_on_one_side_only():
    virtual = dict(FREE_RUN_MEAN, ss_sim=0.80)  # 0.227 real, 0.80 virtual: it enters
    a = transfer_agreement(virtual)
    assert "ss_sim" in a["names"] and a["worst"] == "ss_sim"
    assert a["max_abs_diff"] == pytest.approx(0.80 - 0.227)
    assert a["mean_abs_diff"] == pytest.approx((0.80 - 0.227) / 10)
    assert not a["agrees"]


def test_agreement_spearman_matches_scipy_on_a_shuffled_table():
    names = [n for n in FREE_RUN_MEAN if FREE_RUN_MEAN[n] >= 0.5]
    rng = np.random.default_rng(3)
    virtual = {n: FREE_RUN_MEAN[n] + rng.normal(0, 0.03) for n in names}
    a = transfer_agreement(virtual)
    expected = spearmanr([virtual[n] for n in a["names"]],
                         [FREE_RUN_MEAN[n] for n in a["names"]]).statistic
    assert a["spearman"] == pytest.approx(expected)
    diffs = [abs(virtual[n] - FREE_RUN_MEAN[n]) for n in a["names"]]
    assert a["mean_abs_diff"] == pytest.approx(np.mean(diffs))
    assert a["agrees"] == (a["spearman"] >= 0.8 and np.mean(diffs) <= 0.04 and max(diffs) <= 0.1)


def test_agreement_needs_three_estimators():
    a = transfer_agreement({"mlp": 0.9, "gbt": 0.8})
    assert a["spearman"] is None and not a["agrees"]


def test_recommendation_on_the_real_table_weighs_the_worst_subject():
    summary = {n: {"r2_mean": FREE_RUN_MEAN[n], "r2_min": min(FREE_RUN_PER_SUBJECT[n]),
                   "n_ok": 10, "n": 10} for n in FREE_RUN_MEAN}
    rec = recommend(summary, channels="all")
    assert rec["estimator"] == "mlp" and rec["r2_min"] == 0.78 and rec["runner_up"] == "gbt"
    assert rec["reason"].startswith("A deployed prosthesis has no force sensor, so it should use "
                                    "MLP in free_run on all 8 channels: mean R2 0.898 and worst "
                                    "subject 0.780")
    # a contender within 0.02 of the best mean and with a better worst subject wins
    summary["gbt"] = {"r2_mean": 0.885, "r2_min": 0.86, "n_ok": 10, "n": 10}
    rec = recommend(summary, channels="all")
    assert rec["estimator"] == "gbt" and "MLP's mean is higher by 0.013" in rec["reason"]
    # an estimator that did not run on every subject is not eligible
    summary["gbt"]["n_ok"] = 9
    assert recommend(summary)["estimator"] == "mlp"
    assert recommend({"x": {"r2_mean": 0.9, "r2_min": 0.8, "n_ok": 1, "n": 2}}) is None
