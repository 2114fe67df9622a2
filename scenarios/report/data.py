"""Gathering the report's data: reproduction scores, episodes, outcome grids, loop designs.

Everything here is plain data (no figures, no HTML), so each aggregation can be
tested against an independent re-computation. Input enters at
:func:`load_reproduction_json`, :func:`split_rows` and :func:`check_episode`,
which raise :class:`ReportInputError` with one line saying what was expected
and what was found.
"""

from __future__ import annotations

import hashlib
import json
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import control
import numpy as np

from controllers.analysis import LoopMargins, loop_margins
from scenarios.schema import ESTIMATORS

MODES = ("one_step", "free_run")

#: Result fields every episode row must carry for the report's sections.
EPISODE_FIELDS = (
    "controller", "estimator", "mode", "object_name", "object_mass_kg", "object_friction",
    "dropped", "crushed", "slip_events", "gain_margin_db", "phase_margin_deg", "ms",
    "stable", "loop_dt_s",
)  # fmt: skip
#: Traces an episode row must carry.
EPISODE_TRACES = ("t_s", "intent_n", "reference_n", "grip_force_n")
LOOP_TRACES = ("loop_A", "loop_B", "loop_C", "loop_D")


class ReportInputError(ValueError):
    """A results store row or a reproduction JSON file lacks what the report needs."""


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
    mode, name = key
    rank = ESTIMATORS.index(name) if name in ESTIMATORS else len(ESTIMATORS)
    return (MODES.index(mode) if mode in MODES else len(MODES), rank, name)


def load_reproduction_json(path: str | Path) -> ScoreTable:
    """Read the JSON of ``griploop reproduce --json`` into a :data:`ScoreTable`.

    Raises
    ------
    FileNotFoundError
        No such file.
    ReportInputError
        Not JSON, or not the reproduce contract (``estimators`` -> name -> mode
        -> ``r2_mean``, ``r2_sd``, ``nrmse_mean``, ``nrmse_sd``, ``per_subject``).
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


# ---------------------------------------------------------------- store rows


@dataclass
class StoreRows:
    """The rows of a results store, split by what the report does with them.

    Attributes
    ----------
    reproduction : list of dict
        ``ok`` rows of kind ``reproduction``.
    episodes : list of dict
        ``ok`` rows of kind ``episode``.
    failed : list of dict
        Rows with status ``failed`` (any kind).
    other : list of dict
        ``ok`` rows of other kinds (e.g. ``calibration``), counted only.
    """

    reproduction: list[dict[str, Any]] = field(default_factory=list)
    episodes: list[dict[str, Any]] = field(default_factory=list)
    failed: list[dict[str, Any]] = field(default_factory=list)
    other: list[dict[str, Any]] = field(default_factory=list)


def split_rows(rows: Iterable[dict[str, Any]]) -> StoreRows:
    """Sort store rows into reproduction, episode, failed and other rows.

    Raises
    ------
    ReportInputError
        An ``ok`` episode row lacks a field of :data:`EPISODE_FIELDS`, or a
        reproduction row lacks ``estimator``, ``mode``, ``subject_id``, ``r2``
        or ``nrmse``.
    """
    out = StoreRows()
    for row in rows:
        if row["status"] == "failed":
            out.failed.append(row)
        elif row["kind"] == "episode":
            _require(row, EPISODE_FIELDS, "the episode row of scenarios.episode")
            out.episodes.append(row)
        elif row["kind"] == "reproduction":
            _require(row, ("estimator", "mode", "subject_id", "r2", "nrmse"),
                     "the row of scenarios.runner.run_reproduction")
            out.reproduction.append(row)
        else:
            out.other.append(row)
    return out


def _require(row: Mapping[str, Any], names: Sequence[str], what: str) -> None:
    missing = [n for n in names if n not in row["result"]]
    if missing:
        raise ReportInputError(
            f"{row['kind']} row {row['hash'][:12]}: missing result field(s) "
            f"{', '.join(missing)} (expected {what})"
        )


def check_traces(row: Mapping[str, Any], traces: Mapping[str, np.ndarray],
                 names: Sequence[str]) -> None:
    """Raise :class:`ReportInputError` if ``traces`` of ``row`` lack any of ``names``."""
    missing = [n for n in names if n not in traces]
    if missing:
        raise ReportInputError(
            f"episode row {row['hash'][:12]}: missing trace(s) {', '.join(missing)} "
            f"(found {', '.join(sorted(traces)) or 'none'})"
        )


def group_key(result: Mapping[str, Any]) -> tuple[str, str, str]:
    """``(controller, estimator, mode)`` of an episode result."""
    return (str(result["controller"]), str(result["estimator"]), str(result["mode"]))


def group_label(key: tuple[str, str, str]) -> str:
    """``"pid / ss_kf (free_run)"``."""
    controller, estimator, mode = key
    return f"{controller} / {estimator} ({mode})"


def representative_episodes(episodes: Sequence[dict[str, Any]],
                            limit: int = 12) -> list[dict[str, Any]]:
    """The first row (store order) of each controller / estimator / mode, at most ``limit``."""
    chosen: dict[tuple[str, str, str], dict[str, Any]] = {}
    for row in episodes:
        chosen.setdefault(group_key(row["result"]), row)
    return list(chosen.values())[:limit]


# ---------------------------------------------------------------- outcome grids


@dataclass(frozen=True)
class OutcomeGrid:
    """Drop / crush / slip outcomes of one controller, estimator and mode over mass x friction.

    Attributes
    ----------
    key : (str, str, str)
        ``(controller, estimator, mode)``.
    mass_kg : ndarray, shape (n_mass,)
        Object masses, ascending (shared by every grid of a report).
    friction : ndarray, shape (n_friction,)
        Friction coefficients, ascending (shared).
    not_lifted_frac, dropped_frac, crushed_frac : ndarray, shape (n_mass, n_friction)
        Fraction of episodes (over seeds) whose outcome was not lifted / dropped
        / crushed (one category each: a crushed object counts as crushed only);
        ``nan`` where the cell has no episode.
    slip_events_mean : ndarray, shape (n_mass, n_friction)
        Mean number of slip events per episode; ``nan`` where empty.
    n_episodes : ndarray of int, shape (n_mass, n_friction)
        Episodes behind each cell.
    """

    key: tuple[str, str, str]
    mass_kg: np.ndarray
    friction: np.ndarray
    not_lifted_frac: np.ndarray
    dropped_frac: np.ndarray
    crushed_frac: np.ndarray
    slip_events_mean: np.ndarray
    n_episodes: np.ndarray


def episode_outcome(result: Mapping[str, Any]) -> str:
    """``held``, ``not_lifted``, ``dropped`` or ``crushed`` (rows before the outcome column:
    from the flags, an object never lifted counting as not lifted)."""
    if result.get("outcome"):
        return str(result["outcome"])
    if result.get("crushed"):
        return "crushed"
    if not result.get("lifted", True):
        return "not_lifted"
    return "dropped" if result.get("dropped") else "held"


def outcome_grids(episodes: Sequence[Mapping[str, Any]]) -> list[OutcomeGrid]:
    """Per controller / estimator / mode, outcomes averaged over seeds in each mass x friction cell.

    Masses and frictions are the values the episodes report
    (``object_mass_kg``, ``object_friction``), rounded to 1e-9 so that
    values equal up to round-off share a cell.
    """
    if not episodes:
        return []
    mass = np.array([round(float(e["result"]["object_mass_kg"]), 9) for e in episodes])
    mu = np.array([round(float(e["result"]["object_friction"]), 9) for e in episodes])
    masses, i_mass = np.unique(mass, return_inverse=True)
    frictions, i_mu = np.unique(mu, return_inverse=True)
    keys = [group_key(e["result"]) for e in episodes]
    outcome = [episode_outcome(e["result"]) for e in episodes]
    not_lifted = np.array([o == "not_lifted" for o in outcome], dtype=float)
    dropped = np.array([o == "dropped" for o in outcome], dtype=float)
    crushed = np.array([o == "crushed" for o in outcome], dtype=float)
    slips = np.array([float(e["result"]["slip_events"]) for e in episodes])
    shape = (masses.size, frictions.size)
    grids = []
    for key in dict.fromkeys(keys):
        sel = np.array([k == key for k in keys])
        cells = np.ravel_multi_index((i_mass[sel], i_mu[sel]), shape)
        count = np.bincount(cells, minlength=masses.size * frictions.size).reshape(shape)

        def mean(values: np.ndarray, cells: np.ndarray = cells,
                 count: np.ndarray = count) -> np.ndarray:
            total = np.bincount(cells, weights=values, minlength=count.size).reshape(shape)
            with np.errstate(invalid="ignore", divide="ignore"):
                return np.where(count > 0, total / count, np.nan)

        grids.append(OutcomeGrid(key, masses, frictions, mean(not_lifted[sel]),
                                 mean(dropped[sel]), mean(crushed[sel]), mean(slips[sel]),
                                 count))
    return grids


# ---------------------------------------------------------------- loop designs


@dataclass(frozen=True)
class LoopDesign:
    """One distinct analysed open loop of the episodes, with its margins.

    Attributes
    ----------
    label : str
        ``"D1 pid"``: number in order of appearance and controller.
    controller : str
        Controller family.
    margins : LoopMargins
        :func:`controllers.analysis.loop_margins` of the rebuilt loop.
    hashes : list of str
        Store hashes of the episodes that share this loop.
    conditions : list of str
        ``"object m=0.2 kg mu=0.8"`` of those episodes (distinct, in order).
    row_agrees : bool
        Whether the first episode's stored scalars (gain and phase margin, Ms,
        stable) match the recomputed margins (rtol 1e-3).
    """

    label: str
    controller: str
    margins: LoopMargins
    hashes: list[str]
    conditions: list[str]
    row_agrees: bool


def rebuild_loop(traces: Mapping[str, np.ndarray], dt_s: float) -> control.StateSpace:
    """The analysed open loop ``control.ss(A, B, C, D, dt)`` from an episode's loop traces."""
    a, b, c, d = (np.atleast_2d(np.asarray(traces[n], dtype=float)) for n in LOOP_TRACES)
    return control.ss(a, b, c, d, float(dt_s))


def loop_fingerprint(traces: Mapping[str, np.ndarray], dt_s: float) -> str:
    """SHA-1 of the loop matrices (rounded to 12 significant digits) and the period."""
    digest = hashlib.sha1(repr(float(dt_s)).encode())
    for name in LOOP_TRACES:
        arr = np.atleast_2d(np.asarray(traces[name], dtype=float))
        digest.update(repr(arr.shape).encode())
        digest.update(np.char.mod("%.12g", arr).tobytes())
    return digest.hexdigest()


def _close(stored: Any, value: float) -> bool:
    if stored is None:
        return not np.isfinite(value)
    if isinstance(stored, bool):
        return stored == bool(value)
    return bool(np.isclose(float(stored), value, rtol=1e-3, atol=1e-9))


def condition_label(result: Mapping[str, Any]) -> str:
    """``"block m=0.2 kg mu=0.8"`` of an episode result."""
    return (f"{result['object_name']} m={float(result['object_mass_kg']):g} kg "
            f"mu={float(result['object_friction']):g}")


def loop_designs(episodes: Sequence[Mapping[str, Any]],
                 traces: Mapping[str, Mapping[str, np.ndarray]]) -> list[LoopDesign]:
    """Distinct analysed loops of the episodes, in order of first appearance.

    Parameters
    ----------
    episodes : sequence of dict
        ``ok`` episode rows.
    traces : dict of str to dict
        Store hash -> that row's traces (must hold :data:`LOOP_TRACES`).

    Raises
    ------
    ReportInputError
        A row lacks a loop trace.
    """
    found: dict[str, dict[str, Any]] = {}
    for row in episodes:
        res, tr = row["result"], traces[row["hash"]]
        check_traces(row, tr, LOOP_TRACES)
        key = loop_fingerprint(tr, res["loop_dt_s"])
        entry = found.setdefault(key, {"row": row, "hashes": [], "conditions": []})
        entry["hashes"].append(row["hash"])
        label = condition_label(res)
        if label not in entry["conditions"]:
            entry["conditions"].append(label)
    designs = []
    for i, entry in enumerate(found.values(), start=1):
        row = entry["row"]
        res = row["result"]
        margins = loop_margins(rebuild_loop(traces[row["hash"]], res["loop_dt_s"]))
        agrees = (_close(res["gain_margin_db"], margins.gain_margin_db)
                  and _close(res["phase_margin_deg"], margins.phase_margin_deg)
                  and _close(res["ms"], margins.ms)
                  and bool(res["stable"]) == margins.stable)
        designs.append(LoopDesign(f"D{i} {res['controller']}", str(res["controller"]), margins,
                                  entry["hashes"], entry["conditions"], agrees))
    return designs


# ---------------------------------------------------------------- misc


def most_common_object(episodes: Sequence[Mapping[str, Any]], default: str = "ball") -> str:
    """Most frequent ``object_name`` of the episodes (first in store order on ties)."""
    names = [str(e["result"]["object_name"]) for e in episodes]
    return Counter(names).most_common(1)[0][0] if names else default


def scenario_summary(row: Mapping[str, Any]) -> str:
    """One line naming a stored scenario: kind, subject, object, estimator, controller, seed."""
    cfg = row["config"]
    obj = cfg.get("object", {})
    parts = [row["kind"], f"subject {cfg.get('subject', {}).get('subject_id')}"]
    if row["kind"] == "episode":
        extra = "".join(f" {k}={obj[k]:g}" for k in ("mass_kg", "friction")
                        if obj.get(k) is not None)
        parts.append(f"{obj.get('name')}{extra}")
    est = cfg.get("estimator", {})
    parts.append(f"{est.get('name')} ({est.get('mode')})")
    if row["kind"] == "episode":
        parts.append(cfg.get("controller", {}).get("kind", "?"))
    parts.append(f"seed {cfg.get('seed')}")
    return ", ".join(str(p) for p in parts)
