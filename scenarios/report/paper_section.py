"""Section 4 of the report: the paper's Tables 2 and 3 beside griploop's, and what to deploy."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from estimation.paper import TABLE2, TABLE3
from estimation.registry import paper_estimators
from scenarios.report import figures as F
from scenarios.report import reproduction_data as RD
from scenarios.report.html import (
    Section,
    esc,
    fmt,
    note,
    pm,
    svg_img,
    table,
)

# ---------------------------------------------------------------- 4. paper tables


def paper_section(sources: Sequence[tuple[str, RD.ScoreTable]],
                   reproduction: Path | None = None,
                   reproduction_data: Mapping[str, Any] | None = None) -> Section:
    title = "4. Paper tables: ours next to the paper's"
    if not sources:
        return Section("paper", title, note("No reproduction rows in the store and no "
                                            "--reproduction JSON: section omitted."), True)
    parts = [note("The paper evaluates one step ahead (measured force up to k-1 enters the "
                  "prediction); its numbers appear only next to our one_step figures. "
                  "free_run (sEMG only) has no counterpart in the paper. Virtual subject Vi is "
                  "not the paper's subject Vi: per-subject rows are side by side, not paired.")]
    data = reproduction_data or {}
    for label, scores in sources:
        parts.append(f"<h3>From {esc(label)}</h3>")
        for mode in scores:
            parts.append(_summary_table(scores[mode], mode))
            parts.append(_per_subject_table(scores[mode], mode))
        from_json = reproduction is not None and label.startswith(Path(reproduction).name)
        config = data.get("config") if isinstance(data.get("config"), dict) else {}
        channels = config.get("channels") if from_json else None
        parts.append(note(deployment_note(scores, channels,
                                          data.get("recommendation") if from_json else None)))
        if from_json:
            parts.append(_transfer_table(data.get("transfer")))
        parts.append(_timing_table(scores))
        parts.append(svg_img(F.svg_bytes(F.score_bars_figure(scores, f"Scores ({label})")),
                             f"R2 and NRMSE bars per estimator and mode, {label}"))
    return Section("paper", title, "\n".join(parts))


def _summary_table(scores: Mapping[str, RD.EstimatorScores], mode: str) -> str:
    with_paper = mode == "one_step"
    headers = ["estimator", "n", "R² mean ± SD", "NRMSE mean ± SD", "worst subject R²"]
    if with_paper:
        headers += ["paper R² mean ± SD", "paper NRMSE mean ± SD"]
    rows = []
    for name, s in scores.items():
        worst = min((r2 for r2, _ in s.per_subject.values()), default=None)
        row = [name, s.n, pm(s.r2_mean, s.r2_sd), pm(s.nrmse_mean, s.nrmse_sd), fmt(worst, 3)]
        if with_paper:
            ref = F.paper_reference(name)
            row += [pm(ref[0], ref[1]), pm(ref[2], ref[3])] if ref else ["-", "-"]
        rows.append(row)
    return table(headers, rows, f"Summary, mode {mode}")


def deployment_note(scores: RD.ScoreTable, channels: Any = None,
                    recommendation: Any = None) -> str:
    """The reproduction's own recommendation when its JSON carries one, else the sweep's.

    ``griploop reproduce --json`` judges the estimators that learn from virtual subjects
    on another population and writes its sentence in ``recommendation``; the report
    prints that sentence, so report and reproduction never name two estimators. Rows of
    a results store carry none: :func:`_deployment_sentence` decides from their scores.
    """
    if isinstance(recommendation, Mapping) and recommendation.get("reason"):
        return str(recommendation["reason"])
    return _deployment_sentence(scores, channels)


def _deployment_sentence(scores: RD.ScoreTable, channels: Any = None) -> str:
    """Which estimator a deployed prosthesis (no force sensor) should use, from the numbers.

    The same rule and sentence as ``griploop reproduce`` (:func:`estimation.recommendation.
    recommend`): the worst subject weighs, not only the mean. A sweep's subjects come from
    the population the estimators that learn from virtual subjects were trained on
    (``sim_trained`` in :mod:`estimation.registry`), so those are left out of the choice
    and the sentence says so (``griploop reproduce`` judges them out of population).
    """
    from estimation.recommendation import recommend
    from estimation.verdicts import sim_trained

    free = scores.get("free_run", {})
    n_subjects = len({s for e in free.values() for s in e.per_subject})
    learners = [n for n in free if sim_trained(n)]
    summary = {n: {"r2_mean": e.r2_mean if e.per_subject else None,
                   "r2_min": min((r for r, _ in e.per_subject.values()), default=None),
                   "n_ok": len(e.per_subject), "n": n_subjects} for n, e in free.items()
               if n not in learners}
    ref = scores.get("one_step", {}).get("ss_kf")
    rec = recommend(summary, channels=channels,
                    one_step_reference=None if ref is None else ref.r2_mean)
    text = rec["reason"] if rec else ("No estimator ran in free_run on every subject: none "
                                      "can be recommended.")
    if learners:
        text += (f" Left out of this choice: {', '.join(learners)}, which learn from virtual "
                 "subjects of this population (griploop reproduce judges them on subjects "
                 "of a population they never saw).")
    return text


def _transfer_table(tr: Any) -> str:
    """Virtual next to real (the ``transfer`` entry of ``griploop reproduce --channels all
    --json``), or empty."""
    if not isinstance(tr, dict) or not tr.get("rows"):
        return ""
    rows = [[r["estimator"], fmt(r["virtual_mean"], 3), fmt(r["virtual_min"], 2),
             fmt(r["real_mean"], 3), fmt(r["real_min"], 2),
             "-" if r["real_mean"] is None or r["virtual_mean"] is None
             else f"{r['virtual_mean'] - r['real_mean']:+.3f}"] for r in tr["rows"]]
    a = tr["agreement"]
    if a.get("spearman") is None:
        verdict = "Too few estimators reach R² 0.5 on either side to compare."
    else:
        verdict = (f"Over the {a['n']} estimators reaching R² {a['floor']} on either side: "
                   f"Spearman {a['spearman']:.2f} (goal ≥ {a['thresholds']['spearman']}), mean "
                   f"|virtual − real| {a['mean_abs_diff']:.3f} (≤ "
                   f"{a['thresholds']['mean_abs_diff']}), largest {a['max_abs_diff']:.3f} "
                   f"({a['worst']}; ≤ {a['thresholds']['max_abs_diff']}).")
    return ("<h3>Virtual subjects next to real people (free_run, all 8 channels)</h3>"
            + note(f"{verdict} Real: {tr['source']}.")
            + table(["estimator", "virtual mean", "virtual worst", "real mean", "real worst",
                     "virtual − real"], rows, "Estimation verdicts, virtual and real"))


def _per_subject_table(scores: Mapping[str, RD.EstimatorScores], mode: str) -> str:
    subjects = sorted({s for e in scores.values() for s in e.per_subject})
    names = list(scores)
    headers = ["subject"]
    for name in names:
        headers += [f"{name} R²", f"{name} NRMSE"]
        if mode == "one_step" and name in paper_estimators():
            headers += [f"paper {name} R²", f"paper {name} NRMSE"]
    rows = []
    for sid in subjects:
        row: list[Any] = [f"V{sid}"]
        for name in names:
            row += list(scores[name].per_subject.get(sid, (None, None)))
            if mode == "one_step" and name in paper_estimators():
                row += list(TABLE2.get(f"V{sid}", {}).get(name, (None, None)))
        rows.append(row)
    return table(headers, rows, f"Per subject (Table 2 layout), mode {mode}")


def _timing_table(scores: RD.ScoreTable) -> str:
    names = list(dict.fromkeys(n for m in scores.values() for n in m))
    rows = []
    for name in names:
        entries = [m[name] for m in scores.values() if name in m]
        train = next((e.train_ms for e in entries if e.train_ms is not None), None)
        step = next((e.step_us_median for e in entries if e.step_us_median is not None), None)
        paper = TABLE3.get(name)
        rows.append([
            name, pm(*train, digits=3) if train else "n/a",
            fmt(None if step is None else step / 1e3, 3),
            pm(*paper["train_ms"], digits=3) if paper else "-",
            pm(*paper["loop_ms"], digits=3) if paper else "-",
        ])
    return table(["estimator", "train ms (ours)", "loop ms median (ours)", "train ms (paper)",
                  "loop ms (paper)"], rows, "Timing (Table 3 layout)")
