"""Scores of the paper's protocol and their tables: Tables 2 and 3, deployable, transfer.

This module takes recordings and features and scores estimators on them
(:func:`estimation.evaluation.fit_and_score`); it builds no subjects.
:func:`score_recording` scores one recording (one subject's session),
:func:`population_result` assembles the scores of a population into the JSON
contract below, and :func:`evaluate_recording` does both for one recording (``griploop
evaluate``). The virtual population is made and recorded by
:func:`scenarios.runners.reproduction.run_reproduction` (``griploop reproduce``).

The JSON contract::

    {"estimators": {name: {mode: {"r2_mean", "r2_sd", "r2_min", "nrmse_mean", "nrmse_sd",
                                  "per_subject": [...]}}},
     "training": {name: {hyperparameter: value}},   # settings of every estimator
     "timing": {name: {"train_ms_median", "step_us_median", ...}},
     "model": {"A", "B", "C", "Gamma", "Q", "R", "predictor_gain", "order", ...},
     "order_selection": {...}, "properties": {...}, "config": {...}}

``format_report`` renders Table 2 (per mode) and Table 3 next to the paper's numbers.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from estimation.errors import EstimationInputError
from estimation.evaluation import aggregate, fit_and_score, inner_scores, split_index
from estimation.features import PAPER_CHANNELS, FeatureSet, extract_features
from estimation.order import select_order
from estimation.paper import PAPER_ORDER, SECTION_4_2, TABLE2_SUMMARY, TABLE3
from estimation.registry import (
    deployable_estimators,
    estimator_info,
    estimator_label,
    estimator_names,
    paper_estimators,
)
from estimation.verdicts import (  # noqa: F401  (recommendation, transfer_table re-exported)
    cell,
    format_deployable,
    format_inner_outer,
    format_out_of_population,
    format_transfer,
    recommendation,
    transfer_table,
)
from sim.recording import Recording

#: Paper Table 2/3 estimators, in the paper's column order (``EstimatorKind(paper=True)``).
PAPER_ESTIMATORS = paper_estimators()
#: Estimators that need no force sensor at run time (``EstimatorKind(deployable=True)``).
DEPLOYABLE_ESTIMATORS = deployable_estimators()


def parse_channels(spec: str | Sequence[int | str] | None) -> list[int | str] | None:
    """Channel set from ``"all"``, ``"6,7,8"``, names, or a sequence; ``None`` = all.

    Raises
    ------
    ValueError
        An empty set, e.g. ``""`` or ``","``.
    """
    if spec is None:
        return None
    if isinstance(spec, str):
        if spec.strip().lower() == "all":
            return None
        items = [t.strip() for t in spec.split(",") if t.strip()]
        if not items:
            raise EstimationInputError(f"channels: expected 'all' or a comma-separated list like "
                             f"'6,7,8', found {spec!r}")
        return [int(t) if t.isdigit() else t for t in items]
    if isinstance(spec, str) or len(spec) == 0:
        raise EstimationInputError(f"channels: expected at least one channel, found {spec!r}")
    return list(spec)


def channel_label(channels: Sequence[int | str] | None) -> list[str] | str:
    """JSON form of a channel set: ``"all"`` or the list as strings."""
    return "all" if channels is None else [str(c) for c in channels]


def training_settings(per_subject_params: dict[str, dict], pipelines: dict) -> dict:
    """Hyperparameters every estimator was trained with (first subject; seeds differ)."""
    out: dict = {}
    for name, pipe in pipelines.items():
        est = getattr(pipe, "estimator", None)
        settings = {k: v for k, v in vars(est).items()
                    if not k.startswith("_") and not k.endswith("_")} if est is not None else {}
        settings.update(per_subject_params.get(name, {}))
        settings.pop("random_state", None)
        for attr in ("alpha_", "smoother_", "n_trees_", "network_used_"):
            if est is not None and hasattr(est, attr):
                settings[attr.rstrip("_") + "_chosen"] = getattr(est, attr)
        out[name] = settings
    return out


def to_jsonable(obj: object) -> object:
    """Recursively convert numpy scalars/arrays and drop private (``_``) keys."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items() if not str(k).startswith("_")}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        value = float(obj)
        return value if np.isfinite(value) else None
    if isinstance(obj, complex):
        return [obj.real, obj.imag]
    return obj


def model_summary(est: object) -> dict:
    """The fitted SS_KF matrices of the JSON contract (nested lists via :func:`to_jsonable`)."""
    return {
        "order": est.order_, "dt_s": est.dt_s,
        "A": est.A_, "B": est.B_, "C": est.C_, "Gamma": est.Gamma_,
        "Q": est.Q_, "R": est.R_, "sigma_w2": est.sigma_w2_,
        "predictor_gain": est.predictor_gain_, "filter_gain": est.filter_gain_,
        "poles_abs": np.abs(est.poles_), "kalman_poles_abs": np.abs(est.kalman_poles_),
        "stable": est.stable_, "controllable": est.controllable_, "observable": est.observable_,
    }


@dataclass
class SubjectScore:
    """Every estimator fitted and scored on one subject's recording.

    Attributes
    ----------
    results : dict
        :func:`estimation.evaluation.evaluate_subject`'s result.
    params : dict
        ``{name: {hyperparameter: value}}`` each estimator was made with.
    info : dict
        ``subject_id``, ``n_windows``, ``n_identification``, ``duration_s``.
    order_curve : dict or None
        The AIC over candidate orders (:func:`order_curve`), when ``ss_kf`` was fitted
        and orders were asked for.
    inner : dict or None
        Estimator name -> free_run R^2 on the inner split of the identification half
        (:func:`estimation.evaluation.inner_scores`), when asked for.
    """

    results: dict
    params: dict[str, dict]
    info: dict = field(default_factory=dict)
    order_curve: dict | None = None
    inner: dict | None = None


@dataclass(frozen=True)
class ScoreSettings:
    """What the estimators of the paper's protocol are fitted with.

    Attributes
    ----------
    channels : sequence of int (1-based) or str, or None
        sEMG channels whose MAV, RMS and WL are the inputs (``None``: all).
    order : int
        SS order; NARX delays and hidden units follow it.
    nn_params : mapping, optional
        Overrides for the MLP/NARX hyperparameters.
    """

    channels: Sequence[int | str] | None = PAPER_CHANNELS
    order: int = PAPER_ORDER
    nn_params: Mapping[str, object] | None = None


def score_recording(
    recording: Recording,
    estimators: Sequence[str],
    *,
    rng: np.random.Generator | int | None,
    settings: ScoreSettings = ScoreSettings(),
    orders: Sequence[int] | None = None,
    subject_id: int | None = None,
    inner: Sequence[str] = (),
) -> tuple[SubjectScore, FeatureSet]:
    """The paper's protocol on one recording: features, then fit-then-score.

    Parameters
    ----------
    recording : Recording
        sEMG with the measured force ``force_n``.
    estimators : sequence of str
        Registry names.
    rng : numpy.random.Generator, int or None
        Seeds the estimators (:func:`estimation.evaluation.fit_and_score`).
    settings : ScoreSettings
        The input channels, the model order and the network overrides (default: the
        paper's channels and order).
    orders : sequence of int, optional
        Candidate orders for the AIC curve (needs ``ss_kf``); ``None``: no curve.
    subject_id : int, optional
        For the score's ``info``.
    inner : sequence of str
        Estimators (of ``estimators``) also scored on the inner split of the
        identification half, each with its outer fit's seed (``SubjectScore.inner``);
        empty: none.

    Returns
    -------
    score : SubjectScore
    features : FeatureSet
        The recording's features, ``X`` shape (n_windows, n_inputs).
    """
    channels, order, nn_params = settings.channels, settings.order, settings.nn_params
    fs = extract_features(recording, channels=channels)
    seeds = np.random.default_rng(rng)
    seed_state = seeds.bit_generator.state
    results, params = fit_and_score(fs, estimators, rng=seeds, order=order, nn_params=nn_params)
    n_id = split_index(fs.n_windows)
    info = {"subject_id": subject_id, "n_windows": fs.n_windows, "n_identification": n_id,
            "duration_s": recording.duration_s}
    curve = None
    if orders is not None and "ss_kf" in results and "_pipeline" in results["ss_kf"]:
        curve = order_curve(subject_id, results["ss_kf"]["_pipeline"], fs, n_id, orders)
    inner_r2 = None
    if inner:
        seeds.bit_generator.state = seed_state  # the outer fits' seeds, as on the real halves
        inner_r2 = inner_scores(fs, estimators, rng=seeds, order=order, nn_params=nn_params,
                                only=inner)
    return SubjectScore(results, params, info, curve, inner_r2), fs


def population_result(scores: Sequence[SubjectScore], *, config: dict,
                      order: int = PAPER_ORDER,
                      judged: Sequence[SubjectScore] | None = None,
                      judge: Mapping[str, object] | None = None) -> dict:
    """The JSON contract of a population's scores (see the module docstring).

    Parameters
    ----------
    scores : sequence of SubjectScore
        One per subject, in subject order; the first gives the ``training``
        settings and the first with a fitted ``ss_kf`` the ``model``.
    config : dict
        The run's settings, stored as ``config`` (``estimators`` and ``channels``
        are read from it).
    order : int
        The SS order the tables use.
    judged : sequence of SubjectScore, optional
        The same estimators on subjects of a population none of them was trained on:
        ``out_of_population`` (:mod:`estimation.verdicts` judges with it).
    judge : mapping, optional
        What ``judged`` is: ``population``, ``description``, ``generator``, ``seed``.

    Returns
    -------
    dict
        JSON-serializable (:func:`to_jsonable`); private keys dropped.
    """
    per_subject = [s.results for s in scores]
    result = aggregate(per_subject)
    result["model"] = next((model_summary(r["ss_kf"]["_pipeline"].estimator)
                            for r in per_subject if "_pipeline" in r.get("ss_kf", {})), None)
    curves = [s.order_curve for s in scores if s.order_curve is not None]
    result["order_selection"] = {
        "per_subject": curves,
        "chosen_orders": [c["order"] for c in curves],
        "order_used": order,
        "paper_order": PAPER_ORDER,
    }
    result["properties"] = _properties(per_subject)
    result["subjects"] = [s.info for s in scores]
    result["config"] = config
    result["nn_epochs"] = {name: [r[name]["info"].get("n_epochs") for r in per_subject]
                           for name in config["estimators"] if estimator_info(name)["neural"]}
    result["training"] = training_settings(scores[0].params, _pipelines(scores[0].results))
    if judged:
        result["out_of_population"] = dict(judge or {}, n_subjects=len(judged),
                                           estimators=aggregate([j.results for j in judged])[
                                               "estimators"])
    result["recommendation"] = recommendation(result)
    result["transfer"] = transfer_table(result)
    return to_jsonable(result)


def _pipelines(evaluated: dict) -> dict:
    """The fitted pipelines of :func:`estimation.evaluation.evaluate_subject`'s result, by name."""
    return {n: r["_pipeline"] for n, r in evaluated.items() if "_pipeline" in r}


def order_curve(subject_id: int | None, pipeline: object, fs: FeatureSet, n_id: int,
                orders: Sequence[int]) -> dict:
    """The AIC over candidate orders on the identification part of a subject's session.

    Parameters
    ----------
    pipeline : ForcePipeline
        The fitted SS + KF pipeline (its scaling is reused).
    fs : FeatureSet
        The session's features, ``X`` shape (n_windows, n_features), ``y`` in N.
    n_id : int
        Windows of the identification part.
    orders : sequence of int
        Candidate orders.
    """
    sel = select_order(pipeline.scaling_.transform_u(fs.X[:n_id]),
                       pipeline.scaling_.transform_y(fs.y[:n_id]), orders=orders,
                       dt_s=fs.dt_s)
    return {"subject_id": subject_id, "orders": sel.orders, "aic": sel.aic,
            "order": sel.order, "n_obs": sel.n_obs}


def _properties(per_subject: Sequence[dict]) -> dict:
    """Counts of controllable / observable / stable identified models per estimator."""
    props: dict = {}
    for name in per_subject[0]:
        infos = [s[name]["info"] for s in per_subject if s[name]["info"]]
        if infos and "stable" in infos[0]:
            props[name] = {key: sum(bool(i[key]) for i in infos)
                           for key in ("controllable", "observable", "stable")}
            props[name]["n"] = len(infos)
    return props


# ------------------------------------------------------------------ formatting
def format_table2(result: dict, mode: str) -> str:
    """Paper Table 2 (per-subject R^2 / NRMSE) in one mode, with the paper's rows below."""
    est = result["estimators"]
    names = [n for n in PAPER_ESTIMATORS if n in est and mode in est[n]]
    head = f"{'':10s}" + "".join(f"{estimator_label(n) + ' R2':>11s}{'NRMSE':>8s}" for n in names)
    lines = [f"Table 2 ({mode}) -- ours, virtual subjects", head]
    n_sub = len(est[names[0]][mode]["per_subject"]) if names else 0
    for i in range(n_sub):
        row = f"{'V' + str(i + 1):10s}"
        for n in names:
            r = est[n][mode]["per_subject"][i]
            row += f"{cell(r['r2'], 11)}{cell(r['nrmse'])}"
        lines.append(row)
    for label, key in (("Average", "mean"), ("SD", "sd")):
        row = f"{label:10s}"
        for n in names:
            e = est[n][mode]
            row += f"{cell(e['r2_' + key], 11)}{cell(e['nrmse_' + key])}"
        lines.append(row)
    for label, idx in (("Paper avg", (0, 2)), ("Paper SD", (1, 3))):
        row = f"{label:10s}"
        for n in names:
            p = TABLE2_SUMMARY[n]
            row += f"{p[idx[0]]:>11.4f}{p[idx[1]]:>8.4f}"
        lines.append(row)
    unstable = [n for n in names if est[n][mode]["n_ok"] < n_sub]
    for n in unstable:
        lines.append(f"  {estimator_label(n)}: {n_sub - est[n][mode]['n_ok']} subject(s) unstable, "
                     "excluded from the mean")
    return "\n".join(lines)


def format_others(result: dict, mode: str) -> str:
    """Mean +/- SD of the estimators outside Table 2 in one mode, with section 4.2 figures."""
    est = result["estimators"]
    lines = [f"Other estimators ({mode}): R2 mean +/- SD, NRMSE mean +/- SD, RMSE (N)"]
    paper_ref = {"ss": SECTION_4_2["ss"] if mode == "one_step" else None,
                 "features_mav": SECTION_4_2["features"], "features_rms": SECTION_4_2["features"],
                 "features_wl": SECTION_4_2["features"]}
    for n in est:
        if n in PAPER_ESTIMATORS or mode not in est[n]:
            continue
        e = est[n][mode]
        line = (f"  {estimator_label(n):10s} R2 {cell(e['r2_mean'], 7)} +/- {cell(e['r2_sd'], 6)}"
                f" (min {cell(e.get('r2_min'), 6, 3)})"
                f"  NRMSE {cell(e['nrmse_mean'], 7)} +/- {cell(e['nrmse_sd'], 6)}"
                f"  RMSE {cell(e['rmse_n_mean'], 6, 2)} N")
        ref = paper_ref.get(n)
        if ref is not None:
            line += (f"   paper R2 {ref[0]:.4f} +/- {ref[1]:.4f}, "
                     f"NRMSE {ref[2]:.4f} +/- {ref[3]:.4f}")
        lines.append(line)
    return "\n".join(lines)


def format_table3(result: dict) -> str:
    """Paper Table 3: training time, loop runtime and system properties, ours vs paper."""
    timing, props = result["timing"], result.get("properties", {})
    lines = ["Table 3 -- training time (ms, mean +/- SD), loop runtime (ms per update, "
             "median), controllable/observable/stable (ours: count of subjects)",
             f"{'model':9s}{'train ours':>20s}{'train paper':>18s}{'loop ours':>11s}"
             f"{'loop paper':>18s}{'ctrb/obsv/stable ours':>24s}{'paper':>14s}"]
    for n in PAPER_ESTIMATORS:
        if n not in timing:
            continue
        t, p = timing[n], TABLE3[n]
        if t["train_ms_mean"] is None:
            lines.append(f"{estimator_label(n):9s} failed on every subject")
            continue
        loop = t["step_us_median"]
        loop_ms = "n/a" if loop is None else f"{loop / 1e3:.5f}"
        if n in props:
            q = props[n]
            ours = f"{q['controllable']}/{q['observable']}/{q['stable']} of {q['n']}"
        else:
            ours = "-/-/-"
        paper_p = f"{p['controllable']}/{p['observable']}/{p['stable']}"
        lines.append(
            f"{estimator_label(n):9s}{t['train_ms_mean']:>11.2f} +/- {t['train_ms_sd']:<7.2f}"
            f"{p['train_ms'][0]:>9.2f} +/- {p['train_ms'][1]:<6.2f}{loop_ms:>11s}"
            f"{p['loop_ms'][0]:>10.5f} +/- {p['loop_ms'][1]:<5.4f}{ours:>22s}{paper_p:>14s}"
        )
    epochs = result.get("nn_epochs", {})
    for n, counts in epochs.items():
        lines.append(f"  {estimator_label(n)} epochs (early stop on a validation split of the "
                     f"identification half): {counts}")
    return "\n".join(lines)


def format_report(result: dict) -> str:
    """Every table of the reproduction as plain text."""
    parts = []
    for mode in ("one_step", "free_run"):
        parts += [format_table2(result, mode), format_others(result, mode)]
    parts.append(format_table3(result))
    parts.append(format_deployable(result))
    for extra in (format_out_of_population(result), format_transfer(result),
                  format_inner_outer(result)):
        if extra:
            parts.append(extra)
    sel = result.get("order_selection", {})
    if sel.get("chosen_orders"):
        parts.append(f"AIC order per subject (1..12): {sel['chosen_orders']}; tables use "
                     f"n = {sel['order_used']} (paper: {sel['paper_order']})")
    return "\n\n".join(parts)


def write_csv(result: dict, directory: str | Path) -> list[Path]:
    """Write ``table2_one_step.csv``, ``table2_free_run.csv`` and ``table3.csv``."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    est = result["estimators"]
    for mode in ("one_step", "free_run"):
        names = [n for n in est if mode in est[n]]
        path = out / f"table2_{mode}.csv"
        with path.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["subject"] + [f"{n}_{m}" for n in names for m in ("r2", "nrmse")])
            n_sub = len(est[names[0]][mode]["per_subject"])
            for i in range(n_sub):
                w.writerow([f"V{i + 1}"] + [est[n][mode]["per_subject"][i][m]
                                            for n in names for m in ("r2", "nrmse")])
        written.append(path)
    path = out / "table3.csv"
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["model", "training_time_ms_mean", "training_time_ms_sd",
                    "training_time_ms_median", "loop_runtime_ms_median", "controllable",
                    "observable", "stable"])
        for n, t in result["timing"].items():
            q = result.get("properties", {}).get(n)
            loop = t["step_us_median"]
            w.writerow([n, t["train_ms_mean"], t["train_ms_sd"], t["train_ms_median"],
                        None if loop is None else loop / 1e3,
                        *(["-"] * 3 if q is None else
                          [q["controllable"], q["observable"], q["stable"]])])
    written.append(path)
    return written


def evaluate_recording(
    recording: Recording,
    *,
    channels: str | Sequence[int | str] | None = PAPER_CHANNELS,
    estimators: Sequence[str] | None = None,
    order: int = PAPER_ORDER,
    seed: int = 0,
    nn_params: dict | None = None,
) -> dict:
    """The paper's protocol on one recording (simulated or real, any sampling rate).

    Parameters
    ----------
    recording : sim.Recording
        Must carry the measured force ``force_n``.
    channels : "all", sequence of int (1-based) or str
        sEMG channels whose MAV, RMS and WL are the inputs.
    estimators : sequence of str, optional
        Registered estimators (default: every one).
    order, nn_params
        The state-space order and the networks' settings, as in :class:`ScoreSettings`.
    seed : int
        Seeds the networks (:func:`estimation.evaluation.fit_and_score`).

    Returns
    -------
    dict
        ``estimators``, ``timing``, ``model`` (if ``ss_kf`` ran), ``properties``
        and ``recording`` (source, windows, split).

    Raises
    ------
    EstimationInputError
        The recording has no force.
    """
    if recording.force_n is None:
        raise EstimationInputError(
            f"{recording.source}: no force column; the protocol needs the measured force"
        )
    channels = parse_channels(channels)
    estimators = estimator_names() if estimators is None else tuple(estimators)
    score, fs = score_recording(recording, estimators, rng=seed,
                                settings=ScoreSettings(channels, order, nn_params))
    res = score.results
    result = aggregate([res])
    result["training"] = training_settings(score.params, _pipelines(res))
    if "ss_kf" in res and "_pipeline" in res["ss_kf"]:
        result["model"] = model_summary(res["ss_kf"]["_pipeline"].estimator)
    result["properties"] = _properties([res])
    result["recording"] = {"source": recording.source, "fs_hz": recording.fs_hz,
                           "channels": channel_label(channels), "n_windows": fs.n_windows,
                           "n_identification": split_index(fs.n_windows), "dt_s": fs.dt_s}
    return to_jsonable(result)


def format_summary(result: dict) -> str:
    """One line per estimator and mode: R^2, NRMSE, RMSE, training and step time."""
    lines = [f"{'estimator':13s}{'mode':10s}{'R2':>8s}{'NRMSE':>8s}{'RMSE N':>8s}"
             f"{'train ms':>10s}{'step us':>9s}"]
    for name, modes in result["estimators"].items():
        t = result["timing"][name]
        for mode, e in modes.items():
            step = t["step_us_median"]
            line = (f"{name:13s}{mode:10s}{cell(e['r2_mean'])}{cell(e['nrmse_mean'])}"
                    f"{cell(e['rmse_n_mean'], 8, 2)}{cell(t['train_ms_median'], 10, 2)}"
                    f"{'n/a' if step is None else f'{step:.2f}':>9s}")
            bad = [r["status"] for r in e["per_subject"] if r["status"] != "ok"]
            if bad:
                line += f"  ({', '.join(sorted(set(bad)))}: not run)"
            lines.append(line)
    return "\n".join(lines)
