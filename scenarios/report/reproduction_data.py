"""The reproduction's scores as the report reads them: from a reproduction JSON or store rows."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from estimation.registry import MODES
from scenarios.report.data import ReportInputError

# ---------------------------------------------------------------- reproduction


@dataclass(frozen=True)
class EstimatorScores:
    """R^2 / NRMSE of one estimator in one mode, over subjects.

    Attributes
    ----------
    per_subject : dict of int to (float, float)
        Subject number -> (R^2, NRMSE) on the validation part (mean over rows
        if a subject has several); subjects whose model diverged are absent.
    r2_mean, r2_sd, nrmse_mean, nrmse_sd : float
        Mean and SD (ddof = 1, as the paper's tables; 0 for one subject).
    n : int
        Number of scores behind the mean.
    train_ms : tuple of (float, float) or None
        Training time mean and SD, ms.
    step_us_median : float or None
        Median wall time of one streaming estimator update, microseconds.
    """

    per_subject: dict[int, tuple[float, float]]
    r2_mean: float
    r2_sd: float
    nrmse_mean: float
    nrmse_sd: float
    n: int
    train_ms: tuple[float, float] | None = None
    step_us_median: float | None = None


#: Estimator -> mode -> its scores over the subjects.
ScoreTable = dict[str, dict[str, EstimatorScores]]
"""mode -> estimator -> scores; modes are never mixed."""


def _mean_sd(values: Sequence[float]) -> tuple[float, float]:
    arr = np.asarray(values, dtype=float)
    sd = float(np.std(arr, ddof=1)) if arr.size > 1 else 0.0
    return float(np.mean(arr)), sd


def scores_from_rows(rows: Iterable[Mapping[str, Any]]) -> ScoreTable:
    """Aggregate ``ok`` reproduction rows of a results store per mode and estimator.

    Parameters
    ----------
    rows : iterable of dict
        Rows of :meth:`scenarios.store.ResultStore.rows` of kind ``reproduction``
        and status ``ok`` (``result`` holds ``estimator``, ``mode``,
        ``subject_id``, ``r2``, ``nrmse``, ``train_ms``, ``step_us``).

    Returns
    -------
    ScoreTable
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        res = row["result"]
        groups.setdefault((res["mode"], res["estimator"]), []).append(res)
    table: ScoreTable = {}
    for (mode, name), results in sorted(groups.items(), key=lambda kv: _mode_key(kv[0])):
        by_subject: dict[int, list[tuple[float, float]]] = {}
        for res in results:
            by_subject.setdefault(int(res["subject_id"]), []).append((res["r2"], res["nrmse"]))
        per_subject = {
            s: (float(np.mean([v[0] for v in vals])), float(np.mean([v[1] for v in vals])))
            for s, vals in sorted(by_subject.items())
        }
        r2_mean, r2_sd = _mean_sd([r["r2"] for r in results])
        nrmse_mean, nrmse_sd = _mean_sd([r["nrmse"] for r in results])
        train = [r["train_ms"] for r in results if r.get("train_ms") is not None]
        steps = [r["step_us"] for r in results if r.get("step_us") is not None]
        table.setdefault(mode, {})[name] = EstimatorScores(
            per_subject, r2_mean, r2_sd, nrmse_mean, nrmse_sd, len(results),
            _mean_sd(train) if train else None,
            float(np.median(steps)) if steps else None,
        )
    return table


def _mode_key(key: tuple[str, str]) -> tuple[int, int, str]:
    """Sort key: modes in :data:`MODES` order, estimators in the schema's order."""
    from estimation.registry import estimator_names  # the schema's order, without pydantic

    mode, name = key
    names = estimator_names()
    rank = names.index(name) if name in names else len(names)
    return (MODES.index(mode) if mode in MODES else len(MODES), rank, name)


def load_reproduction_json(path: str | Path) -> ScoreTable:
    """Read the JSON of ``griploop reproduce --json`` into a ``ScoreTable``.

    :func:`read_reproduction_json`, then :func:`reproduction_scores`.

    Raises
    ------
    FileNotFoundError
        No such file.
    ReportInputError
        Not JSON, or not the reproduce contract.
    """
    return reproduction_scores(read_reproduction_json(path), path)


def read_reproduction_json(path: str | Path) -> dict[str, Any]:
    """The JSON object of ``griploop reproduce --json`` (read once; the report's sections
    take its scores, ``config`` and ``transfer`` from it).

    Raises
    ------
    FileNotFoundError
        No such file.
    ReportInputError
        Not JSON, or not an object with ``estimators``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: no such reproduction file (expected the JSON of griploop reproduce --json)"
        )
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ReportInputError(f"{path}: not JSON (expected griploop reproduce --json; {exc})") \
            from None
    if not isinstance(data, dict) or not isinstance(data.get("estimators"), dict):
        kind = type(data).__name__
        found = f"keys {sorted(data)}" if isinstance(data, dict) else f"a JSON {kind}"
        raise ReportInputError(
            f"{path}: expected an object with 'estimators' (griploop reproduce --json), "
            f"found {found}"
        )
    return data


def reproduction_scores(data: Mapping[str, Any], path: str | Path = "reproduction") -> ScoreTable:
    """The ``ScoreTable`` of a reproduction JSON object (:func:`read_reproduction_json`).

    Raises
    ------
    ReportInputError
        An estimator entry lacks ``r2_mean``, ``r2_sd``, ``nrmse_mean``, ``nrmse_sd`` or
        ``per_subject`` (``path`` names the file in the message).
    """
    subject_ids = [s.get("subject_id") for s in data.get("subjects", [])]
    timing = data.get("timing", {})
    table: ScoreTable = {}
    for name, modes in data["estimators"].items():
        for mode, entry in modes.items():
            missing = [k for k in ("r2_mean", "r2_sd", "nrmse_mean", "nrmse_sd", "per_subject")
                       if k not in entry]
            if missing:
                raise ReportInputError(
                    f"{path}: estimators.{name}.{mode} lacks {missing} "
                    "(expected the griploop reproduce --json contract)"
                )
            per_subject = {}
            for i, score in enumerate(entry["per_subject"]):
                if score.get("r2") is None or score.get("nrmse") is None:
                    continue
                sid = subject_ids[i] if i < len(subject_ids) and subject_ids[i] else i + 1
                per_subject[int(sid)] = (float(score["r2"]), float(score["nrmse"]))
            t = timing.get(name, {})
            train = None
            if t.get("train_ms_mean") is not None:
                train = (float(t["train_ms_mean"]), float(t.get("train_ms_sd") or 0.0))
            if entry["r2_mean"] is None:
                continue  # every subject diverged in this mode: nothing to tabulate
            table.setdefault(mode, {})[name] = EstimatorScores(
                per_subject, float(entry["r2_mean"]), float(entry["r2_sd"] or 0.0),
                float(entry["nrmse_mean"]), float(entry["nrmse_sd"] or 0.0),
                int(entry.get("n_ok", len(per_subject))), train,
                t.get("step_us_median"),
            )
    return {m: dict(sorted(table[m].items(), key=lambda kv: _mode_key((m, kv[0]))))
            for m in sorted(table, key=lambda m: _mode_key((m, ""))[0])}
