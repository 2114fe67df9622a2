"""The paper's evaluation on virtual subjects: a population (Tables 2 and 3) or one scenario.

:func:`run_reproduction` (``griploop reproduce``) makes the population
(:func:`sim.user.subjects.make_population`), records each subject's paper session and
scores every estimator on it (:func:`estimation.reproduce.score_recording`, through
:func:`estimation.evaluation.fit_and_score`); :func:`estimation.reproduce.population_result`
makes the JSON contract. :func:`run_reproduction_scenario` is the runner of scenario kind
``reproduction``: one subject, one estimator, one mode.

Seeding: subject ``i`` of ``run_reproduction(n, seed)`` draws its session and its
estimators' seeds from the two children of ``SeedSequence([seed, 0x5EED]).spawn(n)[i]``;
a ``reproduction`` scenario from the two children of ``SeedSequence(scenario.seed)``.

Out of population (issue 28): when an estimator that learns from virtual subjects is
among those evaluated, every estimator is also scored on ``n`` subjects of the
:data:`JUDGE_POPULATION` variant (``sim.user.populations``), population seed
``seed + JUDGE_SEED_OFFSET``, recorded with the other sEMG generator
(:func:`judge_generator`): people none of the estimators learned from. The
recommendation and the virtual-real agreement use those figures
(:mod:`estimation.verdicts`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from estimation.evaluation import split_index
from estimation.features import FeatureSet
from estimation.paper import PAPER_ORDER
from estimation.real_recordings import real_inner_outer
from estimation.registry import estimator_info, estimator_names
from estimation.reproduce import (
    ScoreSettings,
    channel_label,
    parse_channels,
    population_result,
    score_recording,
)
from estimation.threads import one_blas_thread
from scenarios.rows import ReproductionRow
from scenarios.runners.calibration import fit_one
from scenarios.runners.dispatch import ResultRow, UnsupportedScenarioError
from scenarios.runners.subject import calibration_session, subject_for
from scenarios.schema import Scenario
from sim.user.difficulty import inner_outer, summarize_inner_outer
from sim.user.populations import population_description
from sim.user.subjects import make_population

#: Mixed into the population seed to seed the subjects' sessions and estimators.
SESSION_SALT = 0x5EED
#: The population variant an estimator that learns from virtual subjects is judged on.
JUDGE_POPULATION = "wide"
#: Added to the population seed for the judge's subjects (far from the corpora's seeds).
JUDGE_SEED_OFFSET = 1_000_003
#: Estimators whose inner split is compared with the real recordings' (issue 28): those of
#: the real table reaching R^2 0.5 that do not learn from virtual subjects.
INNER_OUTER_ESTIMATORS = ("mlp", "gbt", "ridge", "features_mav", "features_wl", "lda_qpf",
                          "latent_kf", "narx", "features_rms")


def judge_generator(generator: str) -> str:
    """The sEMG generator of the judge's subjects: the other of ``noise`` and ``motor_units``."""
    return "motor_units" if generator == "noise" else "noise"


@dataclass(frozen=True)
class ReproductionAnalyses:
    """What :func:`run_reproduction` studies beside the paper's Tables 2 and 3.

    Attributes
    ----------
    orders : sequence of int
        Candidate orders for the per-subject AIC curve (paper: 1..12).
    judge : str or None
        Population variant of the out-of-population subjects, scored when an estimator
        that learns from virtual subjects is evaluated (``None``: never; the
        recommendation then leaves such estimators out).
    inner : bool
        Also score the inner split of every identification half, for the
        :data:`INNER_OUTER_ESTIMATORS` evaluated, and compare the choice it makes with the
        real recordings' (``inner_outer`` in the result).
    """

    orders: Sequence[int] = tuple(range(1, 13))
    judge: str | None = JUDGE_POPULATION
    inner: bool = False


DEFAULT_ANALYSES = ReproductionAnalyses()
"""The AIC curve over orders 1..12 and the judge's population; no inner split."""
PAPER_SETTINGS = ScoreSettings()
"""The paper's inputs and order: MAV, RMS and WL of channels 6, 7, 8; order 4."""


def run_reproduction(
    n_subjects: int = 10,
    seed: int = 0,
    *,
    estimators: Sequence[str] | None = None,
    settings: ScoreSettings = PAPER_SETTINGS,
    generator: str = "noise",
    analyses: ReproductionAnalyses = DEFAULT_ANALYSES,
    workers: int = 1,
) -> dict:
    """Run the paper's protocol on ``n_subjects`` virtual subjects.

    Parameters
    ----------
    n_subjects : int
        Population size (paper: 10).
    seed : int
        Seeds the population, each session and the networks' initialization.
    estimators : sequence of str
        Registry names to evaluate (must include ``"ss_kf"`` for the ``model`` entry);
        ``None``: every registered estimator.
    settings : ScoreSettings
        The input channels (``"all"``, a sequence of 1-based numbers or names, or a
        string as :func:`estimation.reproduce.parse_channels` reads it; paper: 6, 7, 8),
        the SS order of the tables (paper: 4; NARX delays and hidden units follow it) and
        the MLP/NARX hyperparameter overrides (e.g. ``{"max_epochs": 50}``).
    generator : {"noise", "motor_units"}
        Virtual subjects' sEMG model.
    analyses : ReproductionAnalyses
        The AIC curve's candidate orders, the judge's population and the inner split.
    workers : int
        Subjects evaluated at once, each in a process forked from this one (default 1:
        in this process). Every subject has its own seeds, so the figures do not depend
        on it; only the training times do, when the processes share cores.

    Returns
    -------
    dict
        The JSON contract of :mod:`estimation.reproduce`; private keys dropped.
    """
    settings = replace(settings, channels=parse_channels(settings.channels))
    order, judge = settings.order, analyses.judge
    estimators = estimator_names() if estimators is None else tuple(estimators)
    if int(workers) < 1:
        raise UnsupportedScenarioError(f"workers: expected at least 1, found {workers}")
    learners = [e for e in estimators if estimator_info(e)["sim_trained"]]
    if judge is not None:
        population_description(judge)  # an unknown variant is refused before any work
    with one_blas_thread():
        # the inner split only for the estimators whose choice is compared with the real one
        inner_names = tuple(n for n in INNER_OUTER_ESTIMATORS if n in estimators) \
            if analyses.inner else ()
        jobs = _jobs(make_population(n=n_subjects, seed=seed), seed, generator, estimators,
                     settings, analyses.orders, inner_names)
        scores = _map_subjects(jobs, int(workers))
        config = {"n_subjects": n_subjects, "seed": seed, "generator": generator,
                  "order": order, "channels": channel_label(settings.channels),
                  "identification_fraction": 0.5, "estimators": list(estimators),
                  "nn_params": dict(settings.nn_params or {}), "judge": judge}
        judged, described = None, None
        if learners and judge is not None:
            judge_seed = int(seed) + JUDGE_SEED_OFFSET
            described = {"population": judge, "description": population_description(judge),
                         "generator": judge_generator(generator), "seed": judge_seed}
            judged = _map_subjects(_jobs(make_population(n_subjects, judge_seed, variant=judge),
                                         judge_seed, described["generator"], estimators,
                                         settings, None, ()),
                                   int(workers))
        result = population_result(scores, config=config, order=order, judged=judged,
                                   judge=described)
    if analyses.inner:
        result["inner_outer"] = inner_outer_result(scores, result["estimators"])
    return result


def _jobs(subjects: Sequence[Any], seed: int, generator: str, estimators: Sequence[str],
          settings: ScoreSettings, orders: Any, inner: Sequence[str]) -> list[tuple]:
    """One job per subject for :func:`_score_subject`, seeded from ``[seed, SESSION_SALT]``."""
    children = np.random.SeedSequence([seed, SESSION_SALT]).spawn(len(subjects))
    return [(subject, child, generator, estimators, settings, orders, inner)
            for subject, child in zip(subjects, children, strict=True)]


def inner_outer_result(scores: Sequence[Any], estimators: Mapping[str, Any]) -> dict:
    """The inner -> outer statistics of a population beside the real recordings' (issue 28).

    Over :data:`INNER_OUTER_ESTIMATORS` that were evaluated (per subject:
    :func:`sim.user.difficulty.inner_outer`, MLP the reference), summarized as
    :func:`sim.user.difficulty.summarize_inner_outer`; ``real`` is the same summary of
    S1-S10 (:func:`estimation.real_recordings.real_inner_outer`).
    """
    names = [n for n in INNER_OUTER_ESTIMATORS if n in estimators]
    rows = []
    for i, score in enumerate(scores):
        outer = {n: estimators[n]["free_run"]["per_subject"][i]["r2"] for n in names}
        rows.append(dict(inner_outer({n: score.inner.get(n) for n in names}, outer),
                         inner={n: score.inner.get(n) for n in names}))
    return {"estimators": names, "per_subject": rows, "summary": summarize_inner_outer(rows),
            "real": summarize_inner_outer(real_inner_outer())}


def _score_subject(job: tuple) -> Any:
    """One subject of :func:`run_reproduction`: its paper session, scored by every estimator."""
    subject, child, generator, estimators, settings, orders, inner = job
    session_ss, est_ss = child.spawn(2)
    rec = subject.paper_session(rng=np.random.default_rng(session_ss), generator=generator)
    score, _ = score_recording(rec, estimators, rng=np.random.default_rng(est_ss),
                               settings=settings, orders=orders,
                               subject_id=subject.subject_id, inner=inner)
    return score


def _score_in_worker(job: tuple) -> Any:
    """:func:`_score_subject` in a forked worker, on one BLAS and OpenMP thread.

    The workers already use the cores; and an OpenMP pool the parent started does not
    survive ``fork`` (a child asking it for threads would wait forever).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _score_subject(job)


def _map_subjects(jobs: list[tuple], workers: int) -> list[Any]:
    """Every subject's score, in order: here, or on ``workers`` forked processes.

    Forked workers inherit the registries (plugins, pretraining corpora) and the pretrained
    networks in memory; where processes cannot be forked, the subjects run here.
    """
    import multiprocessing

    workers = min(workers, len(jobs))
    if workers <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [_score_subject(job) for job in jobs]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(_score_in_worker, jobs))


def run_reproduction_scenario(scenario: Scenario) -> ResultRow:
    """One subject x estimator x mode of the paper's evaluation (kind ``reproduction``).

    The virtual subject ``VirtualSubject.sample(population_seed, subject_id)``
    (with the scenario's electrode shift, extra noise and fatigue) performs the
    paper's squeeze session with the FSR; features are extracted on the paper's
    channels; the estimator is fitted on the first ``identification_fraction``
    of the windows and scored on the rest
    (:func:`estimation.evaluation.fit_and_score`), as ``griploop reproduce`` does
    for a whole population.

    Parameters
    ----------
    scenario : Scenario
        Kind ``reproduction``, seed set. ``seed`` drives the session (protocol
        timing, levels, noise) and the networks' initialization.

    Returns
    -------
    ResultRow
        ``r2``, ``nrmse``, ``rmse_n``, ``volatility_n_per_s`` on the validation
        part, ``train_ms``, ``step_us``, ``order``, ``n_windows``,
        ``n_identification``, ``session_s``, and traces ``t_s``, ``force_n``
        (measured) and ``force_hat_n`` (estimated), shape (n_validation,).

    Raises
    ------
    UnsupportedScenarioError
        ``protocol.calibration_s`` set (the paper session has its own length)
        or a mode the estimator does not have.
    DivergedError
        The identified model is unstable in the requested mode.
    """
    if scenario.protocol.calibration_s is not None:
        raise UnsupportedScenarioError(
            "the paper session has its own length (about 25-36 s): leave "
            f"protocol.calibration_s unset (found {scenario.protocol.calibration_s:g})"
        )
    session_seq, estimator_seq = np.random.SeedSequence(scenario.seed).spawn(2)
    subject = subject_for(scenario)
    recording, features = calibration_session(subject, np.random.default_rng(session_seq),
                                              generator=scenario.subject.generator)
    est = scenario.estimator
    result = fit_one(features, est.name, est.mode, rng=np.random.default_rng(estimator_seq),
                     order=PAPER_ORDER if est.order is None else est.order,
                     fraction=scenario.protocol.identification_fraction, time_steps=True,
                     options=est.options)
    return _reproduction_row(scenario, result, features, recording.duration_s)


def _reproduction_row(scenario: Scenario, result: Mapping[str, Any], features: FeatureSet,
                      session_s: float) -> ResultRow:
    """The result row of :func:`run_reproduction_scenario`, with its validation traces."""
    est = scenario.estimator
    scores = result["modes"][est.mode]
    n_id = split_index(features.n_windows, scenario.protocol.identification_fraction)
    force_hat_n = result["_pipeline"].predict(features.X, features.y, mode=est.mode)[n_id:]
    row = ReproductionRow.build(
        subject_id=scenario.subject.subject_id,
        estimator=est.name,
        mode=est.mode,
        order=PAPER_ORDER if est.order is None else est.order,
        r2=float(scores["r2"]),
        nrmse=float(scores["nrmse"]),
        rmse_n=float(scores["rmse_n"]),
        volatility_n_per_s=float(scores["volatility_n_per_s"]),
        train_ms=float(result["train_ms"]),
        step_us=None if result["step_us"] is None else float(result["step_us"]),
        n_windows=int(features.n_windows),
        n_identification=int(n_id),
        session_s=float(session_s),
    )
    return {
        **row.as_dict(),
        "traces": {
            "t_s": features.t_s[n_id:],
            "force_n": features.y[n_id:],
            "force_hat_n": np.asarray(force_hat_n, dtype=float),
        },
    }
