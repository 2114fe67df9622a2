"""What a reproduction's numbers say: the recommendation, and virtual against real people.

An estimator that learns from virtual subjects (``EstimatorKind(sim_trained=True)``:
pretraining on a corpus, settings chosen on virtual subjects) looks best on the population
it learned from. ``griploop reproduce`` therefore also scores every estimator on
subjects of a population none of them was trained on (``out_of_population`` in the JSON
contract: another population variant and sEMG generator, ``scenarios.runners.reproduction``),
and the verdicts here use those figures:

- :func:`recommendation` compares the estimators on the out-of-population subjects (every
  estimator is new to them); without them, an estimator that learns from virtual subjects
  is left out of the recommendation rather than recommended on in-population figures;
- :func:`transfer_table` sets each estimator's virtual figure beside the real one (issue
  18 and 28's agreement), the out-of-population figure for those that learn from virtual
  subjects, their in-population figure shown beside it.
"""

from __future__ import annotations

import numpy as np

from estimation.real_recordings import SOURCE as REAL_SOURCE
from estimation.real_recordings import real_free_run, transfer_agreement
from estimation.recommendation import recommend
from estimation.registry import deployable_estimators, estimator_info, estimator_label


def cell(value: float | None, width: int = 8, digits: int = 4) -> str:
    """A table cell: ``value`` in ``width`` characters, ``digits`` decimals (None: ``n/a``)."""
    return f"{'n/a':>{width}}" if value is None else f"{value:>{width}.{digits}f}"


def sim_trained(name: str) -> bool:
    """Whether ``name`` learns from virtual subjects (False for an unregistered name)."""
    try:
        return bool(estimator_info(name)["sim_trained"])
    except LookupError:
        return False


def free_run_summary(estimators: dict) -> dict[str, dict]:
    """``{name: {"r2_mean", "r2_min", "n_ok", "n"}}`` of every estimator with a free_run mode.

    Parameters
    ----------
    estimators : dict
        The contract's ``estimators`` (or ``out_of_population["estimators"]``).
    """
    return {n: {"r2_mean": e["free_run"]["r2_mean"], "r2_min": e["free_run"]["r2_min"],
                "n_ok": e["free_run"]["n_ok"], "n": len(e["free_run"]["per_subject"])}
            for n, e in estimators.items() if "free_run" in e}


def out_of_population(result: dict) -> dict | None:
    """The contract's ``out_of_population`` entry, or None."""
    return result.get("out_of_population") or None


def recommendation(result: dict) -> dict | None:
    """The JSON contract's ``recommendation`` (:func:`estimation.recommendation.recommend`).

    On the out-of-population subjects when the run has them; otherwise on the population,
    without the estimators that learn from virtual subjects. ``judged_on`` says which.
    """
    channels = result.get("config", {}).get("channels", result.get("recording", {}).get(
        "channels"))
    ref = result["estimators"].get("ss_kf", {}).get("one_step", {}).get("r2_mean")
    oop = out_of_population(result)
    if oop is not None:
        summary = free_run_summary(oop["estimators"])
        where = (f" on {oop['n_subjects']} virtual subjects none of them was trained on "
                 f"({oop['population']} population, {oop['generator']} generator)")
        judged = "out_of_population"
    else:
        summary = {n: e for n, e in free_run_summary(result["estimators"]).items()
                   if not sim_trained(n)}
        where, judged = "", "population"
    rec = recommend(summary, channels=channels, one_step_reference=ref, where=where)
    if rec is not None:
        rec["judged_on"] = judged
    return rec


def transfer_table(result: dict) -> dict | None:
    """Virtual next to real per estimator (free_run), with the agreement of issues 18 and 28.

    The virtual figure of an estimator that learns from virtual subjects is its
    out-of-population one (``in_population_mean`` beside it); without out-of-population
    subjects it takes no part in the agreement. Only for all 8 channels, the real
    recordings' setting; None otherwise.
    """
    if result.get("config", {}).get("channels") != "all":
        return None
    summary = free_run_summary(result["estimators"])
    oop = out_of_population(result)
    judged = free_run_summary(oop["estimators"]) if oop is not None else {}
    rows = []
    for n in summary:
        real = real_free_run(n)
        learner = sim_trained(n)
        figure = judged.get(n) if learner else summary[n]
        rows.append({"estimator": n, "sim_trained": learner,
                     "virtual_mean": None if figure is None else figure["r2_mean"],
                     "virtual_min": None if figure is None else figure["r2_min"],
                     "in_population_mean": summary[n]["r2_mean"] if learner else None,
                     "in_population_min": summary[n]["r2_min"] if learner else None,
                     "real_mean": None if real is None else real["r2_mean"],
                     "real_min": None if real is None else real["r2_min"]})
    rows.sort(key=lambda r: -(r["real_mean"] if r["real_mean"] is not None else -9.0))
    agreement = transfer_agreement({r["estimator"]: r["virtual_mean"] for r in rows})
    return {"source": REAL_SOURCE, "rows": rows, "agreement": agreement}


def format_transfer(result: dict) -> str:
    """The virtual-vs-real table and the agreement lines (empty without ``transfer``)."""
    tr = result.get("transfer")
    if not tr:
        return ""
    lines = ["Virtual subjects next to real people (free_run, all 8 channels; real: "
             f"{tr['source']})",
             f"  {'estimator':13s}{'virtual mean':>13s}{'(worst)':>9s}{'real mean':>11s}"
             f"{'(worst)':>9s}{'difference':>12s}"]
    for r in tr["rows"]:
        real, vm = r["real_mean"], r["virtual_mean"]
        diff = None if real is None or vm is None else vm - real
        line = (f"  {r['estimator']:13s}{cell(vm, 13, 3)}{cell(r['virtual_min'], 9, 2)}"
                f"{cell(real, 11, 3)}{cell(r['real_min'], 9, 2)}"
                f"{'' if diff is None else f'{diff:+12.3f}'}")
        if r.get("sim_trained"):
            line += (f"   (out of population; in population {cell(r['in_population_mean'], 0, 3)}"
                     f", worst {cell(r['in_population_min'], 0, 2)}"
                     f"{'' if real is not None else '; no real figure yet'})")
        lines.append(line)
    a = tr["agreement"]
    if a["spearman"] is None:
        lines.append(f"  agreement: fewer than 3 estimators reach {a['floor']} on either side")
        return "\n".join(lines)
    lines.append(
        f"  agreement over the {a['n']} estimators reaching R2 {a['floor']} on either side: "
        f"Spearman {a['spearman']:.2f} (goal >= {a['thresholds']['spearman']}), mean "
        f"|virtual - real| {a['mean_abs_diff']:.3f} (<= {a['thresholds']['mean_abs_diff']}),"
        f" largest {a['max_abs_diff']:.3f} for {a['worst']} "
        f"(<= {a['thresholds']['max_abs_diff']})")
    reversed_ = ", ".join(f"{b} > {w}" for b, w in a["pairs_reversed"]) or "none"
    lines.append(f"  pairs real people separate (Wilcoxon p < 0.05): {len(a['pairs'])} compared,"
                 f" reversed by the virtual means: {reversed_}")
    return "\n".join(lines)


def format_out_of_population(result: dict) -> str:
    """The out-of-population table: every estimator on subjects none was trained on."""
    oop = out_of_population(result)
    if oop is None:
        return ""
    est = result["estimators"]
    judged = free_run_summary(oop["estimators"])
    lines = [f"Out of population (free_run): {oop['n_subjects']} subjects of the "
             f"{oop['population']} population ({oop['description']}), {oop['generator']} "
             f"generator, seed {oop['seed']}; beside it the population figure",
             f"  {'estimator':13s}{'out of pop.':>12s}{'(worst)':>9s}{'population':>12s}"
             f"{'(worst)':>9s}"]
    for n in sorted(judged, key=lambda k: -(judged[k]["r2_mean"] or -np.inf)):
        e, p = judged[n], est.get(n, {}).get("free_run", {})
        tag = "  learns from virtual subjects: population figure is in-population" \
            if sim_trained(n) else ""
        lines.append(f"  {n:13s}{cell(e['r2_mean'], 12, 3)}{cell(e['r2_min'], 9, 2)}"
                     f"{cell(p.get('r2_mean'), 12, 3)}{cell(p.get('r2_min'), 9, 2)}{tag}")
    return "\n".join(lines)


def format_inner_outer(result: dict) -> str:
    """Choosing per person on the identification half, virtual against real (issue 28)."""
    io = result.get("inner_outer")
    if not io:
        return ""
    v, r = io["summary"], io["real"]
    return "\n".join([
        f"Choosing per person on the identification half (inner split) against the evaluation "
        f"half (outer), over {', '.join(io['estimators'])}:",
        f"  virtual: Spearman median {v['spearman_median']:.2f} [{v['spearman_min']:.2f}.."
        f"{v['spearman_max']:.2f}], regret of the pick {v['regret_mean']:.3f}, pick - MLP "
        f"{v['gain_mean']:+.3f} (worst {v['gain_min']:+.2f})",
        f"  real S1-S10: Spearman median {r['spearman_median']:.2f} [{r['spearman_min']:.2f}.."
        f"{r['spearman_max']:.2f}], regret {r['regret_mean']:.3f}, pick - MLP "
        f"{r['gain_mean']:+.3f} (worst {r['gain_min']:+.2f})"])


def format_deployable(result: dict) -> str:
    """Deployable (sEMG-only) estimators: free_run mean, SD, worst subject, timing, verdict."""
    est, timing = result["estimators"], result["timing"]
    lines = ["Deployable estimators (free_run: sEMG only) -- R2 mean +/- SD, worst subject, "
             "training ms (median), step us (median)"]
    names = [n for n in est if "free_run" in est[n]]
    names.sort(key=lambda n: -(est[n]["free_run"]["r2_mean"] or -np.inf))
    deployable = deployable_estimators()
    for n in names:
        e, t = est[n]["free_run"], timing[n]
        tag = " *" if n in deployable else ""
        line = (f"  {estimator_label(n) + tag:12s} R2 {cell(e['r2_mean'], 7)} +/- "
                f"{cell(e['r2_sd'], 6)}  min {cell(e.get('r2_min'), 7)}  "
                f"n_ok {e['n_ok']}/{len(e['per_subject'])}  train "
                f"{cell(t['train_ms_median'], 8, 1)} ms  step "
                f"{cell(t['step_us_median'], 6, 1)} us")
        if sim_trained(n):
            line += "  (in population: learns from virtual subjects)"
        lines.append(line)
    for n in ("ss_kf", "persistence", "narx"):
        if n in est and "one_step" in est[n]:
            e = est[n]["one_step"]
            lines.append(f"  reference {estimator_label(n):9s} one_step R2 {cell(e['r2_mean'], 7)} "
                         f"(min {cell(e.get('r2_min'), 6, 3)}; needs the measured force)")
    lines.append("  (* built for deployment: all settings chosen on a validation split of the "
                 "identification half or on virtual subjects)")
    rec = result.get("recommendation") or recommendation(result)
    lines.append(rec["reason"] if rec else "No estimator ran in free_run on every subject; "
                 "none can be recommended.")
    return "\n".join(lines)
