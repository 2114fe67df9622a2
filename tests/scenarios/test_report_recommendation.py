"""The report's deployment sentence leaves out estimators that learn from virtual subjects."""

from __future__ import annotations

from scenarios.report.paper_section import _deployment_sentence, deployment_note
from scenarios.report.reproduction_data import EstimatorScores


def _scores(per_subject: dict[int, float]) -> EstimatorScores:
    r2 = list(per_subject.values())
    return EstimatorScores({s: (v, 0.3) for s, v in per_subject.items()},
                           sum(r2) / len(r2), 0.0, 0.3, 0.0, len(r2))


def test_an_estimator_trained_on_the_sweeps_population_is_not_recommended_from_it():
    free = {"mlp": _scores({1: 0.90, 2: 0.88}), "features_mav": _scores({1: 0.85, 2: 0.80}),
            "transfer_mlp": _scores({1: 0.95, 2: 0.94}),
            "adaptive_mlp": _scores({1: 0.93, 2: 0.92})}
    text = _deployment_sentence({"free_run": free}, channels="all")
    assert "should use MLP in free_run" in text
    assert "Left out of this choice: transfer_mlp, adaptive_mlp" in text


def test_without_such_estimators_the_sentence_is_the_plain_rule():
    free = {"mlp": _scores({1: 0.90, 2: 0.88}), "features_mav": _scores({1: 0.91, 2: 0.89})}
    text = _deployment_sentence({"free_run": free})
    assert "should use F_MAV" in text and "Left out" not in text


def test_a_reproduction_json_with_its_own_recommendation_is_quoted_not_recomputed():
    # griploop reproduce judged the sim-trained estimators out of population; the report
    # must not name another estimator from the in-population scores
    free = {"mlp": _scores({1: 0.90, 2: 0.88}), "lda_qpf": _scores({1: 0.91, 2: 0.89})}
    judged = {"estimator": "gbt", "reason": "A deployed prosthesis ... should use GBT ..."}
    assert deployment_note({"free_run": free}, "6,7,8", judged) == judged["reason"]
    assert "should use LDA_QPF" in deployment_note({"free_run": free}, "6,7,8", None)
