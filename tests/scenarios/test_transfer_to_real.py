"""Calibration of the virtual population against real recordings (issue 18).

The real figures are the documented constants of :mod:`estimation.real_recordings`
(source: shared/REAL_RECORDINGS.md, ``griploop evaluate --channels all`` on ten real MYO +
FSR recordings of the paper's protocol). The virtual table is ``griploop reproduce
--subjects 10 --seed 0 --channels all`` with the default (noise) generator.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import spearmanr

from estimation.real_recordings import (
    FREE_RUN_MEAN,
    FREE_RUN_PER_SUBJECT,
    MAX_ABS_DIFF,
    MAX_MEAN_ABS_DIFF,
    MIN_SPEARMAN,
    RECORDING_STATISTICS,
)
from scenarios.runners.reproduction import run_reproduction
from sim.user.difficulty import recording_difficulty
from sim.user.subjects import make_population

ESTIMATORS = (*FREE_RUN_MEAN, "transfer_mlp")
# the module's reproduction (10 subjects, every channel, a network pretrained) takes a
# minute: it starts first on a parallel run (tests/conftest.py)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def result():
    return run_reproduction(10, 0, channels="all", estimators=ESTIMATORS, orders=(4,))


def _row(result, name):
    return next(r for r in result["transfer"]["rows"] if r["estimator"] == name)


def test_virtual_means_are_close_to_the_real_ones(result):
    a = result["transfer"]["agreement"]
    assert a["n"] >= 8
    assert a["mean_abs_diff"] <= MAX_MEAN_ABS_DIFF, a["rows"]
    assert a["max_abs_diff"] <= MAX_ABS_DIFF, (a["worst"], a["rows"])
    # the paper's model in free run fails on virtual people as on real ones (real 0.23)
    assert _row(result, "ss_sim")["virtual_mean"] < 0.5


@pytest.mark.xfail(strict=True, reason=(
    "the real ranking of the nine estimators is not reproducible from 10 subjects: 5 real "
    "subjects against the other 5 rank them with a median Spearman of 0.37 (docs/results/"
    "realism.md, 'How far the virtual verdicts hold'); the virtual ranking reaches about 0.3-0.5"))
def test_virtual_ranking_matches_the_real_one(result):
    assert result["transfer"]["agreement"]["spearman"] >= MIN_SPEARMAN


def test_the_real_ranking_itself_is_unstable_between_halves_of_the_subjects():
    # why the Spearman goal cannot hold for any 10 independent subjects: split the real
    # subjects in two halves and rank the estimators on each
    names = [n for n in FREE_RUN_MEAN if FREE_RUN_MEAN[n] >= 0.5]
    table = np.array([FREE_RUN_PER_SUBJECT[n] for n in names])
    rng = np.random.default_rng(0)
    rhos = []
    for _ in range(500):
        perm = rng.permutation(table.shape[1])
        a, b = table[:, perm[:5]].mean(axis=1), table[:, perm[5:]].mean(axis=1)
        rhos.append(spearmanr(a, b).statistic)
    assert np.median(rhos) < 0.5 and np.mean(np.array(rhos) >= MIN_SPEARMAN) < 0.05


def test_the_recommendation_is_the_transfer_ensemble_and_never_fails_a_subject(result):
    rec = result["recommendation"]
    free = {n: e["free_run"] for n, e in result["estimators"].items() if "free_run" in e}
    best = max(free, key=lambda n: free[n]["r2_mean"])
    assert rec["estimator"] == "transfer_mlp" == best
    assert rec["r2_min"] >= 0.80 and rec["mode"] == "free_run" and rec["channels"] == "all"
    assert rec["reason"] in _reasons(result)
    # it beats the best real-world estimator (the MLP) on mean and worst subject
    assert free["transfer_mlp"]["r2_mean"] > free["mlp"]["r2_mean"]
    assert free["transfer_mlp"]["r2_min"] > free["mlp"]["r2_min"]


def _reasons(result):
    from estimation.reproduce import format_report

    return format_report(result)


def test_fitting_the_transfer_ensemble_to_one_subject_takes_under_2_s(result):
    # pretraining is cached (and built once above); fine-tuning is what a person waits for.
    # The other estimators' times are in docs/results/ (benchmarks/bench_estimation.py): the
    # paper's MLP (mini-batch 1) takes 1-2 s on a two-round session.
    assert result["timing"]["transfer_mlp"]["train_ms_median"] < 2000


def test_population_recordings_look_like_the_real_ones():
    # per-subject statistics of the real recordings (shared/REAL_RECORDINGS.md) against
    # 20 virtual subjects: medians inside the real range, ranges overlapping it
    children = np.random.SeedSequence([0, 0x5EED]).spawn(20)
    rows = [recording_difficulty(r.emg, r.force_n, r.fs_hz) for r in (
        s.paper_session(rng=np.random.default_rng(c.spawn(2)[0]))
        for s, c in zip(make_population(20, 0), children, strict=True))]
    for key in ("squeezes", "peak_cv", "duty", "r2_lin_in", "r2_lin_out", "drift", "nonlin"):
        real = RECORDING_STATISTICS[key]
        virtual = np.median([r[key] for r in rows])
        assert min(real) <= virtual <= max(real), (key, virtual, real)
