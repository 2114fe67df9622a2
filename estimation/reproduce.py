"""Reproduction of the paper's Tables 2 and 3 on virtual subjects.

This module is the only place that depends on the virtual-subject API
(:func:`sim.user.subjects.make_population`, ``VirtualSubject.paper_session``).

``run_reproduction`` returns the JSON contract::

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
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from estimation.errors import EstimationInputError
from estimation.evaluation import aggregate, evaluate_subject, split_index
from estimation.features import PAPER_CHANNELS, extract_features
from estimation.order import select_order
from estimation.paper import PAPER_ORDER, SECTION_4_2, TABLE2_SUMMARY, TABLE3
from estimation.real_recordings import SOURCE as REAL_SOURCE
from estimation.real_recordings import real_free_run, transfer_agreement
from estimation.recommendation import recommend
from estimation.registry import (
    deployable_estimators,
    estimator_info,
    estimator_label,
    estimator_names,
    paper_estimators,
)
from estimation.threads import one_blas_thread

#: Paper Table 2/3 estimators, in the paper's column order (``register_estimator(paper=True)``).
PAPER_ESTIMATORS = paper_estimators()
#: Estimators that need no force sensor at run time (``register_estimator(deployable=True)``).
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


def estimator_params(names: Sequence[str], rng: np.random.Generator, order: int,
                     nn_params: dict | None = None, *, dt_s: float) -> dict[str, dict]:
    """Hyperparameters per estimator: SS order and sample time, NARX delays, NN seeds."""
    params: dict[str, dict] = {}
    for name in names:
        info = estimator_info(name)
        p: dict = {}
        if "order" in info["order_params"]:
            p["order"] = order
        if info["takes_dt"]:
            p["dt_s"] = dt_s
        if info["takes_seed"]:
            p["random_state"] = int(rng.integers(0, 2**31 - 1))
        p.update({k: order for k in info["order_params"] if k != "order"})
        if info["neural"]:
            p.update(nn_params or {})
        params[name] = p
    return params


def run_reproduction(
    n_subjects: int = 10,
    seed: int = 0,
    *,
    generator: str = "noise",
    order: int = PAPER_ORDER,
    estimators: Sequence[str] | None = None,
    orders: Sequence[int] = tuple(range(1, 13)),
    nn_params: dict | None = None,
    channels: str | Sequence[int | str] | None = PAPER_CHANNELS,
    workers: int = 1,
) -> dict:
    """Run the paper's protocol on ``n_subjects`` virtual subjects.

    Parameters
    ----------
    n_subjects : int
        Population size (paper: 10).
    seed : int
        Seeds the population, each session and the networks' initialization.
    generator : {"noise", "motor_units"}
        Virtual subjects' sEMG model.
    order : int
        SS order used for the tables (paper: 4); NARX delays and hidden units follow it.
    estimators : sequence of str
        Registry names to evaluate (must include ``"ss_kf"`` for the ``model`` entry);
        ``None``: every registered estimator.
    orders : sequence of int
        Candidate orders for the per-subject AIC curve (paper: 1..12).
    nn_params : dict, optional
        Overrides for the MLP/NARX hyperparameters (e.g. ``{"max_epochs": 50}``).
    channels : "all", sequence of int (1-based) or str
        sEMG channels whose MAV, RMS and WL are the inputs (paper: 6, 7, 8).
    workers : int
        Subjects evaluated at once, each in a process forked from this one (default 1:
        in this process). Every subject has its own seeds, so the figures do not depend
        on it; only the training times do, when the processes share cores.

    Returns
    -------
    dict
        The JSON contract (see the module docstring); private keys start with ``_``.
    """
    from sim.user.subjects import make_population  # the only dependency on the subject API

    channels = parse_channels(channels)
    estimators = estimator_names() if estimators is None else tuple(estimators)
    if int(workers) < 1:
        raise EstimationInputError(f"workers: expected at least 1, found {workers}")

    with one_blas_thread():
        return _run(make_population, n_subjects, seed, generator, order, estimators, orders,
                    nn_params, channels, int(workers))


def _run(make_population: object, n_subjects: int, seed: int, generator: str, order: int,
         estimators: Sequence[str], orders: Sequence[int], nn_params: dict | None,
         channels: Sequence[int | str] | None, workers: int = 1) -> dict:
    subjects = make_population(n=n_subjects, seed=seed)
    children = np.random.SeedSequence([seed, 0x5EED]).spawn(n_subjects)
    jobs = [(subject, child, generator, channels, estimators, order, nn_params, orders)
            for subject, child in zip(subjects, children, strict=True)]
    done = _map_subjects(jobs, workers)
    per_subject = [d["result"] for d in done]
    features_info = [d["features"] for d in done]
    order_curves = [d["order_curve"] for d in done if d["order_curve"] is not None]
    model = next((d["model"] for d in done if d["model"] is not None), None)
    training = done[0]["training"] if done else {}
    result = aggregate(per_subject)
    result["model"] = model
    result["order_selection"] = {
        "per_subject": order_curves,
        "chosen_orders": [c["order"] for c in order_curves],
        "order_used": order,
        "paper_order": PAPER_ORDER,
    }
    result["properties"] = _properties(per_subject)
    result["subjects"] = features_info
    result["config"] = {"n_subjects": n_subjects, "seed": seed, "generator": generator,
                        "order": order, "channels": channel_label(channels),
                        "identification_fraction": 0.5, "estimators": list(estimators),
                        "nn_params": nn_params or {}}
    result["nn_epochs"] = {name: [s[name]["info"].get("n_epochs") for s in per_subject]
                           for name in estimators if estimator_info(name)["neural"]}
    result["training"] = training
    result["recommendation"] = recommendation(result)
    result["transfer"] = transfer_table(result)
    return to_jsonable(result)


def _evaluate_one(job: tuple) -> dict:
    """One subject of :func:`run_reproduction`: session, features, every estimator, AIC curve.

    Returns plain data (no fitted pipeline), so that a worker process can send it back.
    """
    subject, child, generator, channels, estimators, order, nn_params, orders = job
    session_ss, est_ss = child.spawn(2)
    rec = subject.paper_session(rng=np.random.default_rng(session_ss), generator=generator)
    fs = extract_features(rec, channels=channels)
    params = estimator_params(estimators, np.random.default_rng(est_ss), order, nn_params,
                              dt_s=fs.dt_s)
    res = evaluate_subject(fs.X, fs.y, params, dt_s=fs.dt_s)
    n_id = split_index(fs.n_windows)
    ss_kf = res.get("ss_kf", {}).get("_pipeline")
    return {
        "result": {name: {k: v for k, v in r.items() if k != "_pipeline"}
                   for name, r in res.items()},
        "training": training_settings(params, _pipelines(res)),
        "features": {"subject_id": subject.subject_id, "n_windows": fs.n_windows,
                     "n_identification": n_id, "duration_s": rec.duration_s},
        "model": None if ss_kf is None else model_summary(ss_kf.estimator),
        "order_curve": None if ss_kf is None else _order_curve(subject.subject_id, ss_kf, fs,
                                                                n_id, orders),
    }


def _evaluate_in_worker(job: tuple) -> dict:
    """:func:`_evaluate_one` in a forked worker: one thread for BLAS and OpenMP alike.

    The workers already use the cores. And an OpenMP thread pool the parent started (say,
    for scikit-learn's gradient boosting) does not survive ``fork``: a child that asked it
    for threads would wait for them forever; with one thread it never does.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        return _evaluate_one(job)


def _map_subjects(jobs: list[tuple], workers: int) -> list[dict]:
    """:func:`_evaluate_one` of every job, in order: here, or on ``workers`` forked processes.

    Forked workers inherit the registries (plugins, pretraining corpora) and the pretrained
    networks already in memory; where processes cannot be forked, the jobs run here.
    """
    import multiprocessing

    workers = min(workers, len(jobs))
    if workers <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [_evaluate_one(job) for job in jobs]
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(_evaluate_in_worker, jobs))


def _pipelines(evaluated: dict) -> dict:
    """The fitted pipelines of :func:`estimation.evaluation.evaluate_subject`'s result, by name."""
    return {n: r["_pipeline"] for n, r in evaluated.items() if "_pipeline" in r}


def _order_curve(subject_id: int, pipeline: object, fs: object, n_id: int,
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
def _fmt(value: float | None, width: int = 8, digits: int = 4) -> str:
    return f"{'n/a':>{width}}" if value is None else f"{value:>{width}.{digits}f}"


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
            row += f"{_fmt(r['r2'], 11)}{_fmt(r['nrmse'])}"
        lines.append(row)
    for label, key in (("Average", "mean"), ("SD", "sd")):
        row = f"{label:10s}"
        for n in names:
            e = est[n][mode]
            row += f"{_fmt(e['r2_' + key], 11)}{_fmt(e['nrmse_' + key])}"
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
        line = (f"  {estimator_label(n):10s} R2 {_fmt(e['r2_mean'], 7)} +/- {_fmt(e['r2_sd'], 6)}"
                f" (min {_fmt(e.get('r2_min'), 6, 3)})"
                f"  NRMSE {_fmt(e['nrmse_mean'], 7)} +/- {_fmt(e['nrmse_sd'], 6)}"
                f"  RMSE {_fmt(e['rmse_n_mean'], 6, 2)} N")
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


def free_run_summary(result: dict) -> dict[str, dict]:
    """``{name: {"r2_mean", "r2_min", "n_ok", "n"}}`` of every estimator with a free_run mode."""
    est = result["estimators"]
    return {n: {"r2_mean": est[n]["free_run"]["r2_mean"], "r2_min": est[n]["free_run"]["r2_min"],
                "n_ok": est[n]["free_run"]["n_ok"], "n": len(est[n]["free_run"]["per_subject"])}
            for n in est if "free_run" in est[n]}


def recommendation(result: dict) -> dict | None:
    """The JSON contract's ``recommendation`` (:func:`estimation.recommendation.recommend`)."""
    channels = result.get("config", {}).get("channels", result.get("recording", {}).get(
        "channels"))
    ref = result["estimators"].get("ss_kf", {}).get("one_step", {}).get("r2_mean")
    return recommend(free_run_summary(result), channels=channels, one_step_reference=ref)


def transfer_table(result: dict) -> dict | None:
    """Virtual next to real per estimator (free_run), with the agreement of issue 18.

    Only for all 8 channels, the real recordings' setting; None otherwise.
    """
    if result.get("config", {}).get("channels") != "all":
        return None
    summary = free_run_summary(result)
    agreement = transfer_agreement({n: e["r2_mean"] for n, e in summary.items()})
    rows = []
    for n in summary:
        real = real_free_run(n)
        rows.append({"estimator": n, "virtual_mean": summary[n]["r2_mean"],
                     "virtual_min": summary[n]["r2_min"],
                     "real_mean": None if real is None else real["r2_mean"],
                     "real_min": None if real is None else real["r2_min"]})
    rows.sort(key=lambda r: -(r["real_mean"] if r["real_mean"] is not None else -9.0))
    return {"source": REAL_SOURCE, "rows": rows, "agreement": agreement}


def format_transfer(result: dict) -> str:
    """The virtual-vs-real table and the agreement line (empty without ``transfer``)."""
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
        lines.append(f"  {r['estimator']:13s}{_fmt(vm, 13, 3)}{_fmt(r['virtual_min'], 9, 2)}"
                     f"{_fmt(real, 11, 3)}{_fmt(r['real_min'], 9, 2)}"
                     f"{'' if diff is None else f'{diff:+12.3f}'}")
    a = tr["agreement"]
    if a["spearman"] is None:
        lines.append(f"  agreement: fewer than 3 estimators reach {a['floor']} on either side")
    else:
        lines.append(
            f"  agreement over the {a['n']} estimators reaching R2 {a['floor']} on either side: "
            f"Spearman {a['spearman']:.2f} (goal >= {a['thresholds']['spearman']}), mean "
            f"|virtual - real| {a['mean_abs_diff']:.3f} (<= {a['thresholds']['mean_abs_diff']}),"
            f" largest {a['max_abs_diff']:.3f} for {a['worst']} "
            f"(<= {a['thresholds']['max_abs_diff']})")
    return "\n".join(lines)


def format_deployable(result: dict) -> str:
    """Deployable (sEMG-only) estimators: free_run mean, SD, worst subject, timing, verdict."""
    est, timing = result["estimators"], result["timing"]
    lines = ["Deployable estimators (free_run: sEMG only) -- R2 mean +/- SD, worst subject, "
             "training ms (median), step us (median)"]
    names = [n for n in est if "free_run" in est[n]]
    names.sort(key=lambda n: -(est[n]["free_run"]["r2_mean"] or -np.inf))
    for n in names:
        e, t = est[n]["free_run"], timing[n]
        tag = " *" if n in DEPLOYABLE_ESTIMATORS else ""
        lines.append(f"  {estimator_label(n) + tag:12s} R2 {_fmt(e['r2_mean'], 7)} +/- "
                     f"{_fmt(e['r2_sd'], 6)}  min {_fmt(e.get('r2_min'), 7)}  "
                     f"n_ok {e['n_ok']}/{len(e['per_subject'])}  train "
                     f"{_fmt(t['train_ms_median'], 8, 1)} ms  step "
                     f"{_fmt(t['step_us_median'], 6, 1)} us")
    for n in ("ss_kf", "persistence", "narx"):
        if n in est and "one_step" in est[n]:
            e = est[n]["one_step"]
            lines.append(f"  reference {estimator_label(n):9s} one_step R2 {_fmt(e['r2_mean'], 7)} "
                         f"(min {_fmt(e.get('r2_min'), 6, 3)}; needs the measured force)")
    lines.append("  (* built for deployment: all settings chosen on a validation split of the "
                 "identification half)")
    rec = result.get("recommendation") or recommendation(result)
    lines.append(rec["reason"] if rec else "No estimator ran in free_run on every subject; "
                 "none can be recommended.")
    return "\n".join(lines)


def format_report(result: dict) -> str:
    """Every table of the reproduction as plain text."""
    parts = []
    for mode in ("one_step", "free_run"):
        parts += [format_table2(result, mode), format_others(result, mode)]
    parts.append(format_table3(result))
    parts.append(format_deployable(result))
    if result.get("transfer"):
        parts.append(format_transfer(result))
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
    recording: object,
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
    estimators, order, nn_params
        As for :func:`run_reproduction`.
    seed : int
        Seeds the networks.

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
    fs = extract_features(recording, channels=channels)
    params = estimator_params(estimators, np.random.default_rng(seed), order, nn_params,
                              dt_s=fs.dt_s)
    with one_blas_thread():
        res = evaluate_subject(fs.X, fs.y, params, dt_s=fs.dt_s)
    result = aggregate([res])
    result["training"] = training_settings(params, _pipelines(res))
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
            line = (f"{name:13s}{mode:10s}{_fmt(e['r2_mean'])}{_fmt(e['nrmse_mean'])}"
                    f"{_fmt(e['rmse_n_mean'], 8, 2)}{_fmt(t['train_ms_median'], 10, 2)}"
                    f"{'n/a' if step is None else f'{step:.2f}':>9s}")
            bad = [r["status"] for r in e["per_subject"] if r["status"] != "ok"]
            if bad:
                line += f"  ({', '.join(sorted(set(bad)))}: not run)"
            lines.append(line)
    return "\n".join(lines)
