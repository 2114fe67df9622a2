"""Assembling the report: one section per kind of data, in page order.

:func:`build_report` reads a results store (and optionally the JSON of
``griploop reproduce --json``, read once) into a
:class:`~scenarios.report.sections.ReportContext`, builds every section registered in
:mod:`scenarios.report.sections` from the data present -- a section without data becomes a
one-line note -- and writes ``OUT/index.html``. The page opens with what the sweep found
(:mod:`scenarios.report.findings`); the built-in sections are registered at the end of
this module.

Speed: the analyses are read from the store (the episode runner stored each loop's
margins), so the report imports neither python-control nor scipy.stats unless asked to
re-analyse the loops (``recheck_margins``); figures are a handful of SVGs, the force
traces inline SVG charts (:mod:`scenarios.report.svg`), the outcome maps coloured tables;
the grasp frame renders in a child process while the sections are built.
"""

from __future__ import annotations

import datetime as _dt
import platform
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from scenarios.outcomes import OUTCOMES, PHASE_CODES, row_outcome
from scenarios.report import data as D
from scenarios.report import factors as FA
from scenarios.report import figures as F
from scenarios.report import findings
from scenarios.report import loops as LP
from scenarios.report import reproduction_data as RD
from scenarios.report import summaries as SU
from scenarios.report import svg as S
from scenarios.report.frame import FRAME_GRIP_N, FrameRender, frame_section
from scenarios.report.html import (
    HeatCell,
    Section,
    choices,
    esc,
    figure,
    fmt,
    heat_table,
    note,
    page,
    svg_img,
    table,
)
from scenarios.report.paper_section import paper_section
from scenarios.report.sections import ReportContext, build_sections, register_section
from scenarios.store import ResultStore, package_version

#: Grip force of the rendered frame, N (``sim.hand.render_snapshot``'s default; below about
#: 4 N the hand's steady grasp of the block loses thumb contact).


@dataclass(frozen=True)
class ReportResult:
    """What :func:`build_report` wrote.

    Attributes
    ----------
    path : Path
        The HTML file.
    sections : list of Section
        Every section, in page order (``omitted`` ones hold only a note).
    n_images : int
        Figures: embedded images (SVG figures, the PNG of the grasp) and inline SVG charts.
    elapsed_s : float
        Wall time of the build, s.
    """

    path: Path
    sections: list[Section]
    n_images: int
    elapsed_s: float


@dataclass(frozen=True)
class ReportLimits:
    """How many of a sweep's loops and episodes the report draws.

    Attributes
    ----------
    max_designs : int
        Loop designs drawn in the Bode / Nyquist / pole figure (all are tabulated).
    max_traces : int
        Episodes drawn as force traces (one selectable chart per scenario).
    """

    max_designs: int = 6
    max_traces: int = 120


def build_report(
    results: str | Path,
    out_dir: str | Path,
    *,
    sweep: str | None = None,
    reproduction: str | Path | None = None,
    render_frame: bool = True,
    limits: ReportLimits = ReportLimits(),
    recheck_margins: bool = False,
    created: _dt.datetime | None = None,
) -> ReportResult:
    """Write ``out_dir/index.html`` from a results store and an optional reproduction JSON.

    Parameters
    ----------
    results : str or Path
        SQLite results store written by ``griploop sweep``.
    out_dir : str or Path
        Output directory (created if missing).
    sweep : str, optional
        Only the rows of this sweep.
    reproduction : str or Path, optional
        JSON written by ``griploop reproduce --json``.
    render_frame : bool
        Render a MuJoCo frame of the grasp (a child process, about 2 s with EGL, run
        while the other sections are built).
    limits : ReportLimits
        Loop designs and force traces drawn (default: 6 and 120).
    recheck_margins : bool
        Re-analyse every distinct loop with :func:`controllers.analysis.loop_margins`
        and mark where the stored margins differ (imports python-control; about 0.1 s
        a loop); by default the margins are the stored ones.
    created : datetime, optional
        Creation time printed in the provenance (default: now, UTC).

    Returns
    -------
    ReportResult

    Raises
    ------
    FileNotFoundError
        ``results`` or ``reproduction`` does not exist.
    scenarios.store.StoreError
        Not a results store, or unknown sweep.
    ReportInputError
        A row or the JSON lacks what the report needs.
    """
    t0 = time.perf_counter()
    results = Path(results)
    if not results.is_file():
        raise FileNotFoundError(
            f"{results}: no such results store (expected a file written by griploop sweep)"
        )
    repro_data = RD.read_reproduction_json(reproduction) if reproduction is not None else None
    json_scores = (RD.reproduction_scores(repro_data, reproduction)
                   if repro_data is not None else None)
    json_config = repro_data.get("config", {}) if repro_data is not None else {}
    json_config = json_config if isinstance(json_config, dict) else {}
    rows, split, traces, members = _read_store(results, sweep)
    created = created or _dt.datetime.now(_dt.timezone.utc)
    frame = (FrameRender(D.most_common_object(split.episodes), FRAME_GRIP_N)
             if render_frame else None)
    try:
        sources = _score_sources(split, json_scores, reproduction)
        factors = FA.swept_factors(split.episodes)
        conditions = [f for f in factors if f != FA.CONTROLLER_FACTOR]
        designs = (LP.loop_designs(split.episodes, traces,
                                  label=lambda row: FA.scenario_title(row, conditions),
                                  recheck=recheck_margins)
                   if split.episodes else [])
        context = ReportContext(
            results=results, sweep=sweep, rows=rows, split=split, traces=traces,
            members=members, sources=sources, factors=factors, designs=designs,
            reproduction=None if reproduction is None else Path(reproduction),
            json_config=json_config, created=created,
            options={"render_frame": render_frame, "max_designs": limits.max_designs,
                     "max_traces": limits.max_traces, "recheck_margins": recheck_margins,
                     "frame": frame},
            reproduction_data=repro_data,
        )
        sections = build_sections(context)
    finally:
        if frame is not None:
            frame.cancel()
    text = page("griploop report", _subtitle(results, sweep, rows, split, reproduction),
                sections)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "index.html"
    path.write_text(text, encoding="utf-8")
    n_figures = text.count("<img ") + text.count("<svg ")
    return ReportResult(path, sections, n_figures, time.perf_counter() - t0)


def _read_store(results: Path, sweep: str | None
                ) -> tuple[list[dict], D.StoreRows, dict[str, Any], dict[str, list[dict]]]:
    """Everything the report reads from the results store, in one read-only session.

    Returns
    -------
    rows : list of dict
        The rows of ``sweep`` (all rows if None).
    split : StoreRows
        Those rows by kind (:func:`scenarios.report.data.split_rows`).
    traces : dict
        Each episode's traces, by content hash.
    members : dict
        The rows of each sweep shown, by sweep name (for the provenance).
    """
    with ResultStore(results, read_only=True) as store:
        rows = store.rows(sweep=sweep)
        split = D.split_rows(rows)
        traces = {r["hash"]: store.traces(r["hash"]) for r in split.episodes}
        sweeps = [sweep] if sweep is not None else store.sweeps()
        members = {s: store.rows(sweep=s) for s in sweeps}
    return rows, split, traces, members


def _score_sources(split: D.StoreRows, json_scores: RD.ScoreTable | None,
                   reproduction: str | Path | None) -> list[tuple[str, RD.ScoreTable]]:
    """The estimator scores to tabulate: the store's reproduction rows, then the JSON's."""
    sources: list[tuple[str, RD.ScoreTable]] = []
    if split.reproduction:
        sources.append((f"results store ({len(split.reproduction)} reproduction rows)",
                        RD.scores_from_rows(split.reproduction)))
    if json_scores:
        sources.append((f"{Path(reproduction).name} (griploop reproduce --json)", json_scores))
    return sources


def _subtitle(results: Path, sweep: str | None, rows: Sequence[dict], split: D.StoreRows,
              reproduction: str | Path | None) -> str:
    """The page's subtitle: the store, the sweep, and how many rows of each kind."""
    n_ok = len(rows) - len(split.failed)
    return (f"{results.name}{f', sweep {sweep}' if sweep else ''}: {len(rows)} rows "
            f"({n_ok} ok, {len(split.failed)} failed; {len(split.reproduction)} "
            f"reproduction, {len(split.episodes)} episode, {len(split.other)} other)"
            f"{f'; reproduction JSON {Path(reproduction).name}' if reproduction else ''}.")


# ---------------------------------------------------------------- 5. traces


#: Shading of a trial's phases in the trace chart (phases not listed are not shaded).
PHASE_FILLS = {"liftoff": "#fff3c4", "lift": "#dff2df", "setdown": "#eeeeee",
               "release": "#eeeeee"}


def phase_bands(t_s: np.ndarray, phase: np.ndarray) -> list[tuple[float, float, str, str]]:
    """Shaded spans of a self-paced trial's phases, each lift-off labelled with its attempt."""
    codes = np.asarray(phase, dtype=int)
    starts = np.flatnonzero(np.diff(np.concatenate([[-1], codes])))
    ends = [*starts[1:], codes.size]
    dt = float(t_s[1] - t_s[0]) if t_s.size > 1 else 0.0
    bands, attempt = [], 0
    for a, b in zip(starts, ends, strict=True):
        name = PHASE_CODES[codes[a]]
        if name not in PHASE_FILLS:
            continue
        attempt += name == "liftoff"
        text = f"lift-off {attempt}" if name == "liftoff" else ("lift, hold" if name == "lift"
                                                                 else "")
        bands.append((float(t_s[a]), float(t_s[b - 1]) + dt, text, PHASE_FILLS[name]))
    return bands


def trace_chart(traces: Mapping[str, np.ndarray], name: str) -> str:
    """Inline SVG chart of one episode's intent, reference and grip force against time,
    over the shaded phases and attempts of a trial the user paced."""
    bands = phase_bands(traces["t_s"], traces["phase"]) if "phase" in traces else []
    return S.line_chart(traces["t_s"], [("intent", traces["intent_n"], S.GREY),
                                        ("reference", traces["reference_n"], S.ORANGE),
                                        ("grip force", traces["grip_force_n"], S.BLUE)],
                        x_label="time (s)", y_label="force (N)",
                        label=f"force trace of {name}", bands=bands)


def _traces_section(episodes: Sequence[dict], traces: Mapping[str, Mapping[str, np.ndarray]],
                    limit: int, factors: Sequence[str] = ()) -> Section:
    title = "5. Force traces, one per scenario"
    if not episodes:
        return Section("traces", title, note("No episode rows: section omitted."), True)
    chosen = list(episodes)[:limit]
    items = []
    for row in chosen:
        D.check_traces(row, traces[row["hash"]], D.EPISODE_TRACES)
        res = row["result"]
        seed = res.get("seed", row["config"].get("seed"))
        name = FA.scenario_title(row, factors)
        outcome = row_outcome(res).replace("_", " ")
        caption = (f"{name}: {outcome}; seed {seed}, subject {res.get('subject_id', '?')}, "
                   f"scenario {row['hash'][:12]}.")
        items.append((f"{name} ({outcome})",
                      figure(trace_chart(traces[row["hash"]], name), caption)))
    shown = (f"all {len(episodes)} episodes" if len(chosen) == len(episodes)
             else f"the first {len(chosen)} of {len(episodes)} episodes (store order)")
    body = [note(f"Open a scenario to see its intent, reference and grip force: {shown}, "
                 "titled by the factors the sweep varies; the seed is in the caption. In a "
                 "trial the user paced, each careful lift-off is shaded yellow and numbered "
                 "(a second one is a new attempt after the object stayed behind), the lift "
                 "and the hold green, the set-down and the release grey."),
            choices(items)]
    return Section("traces", title, "\n".join(body))


# ---------------------------------------------------------------- 2 + 3. combinations, comparison


def _combinations_section(episodes: Sequence[dict], factors: Sequence[str]) -> Section:
    title = "2. Outcomes per combination of the swept factors"
    if not episodes:
        return Section("combinations", title, note("No episode rows: section omitted."), True)
    summary = SU.outcome_summary(episodes, factors)
    single = all(r.n == 1 for r in summary)
    names = [FA.factor_name(f) for f in factors] or ["episodes"]
    outcome_headers = (["outcome"] if single
                       else [*(f"{findings.OUTCOME_WORDS[o]} %" for o in OUTCOMES)])
    headers = [*names, "n", *outcome_headers, "tracking RMSE (N)", "contact peak ratio",
               "slip distance (m)", "PM at held force (deg)", "worst visited PM (deg)"]
    rows = []
    for r in summary:
        levels = [FA.level_text(v) for v in r.levels] or ["all"]
        level = findings.LevelOutcomes(r.levels, r.n, r.counts)
        cells = ([findings.OUTCOME_WORDS[OUTCOMES[[r.counts[o] for o in OUTCOMES].index(1)]]]
                 if single else findings.rate_cells(level, OUTCOMES))
        rows.append([*levels, r.n, *cells, r.tracking_rmse_n, r.contact_peak_ratio,
                     r.slip_distance_m, r.phase_margin_deg, r.worst_phase_margin_deg])
    swept = ", ".join(f"{FA.factor_name(f)} ({f})" for f in factors) or "nothing"
    rates = ("Each combination ran once, so each row shows its episode's outcome (a rate of "
             "one episode would say nothing more)." if single else
             "Rates are the percentage of the row's episodes with its 95 % Wilson interval; "
             "a row of one episode shows its outcome instead.")
    parts = [note(f"Factors that vary between the stored scenario configs (the seed apart): "
                  f"{swept}. One row per combination ({len(summary)} rows, "
                  f"{len(episodes)} episodes). {rates} Tracking RMSE, contact peak ratio, "
                  "slip distance and the phase margin at the held force are means, the worst "
                  "visited phase margin is the minimum over the row's episodes."),
             f"<details><summary>Table of the {len(summary)} combinations</summary>"
             + table(headers, rows, "Outcomes and metrics per factor combination",
                     text_columns=len(names)) + "</details>"]
    return Section("combinations", title, "\n".join(parts))


def _compare_section(episodes: Sequence[dict], factors: Sequence[str]) -> Section:
    title = "3. Controllers side by side on the same scenarios"
    if not episodes:
        return Section("compare", title, note("No episode rows: section omitted."), True)
    if FA.CONTROLLER_FACTOR not in factors:
        return Section("compare", title, note("The controller does not vary in these "
                                              "episodes: nothing to compare."), True)
    diffs = SU.paired_differences(episodes, factors)
    others = [FA.factor_name(f) for f in factors if f != FA.CONTROLLER_FACTOR]
    rows = [[d.baseline, d.other, SU.PAIRED_METRICS[d.metric][0], d.n_pairs, d.baseline_mean,
             d.other_mean, d.mean_diff,
             "n/a" if not np.isfinite(d.ci_low) else f"{fmt(d.ci_low)} to {fmt(d.ci_high)}"]
            for d in diffs]
    parts = [note("Two episodes are paired when they share every other swept factor ("
                  f"{', '.join(others) or 'none'}) and the seed. Difference = B - A, averaged "
                  "over the pairs, with the 95 % t interval of the mean paired difference "
                  "(n/a below two pairs); for the held rate, a difference of +0.1 means B "
                  "held in 10 % more of the scenarios."),
             table(["controller A", "controller B", "metric", "pairs", "A mean", "B mean",
                    "B - A", "95 % interval"], rows, "Paired differences", text_columns=3)]
    return Section("compare", title, "\n".join(parts))


# ---------------------------------------------------------------- 6 + 8. loops


def drawn_designs(designs: Sequence[LP.LoopDesign], limit: int) -> list[LP.LoopDesign]:
    """At most ``limit`` designs, taken in turn from each controller family (first seen
    first), in their original order: every family is drawn before any has two."""
    queues: dict[str, list[LP.LoopDesign]] = {}
    for d in designs:
        queues.setdefault(d.controller, []).append(d)
    chosen: list[LP.LoopDesign] = []
    while len(chosen) < min(limit, len(designs)):
        for queue in queues.values():
            if queue and len(chosen) < limit:
                chosen.append(queue.pop(0))
    return sorted(chosen, key=lambda d: designs.index(d))


def _conditions(d: LP.LoopDesign, n: int = 3) -> str:
    return "; ".join(d.conditions[:n]) + (" ..." if len(d.conditions) > n else "")


def _loop_section(designs: Sequence[LP.LoopDesign], limit: int) -> Section:
    title = "6. Loop analysis: Bode, Nyquist and pole maps"
    if not designs:
        return Section("loops", title, note("No episode rows with an analysed loop: "
                                            "section omitted."), True)
    chosen = drawn_designs(designs, limit)
    parts = [note(f"{len(designs)} distinct loops (each episode's loop at the force it held); "
                  + (f"{len(chosen)} drawn, taken in turn from each controller family; "
                     if len(chosen) < len(designs) else "all drawn; ")
                  + "every one is in the margin table. Each loop is drawn from the state "
                  "space stored with its first episode; the legend gives its stored margins."),
             table(["design", "episodes", "conditions"],
                   [[d.label, len(d.hashes), _conditions(d)] for d in chosen],
                   "Designs drawn", text_columns=3),
             svg_img(F.svg_bytes(F.loop_figure(chosen)),
                     "Bode, Nyquist and closed-loop poles of the drawn designs")]
    return Section("loops", title, "\n".join(parts))


def _crossovers(stored: Mapping[str, Any]) -> str:
    """The stored gain crossover, and how many more the loop has."""
    w, n = stored.get("crossover_rad_s"), stored.get("n_crossovers")
    if w is None:
        return "none"
    more = int(n) - 1 if n is not None else 0
    return fmt(w) + (f" (+{more} more)" if more > 0 else "")


def _margin_section(designs: Sequence[LP.LoopDesign], episodes: Sequence[dict] = ()) -> Section:
    title = "8. Margins per controller design"
    if not designs:
        return Section("margins", title, note("No episode rows with an analysed loop: "
                                              "section omitted."), True)
    parts = []
    analysed = sum(len(d.hashes) for d in designs)
    if episodes and analysed < len(episodes):
        parts.append(note(f"{len(episodes) - analysed} of {len(episodes)} episodes never held "
                          "a force in the air (not lifted, or crushed on the way) and have no "
                          "analysed loop; they are in the summary, not in this table."))
    if any(e["result"].get("held_force_n") is not None for e in episodes):
        parts.append(note("A margin belongs to a loop at an operating point: each episode's "
                          "margins are those of the controller that ran at the grip force it "
                          "held in the air, on the plant linearized at that force; the open "
                          "markers are the worst over the forces it visited."))
        parts.append(svg_img(F.svg_bytes(F.margins_vs_force_figure(list(episodes))),
                             "margins against held grip force"))
    rechecked = all(d.margins is not None for d in designs)
    rows = []
    for d in designs:
        m, st = d.margins, d.stored
        row = [d.label, _conditions(d), len(d.hashes)]
        if rechecked:
            row += [m.gain_margin_db, m.phase_margin_deg, m.delay_margin_s,
                    ", ".join(fmt(w) for w in m.crossover_rad_s) or "none",
                    ", ".join(fmt(w) for w in m.phase_crossover_rad_s) or "none",
                    m.ms, m.stable, d.row_agrees]
        else:
            row += [st["gain_margin_db"], st["phase_margin_deg"], st["delay_margin_s"],
                    _crossovers(st), st["ms"], st["stable"]]
        rows.append(row)
    headers = ["design", "conditions", "episodes", "GM (dB)", "PM (deg)", "delay margin (s)",
               "gain crossovers (rad/s)"]
    if rechecked:
        headers += ["phase crossovers (rad/s)", "Ms", "stable", "row agrees"]
        caption = "Recomputed from each loop's state space (--recheck-margins)"
    else:
        headers += ["Ms", "stable"]
        caption = ("Stored by the episode runner (controllers.analysis.loop_margins of the "
                   "loop at the held force); griploop report --recheck-margins recomputes them")
    body = table(headers, rows, caption, text_columns=2)
    bad = [d.label for d in designs if d.row_agrees is False]
    if bad:
        body += (f'<p class="bad">Stored margins differ from the recomputed ones for '
                 f"{esc(', '.join(bad))}.</p>")
    return Section("margins", title, "\n".join(parts) + body)


# ---------------------------------------------------------------- 7. outcome maps


def _heat_rows(grid: D.OutcomeGrid, attr: str, limits: tuple[float, float], cmap: str
               ) -> list[tuple[str, list[HeatCell]]]:
    values = getattr(grid, attr)
    rows = []
    for i, level in enumerate(grid.row_levels):
        cells = []
        for j in range(len(grid.col_levels)):
            n = int(grid.n_episodes[i, j])
            background, color = F.heat_colors(values[i, j], *limits, cmap) if n else ("#fff",
                                                                                     "#000")
            cells.append(HeatCell(f"{values[i, j]:.2g}" if n else "", n, background, color))
        rows.append((FA.level_text(level), cells))
    return rows


def _outcome_section(episodes: Sequence[dict], factors: Sequence[str] = ()) -> Section:
    title = "7. Not lifted, slip, drop and crush maps"
    if not episodes:
        return Section("outcomes", title, note("No episode rows: section omitted."), True)
    rows_f, cols_f, grids = FA.faceted_grids(episodes, factors)
    facets = [FA.factor_name(f) for f in factors if f not in (rows_f, cols_f)]
    corner = f"{FA.factor_name(rows_f)} \\ {FA.factor_name(cols_f)}"
    parts = [note(f"{FA.factor_name(rows_f)} (rows) x {FA.factor_name(cols_f)} (columns); one "
                  "table per combination of the other swept factors "
                  f"({', '.join(facets) or 'none'}), so no cell averages different objects or "
                  "designs. Each cell averages its episodes (seeds), n below the value; darker "
                  "is more. Each episode has "
                  "one outcome: held, not lifted, dropped or crushed.")]
    for metric, (attr, label, limits) in F.OUTCOME_METRICS.items():
        if metric in OUTCOMES and not any(np.nansum(getattr(g, attr)) for g in grids):
            parts.append(note(f"No episode was {findings.OUTCOME_WORDS[metric]}: its map "
                              "would be all zeros."))
            continue
        if limits is None:
            finite = np.concatenate([getattr(g, attr)[np.isfinite(getattr(g, attr))]
                                     for g in grids])
            limits = (0.0, max(1.0, float(finite.max(initial=0.0))))
        cmap = "Blues" if limits != (0.0, 1.0) else "Reds"
        tables = [heat_table(corner, [FA.level_text(c) for c in g.col_levels],
                             _heat_rows(g, attr, limits, cmap), g.label or str(g.key))
                  for g in grids]
        parts.append(f"<h3>{esc(label)}</h3>")
        parts.append('<div class="row">' + "".join(tables) + "</div>")
    return Section("outcomes", title, "\n".join(parts))


# ---------------------------------------------------------------- 10. failures


def _failed_section(failed: Sequence[dict]) -> Section:
    title = "10. Failed scenarios"
    if not failed:
        return Section("failed", title, note("No failed scenarios."))
    rows = [[r["hash"][:12], D.scenario_summary(r),
             (r.get("error") or "").splitlines()[0] if r.get("error") else "(no message)"]
            for r in failed]
    return Section("failed", title, table(["hash", "scenario", "error"], rows,
                                          f"{len(failed)} failed row(s)", text_columns=3))


# ---------------------------------------------------------------- 11. provenance


def library_versions() -> dict[str, str]:
    """Versions of griploop, Python and the numerical libraries the results depend on."""
    out = {"griploop": package_version(), "python": platform.python_version()}
    for dist in ("numpy", "scipy", "mujoco", "control", "casadi", "scikit-learn", "matplotlib"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = "not installed"
    return out


def _provenance_section(results: Path, sweep: str | None, rows: Sequence[dict],
                        members: Mapping[str, Sequence[dict]], reproduction: Any,
                        json_config: Mapping[str, Any], created: _dt.datetime) -> Section:
    versions = library_versions()
    parts = [table(["item", "value"], [
        ["created", created.isoformat(timespec="seconds")],
        ["results store", str(results)],
        ["sweep filter", sweep or "all rows"],
        ["reproduction JSON", str(reproduction) if reproduction else "none"],
        *[[k, v] for k, v in versions.items()],
        ["row versions", ", ".join(sorted({r["version"] for r in rows})) or "none"],
    ], "Inputs and versions", text_columns=2)]
    sweep_rows = []
    for name, member_rows in members.items():
        seeds = sorted({r["config"].get("seed") for r in member_rows} - {None})
        shown = ", ".join(str(s) for s in seeds[:12]) + (" ..." if len(seeds) > 12 else "")
        sweep_rows.append([name, len(member_rows), len(seeds), shown])
    parts.append(table(["sweep", "scenarios", "distinct seeds", "seeds"], sweep_rows,
                       "Sweeps", text_columns=1))
    if json_config:
        parts.append(table(["reproduce config", "value"],
                           [[k, v] for k, v in json_config.items()], text_columns=2))
    items = "".join(f"<li><code>{esc(r['hash'])}</code> {esc(r['status'])}: "
                    f"{esc(D.scenario_summary(r))}</li>" for r in rows)
    parts.append(f"<details><summary>Config hashes of {len(rows)} rows</summary>"
                 f"<ul>{items}</ul></details>")
    return Section("provenance", "11. Provenance", "\n".join(parts))


# ---------------------------------------------------------------- registrations
register_section("summary", "scenarios.report.findings:summary_section", order=5)
register_section("combinations", lambda c: _combinations_section(c.split.episodes, c.factors),
                 order=10)
register_section("compare", lambda c: _compare_section(c.split.episodes, c.factors), order=20)
register_section("paper", lambda c: paper_section(c.sources, c.reproduction,
                                                   c.reproduction_data), order=30)
register_section("traces", lambda c: _traces_section(c.split.episodes, c.traces,
                                                     c.options["max_traces"], c.factors),
                 order=40)
register_section("loops", lambda c: _loop_section(c.designs, c.options["max_designs"]), order=50)
register_section("outcomes", lambda c: _outcome_section(c.split.episodes, c.factors), order=60)
register_section("margins", lambda c: _margin_section(c.designs, c.split.episodes), order=70)
register_section("frame", lambda c: frame_section(c.split.episodes, c.options["render_frame"],
                                                   c.options.get("frame")), order=80)
register_section("feedback", "scenarios.report.feedback:feedback_section", order=85)
register_section("published", "scenarios.published.report:published_section", order=6)
register_section("failed", lambda c: _failed_section(c.split.failed), order=90)
register_section("provenance", lambda c: _provenance_section(
    c.results, c.sweep, c.rows, c.members, c.reproduction, c.json_config, c.created), order=100)
