"""The paper's claim under test: does a smoother reference make a better grasp?

The paper argues that the SS + Kalman estimate is smooth (low volatility) and
that this protects the force loop. :func:`compare_references` runs the same
grasp with references from several estimators and the oracle (the user's true
force) over several virtual subjects, and reports volatility, estimation and
tracking error, slip, drop and crush side by side. Failed episodes (e.g. an
identified model that is unstable in free run) are counted, never dropped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from controllers.design import DEFAULT_SPECS
from scenarios.outcomes import OUTCOMES
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.schema import ORACLE, derive_seed
from scenarios.stats import wilson_interval
from sim.hand.objects import ObjectSpec
from sim.user.subjects import VirtualSubject

DEFAULT_REFERENCES = ("ss_kf", "mlp", "features_mav", ORACLE)
#: Per-reference means reported beside the outcome counts.
COLUMNS = ("reference_volatility_n_per_s", "estimation_rmse_n", "tracking_rmse_n",
           "slip_events", "slip_distance_m", "dropped", "crushed", "peak_force_n",
           "user_corrections", "attempts", "time_to_lift_s", "safety_margin_pct")
DEFAULT_EPISODE = EpisodeSpec()
"""How :func:`compare_references` runs each episode unless told: ``EpisodeSpec()``."""


def session_seed(seed: int, population_seed: int, subject_id: int, session: int = 0) -> int:
    """The seed of one subject's session (calibration, practice and trial) in a run.

    Derived from the run's ``seed``, the subject and the session number, so that
    subjects draw independent sessions (one seed given to every subject would be one
    draw seen again and again) and a subject's estimators share theirs (paired).
    """
    return derive_seed(seed, f"population {population_seed} subject {subject_id}", session)


def compare_references(
    obj: ObjectSpec,
    spec: EpisodeSpec = DEFAULT_EPISODE,
    *,
    estimators: Sequence[str] = DEFAULT_REFERENCES,
    subject_ids: Sequence[int] = (1, 2, 3),
    population_seed: int = 0,
    seed: int = 0,
    sessions: int = 1,
) -> dict[str, Any]:
    """Run one grasp per subject and estimator; summarize per estimator.

    Parameters
    ----------
    obj : ObjectSpec
        The object, the same for every run.
    spec : EpisodeSpec
        How every episode runs (default :data:`DEFAULT_EPISODE`: free run, ``pid``, the
        reacting user without feedback after 5 practice lifts, today's hand); its
        ``mode`` is the estimators' (the oracle ignores it), its ``controller_spec``
        defaults to ``controllers.design.DEFAULT_SPECS`` of its ``controller``, and its
        ``episode_s`` is the trial's time limit (default: the user kind's). Its
        ``estimator`` and ``seed`` are set for each run.
    estimators : sequence of str
        Reference sources (estimator names or ``"oracle"``).
    subject_ids : sequence of int
        Virtual subjects of ``population_seed``.
    seed : int
        The run's seed: each subject's sessions derive from it and the subject
        (:func:`session_seed`); a subject's estimators share them, so their sEMG
        is identical (paired).
    sessions : int
        Sessions per subject (independent calibrations, practice and trials).

    Returns
    -------
    dict
        ``rows``: one flat row per (subject, session, estimator) with its
        ``seed``, ``status`` ok/failed and ``error``; ``summary``: per estimator,
        the mean of each column in :data:`COLUMNS` over the successful episodes
        (``held``, ``not_lifted``, ``dropped`` and ``crushed`` as fractions of the
        outcome categories: each episode has one), ``held_ci95`` (Wilson),
        ``held_by_subject`` (min and max over subjects of their held fraction:
        the spread a verdict on few draws hides), ``n_ok`` and ``n_failed``.
    """
    mode, controller = spec.mode, spec.controller
    design_spec = dict(DEFAULT_SPECS.get(controller, {}) if spec.controller_spec is None
                       else spec.controller_spec)
    rows: list[dict[str, Any]] = []
    for sid in subject_ids:
        subject = VirtualSubject.sample(population_seed, sid)
        for session in range(sessions):
            episode_seed = session_seed(seed, population_seed, sid, session)
            for name in estimators:
                base = {"subject_id": sid, "session": session, "seed": episode_seed,
                        "estimator": name, "mode": "oracle" if name == ORACLE else mode}
                try:
                    result = run_episode(subject, obj, replace(
                        spec, estimator=name, controller_spec=design_spec, seed=episode_seed))
                except (DivergedError, UnsupportedScenarioError) as exc:
                    rows.append({**base, "status": "failed", "error": str(exc)})
                    continue
                row = result.row
                rows.append({**base, "status": "ok", "error": None,
                             **{k: row[k] for k in COLUMNS},
                             **{o: row["outcome"] == o for o in OUTCOMES}})
    summary = {name: _summarize(rows, name, mode, subject_ids) for name in estimators}
    return {"object": {"name": obj.name, "mass_kg": obj.mass_kg, "friction": obj.friction,
                       "break_force_n": obj.break_force_n},
            "controller": controller, "subjects": list(subject_ids), "seed": seed,
            "sessions": sessions, "user": spec.user, "feedback": spec.feedback,
            "practice": spec.practice, **spec.hand.fields(), "rows": rows, "summary": summary}


def _summarize(rows: list[dict[str, Any]], name: str, mode: str,
               subject_ids: Sequence[int]) -> dict[str, Any]:
    """One estimator's entry of :func:`compare_references`'s ``summary``."""
    ok = [r for r in rows if r["estimator"] == name and r["status"] == "ok"]
    entry: dict[str, Any] = {"mode": "oracle" if name == ORACLE else mode,
                             "n_ok": len(ok), "n_failed": sum(
                                 r["estimator"] == name and r["status"] == "failed"
                                 for r in rows)}
    for col in (*COLUMNS, *OUTCOMES):
        values = [float(r[col]) for r in ok if r[col] is not None]
        entry[col] = float(np.mean(values)) if values else None
    entry["held_ci95"] = list(wilson_interval(sum(r["held"] for r in ok), len(ok)))
    by_subject = [np.mean([r["held"] for r in ok if r["subject_id"] == sid])
                  for sid in subject_ids if any(r["subject_id"] == sid for r in ok)]
    entry["held_by_subject"] = ([float(min(by_subject)), float(max(by_subject))]
                                if by_subject else None)
    return entry


def format_comparison(result: dict[str, Any]) -> str:
    """A plain-text table of :func:`compare_references`'s summary."""
    head = (f"{'reference':<14}{'mode':<10}{'held %':>7}{'not lifted %':>13}"
            f"{'drop %':>7}{'crush %':>8}{'attempts':>9}{'lift s':>7}{'margin %':>9}"
            f"{'volatility N/s':>15}{'est. RMSE N':>12}{'track RMSE N':>13}{'slip mm':>8}"
            f"{'peak N':>8}{'corr.':>6}{'ok/fail':>9}")
    lines = [head]

    def f(v: float | None, scale: float = 1.0, fmt: str = ".2f") -> str:
        return "-" if v is None else format(v * scale, fmt)

    for name, s in result["summary"].items():
        lines.append(
            f"{name:<14}{s['mode']:<10}{f(s['held'], 100, '.0f'):>7}"
            f"{f(s['not_lifted'], 100, '.0f'):>13}"
            f"{f(s['dropped'], 100, '.0f'):>7}{f(s['crushed'], 100, '.0f'):>8}"
            f"{f(s['attempts'], fmt='.2f'):>9}{f(s['time_to_lift_s'], fmt='.2f'):>7}"
            f"{f(s['safety_margin_pct'], fmt='.0f'):>9}"
            f"{f(s['reference_volatility_n_per_s']):>15}"
            f"{f(s['estimation_rmse_n']):>12}{f(s['tracking_rmse_n']):>13}"
            f"{f(s['slip_distance_m'], 1e3, '.1f'):>8}"
            f"{f(s['peak_force_n'], fmt='.1f'):>8}{f(s['user_corrections'], fmt='.1f'):>6}"
            f"{s['n_ok']:>5}/{s['n_failed']}"
        )
    return "\n".join(lines)
