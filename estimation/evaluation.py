"""The paper's evaluation protocol on one feature set, and aggregation over subjects.

Per subject (paper section 3.3): features and force are normalized 0..1 on the
identification part; the first 50 % of windows identifies, the last 50 %
validates. Every estimator is fitted on the identification part and run over
the whole record (its state carries over, so the validation part starts warm);
metrics are computed on the validation part only. ``one_step`` predictions see
the measured force up to ``k - 1``; ``free_run`` predictions see sEMG only.

Result of :func:`evaluate_subject` (JSON-serializable)::

    {name: {"train_ms": float, "step_us": float, "step_mode": str,
            "modes": {mode: {"r2", "nrmse", "rmse_n", "volatility_n_per_s",
                             "status"}},      # "ok", "unstable", "riccati_failed" or
                                              # "unsupported" (inputs it cannot take)
            "info": {...},                    # order, stability, epochs...
            "_pipeline": ForcePipeline}}      # the fitted estimator (not serialized)

:func:`fit_and_score` is the one fit-then-score of griploop: it makes the estimators
(:func:`estimator_params`, seeded from the caller's generator) and runs
:func:`evaluate_subject` on one feature set. The reproduction, the evaluation of a
recording and a calibration all call it; they differ only in the generator they pass.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

import numpy as np

from estimation.errors import (
    EstimationInputError,
    InsufficientDataError,
    RiccatiError,
    UnstableModelError,
    check_features,
    check_target,
)
from estimation.features import FeatureSet
from estimation.metrics import nrmse_fit, r2_score, rmse, total_variation_rate
from estimation.paper import PAPER_ORDER
from estimation.pipeline import ForcePipeline
from estimation.registry import estimator_info, make_estimator
from estimation.threads import one_blas_thread

#: Fraction of windows used for identification (paper: 50 %).
IDENTIFICATION_FRACTION = 0.5


def split_index(n_samples: int, fraction: float = IDENTIFICATION_FRACTION) -> int:
    """Number of identification windows: ``floor(fraction * n_samples)``.

    Raises
    ------
    InsufficientDataError
        Fewer than 2 windows on either side.
    """
    n_id = int(np.floor(fraction * n_samples))
    if n_id < 2 or n_samples - n_id < 2:
        raise InsufficientDataError(
            f"{n_samples} windows split at {fraction:.0%} leave {n_id}/{n_samples - n_id}; "
            "expected at least 2 on each side"
        )
    return n_id


def _step_times_us(stream: object, U: np.ndarray, y: np.ndarray, uses_force: bool) -> float:
    """Median wall time of one ``stream.step`` over the rows of ``U`` in microseconds."""
    stream.reset()
    clock = time.perf_counter_ns
    times = np.empty(U.shape[0])
    step = stream.step
    prev = None
    for k in range(U.shape[0]):
        u = U[k]
        t0 = clock()
        step(u, prev)
        times[k] = clock() - t0
        if uses_force:
            prev = float(y[k])
    return float(np.median(times) / 1e3)


def _info(est: object) -> dict:
    info: dict = {}
    for attr in ("order_", "n_epochs_", "converged_", "stable_", "controllable_", "observable_"):
        if hasattr(est, attr):
            info[attr.rstrip("_")] = getattr(est, attr)
    return info


def evaluate_subject(
    U: np.ndarray,
    y_n: np.ndarray,
    estimators: Mapping[str, Mapping[str, object]] | Sequence[str],
    *,
    dt_s: float,
    fraction: float = IDENTIFICATION_FRACTION,
    time_steps: bool = True,
) -> dict:
    """Fit and score estimators on one subject's features.

    Parameters
    ----------
    U : ndarray, shape (n_windows, n_inputs)
        Raw features (e.g. ``FeatureSet.X``).
    y_n : ndarray, shape (n_windows,)
        Measured force in newtons aligned to the windows.
    estimators : sequence of names, or mapping name -> hyperparameters
        Registry names (see :mod:`estimation.registry`).
    dt_s : float
        Window increment in seconds (volatility is per second).
    fraction : float
        Identification fraction.
    time_steps : bool
        Measure the median streaming step time.

    Returns
    -------
    dict
        See the module docstring.
    """
    U = check_features(U)
    y_n = check_target(y_n, U.shape[0], name="y_n")
    n_id = split_index(U.shape[0], fraction)
    specs = {name: {} for name in estimators} if not isinstance(estimators, Mapping) \
        else {k: dict(v) for k, v in estimators.items()}
    y_val = y_n[n_id:]
    out: dict = {}
    first_input_error: list[EstimationInputError] = []
    for name, params in specs.items():
        pipe: ForcePipeline = make_estimator(name, **params)
        t0 = time.perf_counter()
        try:
            pipe.fit(U[:n_id], y_n[:n_id])
        except (RiccatiError, EstimationInputError) as exc:
            # reported per estimator, never silently replaced by another design: a
            # Riccati failure, or inputs this estimator cannot take (a channel set a
            # pretrained estimator lacks); the other estimators still run
            status = "riccati_failed" if isinstance(exc, RiccatiError) else "unsupported"
            if status == "unsupported":
                first_input_error.append(exc)
            failed = {"r2": None, "nrmse": None, "rmse_n": None, "volatility_n_per_s": None,
                      "status": status, "message": str(exc)}
            out[name] = {"train_ms": None, "step_us": None, "step_mode": None,
                         "modes": {m: dict(failed) for m in pipe.modes}, "info": {}}
            continue
        train_ms = (time.perf_counter() - t0) * 1e3
        modes: dict = {}
        for mode in pipe.modes:
            try:
                y_hat = pipe.predict(U, y_n, mode=mode)[n_id:]
            except UnstableModelError as exc:
                modes[mode] = {"r2": None, "nrmse": None, "rmse_n": None,
                               "volatility_n_per_s": None, "status": "unstable",
                               "message": str(exc)}
                continue
            modes[mode] = {
                "r2": r2_score(y_val, y_hat),
                "nrmse": nrmse_fit(y_val, y_hat),
                "rmse_n": rmse(y_val, y_hat),
                "volatility_n_per_s": total_variation_rate(y_hat, dt_s),
                "status": "ok",
            }
        step_mode = next((m for m in ("one_step", "free_run")
                          if m in modes and modes[m]["status"] == "ok"), None)
        step_us = None
        if time_steps and step_mode is not None:
            stream = pipe.streaming(step_mode)
            step_us = _step_times_us(stream, U[n_id:], y_val, stream.uses_force)
        out[name] = {"train_ms": train_ms, "step_us": step_us, "step_mode": step_mode,
                     "modes": modes, "info": _info(pipe.estimator), "_pipeline": pipe}
    if out and all("_pipeline" not in r for r in out.values()) and first_input_error:
        raise first_input_error[0]  # the recording itself is unusable: say why, once
    return out


def estimator_params(names: Sequence[str], rng: np.random.Generator, order: int,
                     nn_params: Mapping[str, object] | None = None, *,
                     dt_s: float,
                     options: Mapping[str, Mapping[str, object]] | None = None
                     ) -> dict[str, dict]:
    """Hyperparameters per estimator: SS order and sample time, NARX delays, NN seeds.

    Parameters
    ----------
    names : sequence of str
        Registry names, in the order the seeds are drawn.
    rng : numpy.random.Generator
        Draws one ``random_state`` per estimator that takes a seed, in ``names`` order.
    order : int
        State-space order; NARX delays and hidden units follow it.
    nn_params : mapping, optional
        Overrides for the networks' hyperparameters (e.g. ``{"max_epochs": 50}``).
    dt_s : float
        Window increment, s, for the estimators that take one.
    options : mapping, optional
        ``{name: {hyperparameter: value}}`` a user chose (a scenario's
        ``estimator.options``), applied last.

    Returns
    -------
    dict
        ``{name: {hyperparameter: value}}``.
    """
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
        p.update((options or {}).get(name, {}))
        params[name] = p
    return params


def fit_and_score(
    features: FeatureSet,
    estimators: Sequence[str],
    *,
    rng: np.random.Generator | int | None,
    order: int = PAPER_ORDER,
    nn_params: Mapping[str, object] | None = None,
    fraction: float = IDENTIFICATION_FRACTION,
    time_steps: bool = True,
    options: Mapping[str, Mapping[str, object]] | None = None,
) -> tuple[dict, dict[str, dict]]:
    """Make, fit and score estimators on one feature set: the one fit-then-score.

    The estimators are made with :func:`estimator_params` (seeds drawn from ``rng``
    in ``estimators`` order), fitted on the first ``fraction`` of the windows and
    scored on the rest by :func:`evaluate_subject`, with one BLAS thread.

    Parameters
    ----------
    features : FeatureSet
        ``X`` shape (n_windows, n_inputs), ``y`` the measured force in N.
    estimators : sequence of str
        Registry names.
    rng : numpy.random.Generator, int or None
        Seeds the estimators that draw random numbers (networks, trees).
    order : int
        State-space order (paper: 4).
    nn_params : mapping, optional
        Overrides for the networks' hyperparameters.
    fraction : float
        Identification fraction (paper: 0.5).
    time_steps : bool
        Measure the median streaming step time.
    options : mapping, optional
        Per-estimator hyperparameters a user chose (:func:`estimator_params`).

    Returns
    -------
    results : dict
        :func:`evaluate_subject`'s result (see the module docstring).
    params : dict
        ``{name: {hyperparameter: value}}`` each estimator was made with.
    """
    params = estimator_params(estimators, np.random.default_rng(rng), order, nn_params,
                              dt_s=features.dt_s, options=options)
    with one_blas_thread():
        results = evaluate_subject(features.X, features.y, params, dt_s=features.dt_s,
                                   fraction=fraction, time_steps=time_steps)
    return results, params


def inner_scores(features: FeatureSet, estimators: Sequence[str], *,
                 rng: np.random.Generator | int | None, order: int = PAPER_ORDER,
                 nn_params: Mapping[str, object] | None = None,
                 fraction: float = IDENTIFICATION_FRACTION,
                 options: Mapping[str, Mapping[str, object]] | None = None,
                 only: Sequence[str] | None = None
                 ) -> dict[str, float | None]:
    """free_run R^2 of estimators on the *inner* split of the identification half.

    The identification half (the first ``fraction`` of the windows) is evaluated on its
    own, as a recording of its own would be: its first ``fraction`` fits, the rest
    validates. What a person's own calibration data can say about an estimator before it
    is deployed; :func:`sim.user.difficulty.inner_outer` sets it beside the usual (outer)
    figure.

    Parameters
    ----------
    features : FeatureSet
        The whole recording's features, ``X`` shape (n_windows, n_inputs), ``y`` in N.
    estimators : sequence of str
        Registry names (seeded from ``rng`` as :func:`fit_and_score` seeds them).
    rng : numpy.random.Generator, int or None
    order : int
        State-space order.
    nn_params : mapping, optional
        Overrides for the networks' hyperparameters.
    fraction : float
        Identification fraction, of the recording and of its identification half.
    options : mapping, optional
        Per-estimator hyperparameters (:func:`estimator_params`).
    only : sequence of str, optional
        Score only these of ``estimators`` (default: all). The seeds are drawn for all of
        ``estimators``, so each keeps the seed :func:`fit_and_score` gives it.

    Returns
    -------
    dict
        Estimator name -> inner free_run R^2, or None where it did not run (unstable,
        unsupported) or has no free_run mode.
    """
    n_id = split_index(features.n_windows, fraction)
    params = estimator_params(estimators, np.random.default_rng(rng), order, nn_params,
                              dt_s=features.dt_s, options=options)
    if only is not None:
        params = {name: p for name, p in params.items() if name in only}
    with one_blas_thread():
        res = evaluate_subject(features.X[:n_id], features.y[:n_id], params,
                               dt_s=features.dt_s, fraction=fraction, time_steps=False)
    return {name: r["modes"].get("free_run", {}).get("r2") for name, r in res.items()}


def _mean_sd(values: list[float]) -> tuple[float | None, float | None]:
    if not values:
        return None, None
    arr = np.asarray(values, dtype=float)
    sd = float(np.std(arr, ddof=1)) if arr.size > 1 else 0.0
    return float(arr.mean()), sd


def aggregate(per_subject: Sequence[Mapping[str, Mapping]]) -> dict:
    """Mean and SD (ddof = 1, as the paper's tables) over subjects.

    Parameters
    ----------
    per_subject : sequence of :func:`evaluate_subject` results

    Returns
    -------
    dict
        ``{"estimators": {name: {mode: {"r2_mean", "r2_sd", "r2_min", "nrmse_mean",
        "nrmse_sd", "rmse_n_mean", "n_ok", "per_subject": [...]}}},
        "timing": {name: {"train_ms_median", "step_us_median", ...}}}``.
        Subjects whose model was unstable in a mode (``status`` ``"unstable"``),
        whose Kalman design failed (``"riccati_failed"``) or whose inputs the estimator
        cannot take (``"unsupported"``) are listed but excluded
        from that mode's mean (``n_ok`` counts the rest).
    """
    names = list(per_subject[0]) if per_subject else []
    estimators: dict = {}
    timing: dict = {}
    for name in names:
        modes = list(per_subject[0][name]["modes"])
        estimators[name] = {}
        for mode in modes:
            rows = [s[name]["modes"][mode] for s in per_subject]
            ok = [r for r in rows if r["status"] == "ok"]
            entry: dict = {}
            for key, label in (("r2", "r2"), ("nrmse", "nrmse"), ("rmse_n", "rmse_n"),
                               ("volatility_n_per_s", "volatility_n_per_s")):
                mean, sd = _mean_sd([r[key] for r in ok])
                entry[f"{label}_mean"], entry[f"{label}_sd"] = mean, sd
            entry["r2_min"] = min((r["r2"] for r in ok), default=None)
            entry["n_ok"] = len(ok)
            entry["per_subject"] = [
                {k: v for k, v in r.items() if k != "message"} for r in rows
            ]
            estimators[name][mode] = entry
        train = [s[name]["train_ms"] for s in per_subject if s[name]["train_ms"] is not None]
        steps = [s[name]["step_us"] for s in per_subject if s[name]["step_us"] is not None]
        timing[name] = {
            "train_ms_median": float(np.median(train)) if train else None,
            "train_ms_mean": float(np.mean(train)) if train else None,
            "train_ms_sd": float(np.std(train, ddof=1)) if len(train) > 1 else 0.0,
            "step_us_median": float(np.median(steps)) if steps else None,
            "step_mode": per_subject[0][name]["step_mode"],
        }
    return {"estimators": estimators, "timing": timing}
