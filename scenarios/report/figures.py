"""The report's figures, drawn on :class:`matplotlib.figure.Figure` (no pyplot) and rendered
to PNG bytes in memory.

Loop figures (Bode, Nyquist, pole-zero) come from :mod:`controllers.figures`.
"""

from __future__ import annotations

import io
import textwrap
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.text import Annotation, Text

from estimation.paper import SECTION_4_2, TABLE2_SUMMARY
from scenarios.report.data import MODES, OutcomeGrid, ScoreTable, level_text

DPI = 80
#: Smallest font size of any text in a report figure, pt.
MIN_FONT_PT = 9.0
_MODE_COLORS = {"one_step": "C0", "free_run": "C1"}
#: Outcome maps: metric -> (OutcomeGrid attribute, colour-bar label, fixed colour range or None).
OUTCOME_METRICS: dict[str, tuple[str, str, tuple[float, float] | None]] = {
    "not_lifted": ("not_lifted_frac", "fraction not lifted", (0.0, 1.0)),
    "dropped": ("dropped_frac", "fraction dropped", (0.0, 1.0)),
    "crushed": ("crushed_frac", "fraction crushed", (0.0, 1.0)),
    "slip": ("slip_events_mean", "mean slip events", None),
}


def readable(fig: Figure, min_pt: float = MIN_FONT_PT) -> Figure:
    """Raise every text of ``fig`` (labels, ticks, legends, annotations) to at least ``min_pt``."""
    for text in fig.findobj(Text):
        if text.get_fontsize() < min_pt:
            text.set_fontsize(min_pt)
    return fig


def offset_annotations(fig: Figure, dx_pt: float = 6.0, dy_pt: float = 6.0) -> Figure:
    """Move annotations placed on their point (margin labels) ``dx_pt, dy_pt`` points away
    from it, so that the text does not sit on the curve it labels."""
    for ann in fig.findobj(Annotation):
        if ann.anncoords == "data" and tuple(ann.xyann) == tuple(ann.xy):
            ann.anncoords = "offset points"
            ann.xyann = (dx_pt, dy_pt)
    return fig


def short_title(text: str, width: int = 34) -> str:
    """``text`` wrapped on lines of at most ``width`` characters (two lines, then cut)."""
    lines = textwrap.wrap(text, width) or [""]
    if len(lines) > 2:
        lines = [lines[0], textwrap.shorten(" ".join(lines[1:]), width, placeholder=" ...")]
    return "\n".join(lines)


def png_bytes(fig: Figure, dpi: int = DPI) -> bytes:
    """The figure as PNG bytes, every text at least :data:`MIN_FONT_PT` (:func:`readable`)."""
    readable(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def paper_reference(estimator: str) -> tuple[float, float, float, float] | None:
    """The paper's (R^2 mean, SD, NRMSE mean, SD) of an estimator (one-step), if it reports one.

    Table 2's summary rows first, then section 4.2 (SS without KF; single
    features pooled over MAV, RMS and WL).
    """
    if estimator in TABLE2_SUMMARY:
        return TABLE2_SUMMARY[estimator]
    if estimator.startswith("features_"):
        return SECTION_4_2["features"]
    return SECTION_4_2.get(estimator)


def score_bars_figure(table: ScoreTable, title: str = "") -> Figure:
    """R^2 and NRMSE per estimator, one bar per mode with SD error bars, paper values marked.

    The paper's values (one-step evaluation) are drawn as black diamonds over
    the one-step bars only.
    """
    modes = [m for m in MODES if m in table] + [m for m in table if m not in MODES]
    names = list(dict.fromkeys(n for m in modes for n in table[m]))
    x = np.arange(len(names))
    width = 0.8 / max(len(modes), 1)
    fig = Figure(figsize=(max(6.0, 0.9 * len(names) + 2), 5.5), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    for ax, (metric, label) in zip(axes, (("r2", "R$^2$"), ("nrmse", "NRMSE fit")), strict=True):
        for j, mode in enumerate(modes):
            offset = (j - (len(modes) - 1) / 2) * width
            mean = np.array([getattr(table[mode][n], f"{metric}_mean") if n in table[mode]
                             else np.nan for n in names])
            sd = np.array([getattr(table[mode][n], f"{metric}_sd") if n in table[mode]
                           else np.nan for n in names])
            ax.bar(x + offset, mean, width, yerr=sd, capsize=3, label=mode,
                   color=_MODE_COLORS.get(mode, f"C{j + 2}"))
            if mode == "one_step":
                refs = [paper_reference(n) for n in names]
                idx = 0 if metric == "r2" else 2
                px = [x[i] + offset for i, r in enumerate(refs) if r is not None]
                py = [r[idx] for r in refs if r is not None]
                ax.errorbar(px, py, yerr=[r[idx + 1] for r in refs if r is not None],
                            fmt="D", color="k", ms=5, capsize=2, label="paper (one_step)")
        ax.set_ylabel(label)
        ax.set_ylim(min(0.0, float(np.nanmin(ax.get_ylim()))), 1.05)
        ax.grid(True, axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="outside upper right", ncols=3)
    axes[1].set_xticks(x, names, rotation=30, ha="right")
    axes[0].set_title(title or "Validation scores, mean and SD over subjects")
    return fig


def force_traces_figure(episodes: Sequence[tuple[str, Mapping[str, np.ndarray]]]) -> Figure:
    """Intent, reference and grip force vs time, one panel per ``(label, traces)``."""
    n = len(episodes)
    cols = 2 if n > 1 else 1
    rows = int(np.ceil(n / cols))
    fig = Figure(figsize=(5.2 * cols, 2.4 * rows + 0.4), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, sharex=False, squeeze=False)).ravel()
    for ax, (label, tr) in zip(axes, episodes, strict=False):
        ax.plot(tr["t_s"], tr["intent_n"], color="0.5", lw=1, label="intent")
        ax.plot(tr["t_s"], tr["reference_n"], color="C1", lw=1, label="reference")
        ax.plot(tr["t_s"], tr["grip_force_n"], color="C0", lw=1.2, label="grip force")
        ax.set_title(label, fontsize=9)
        ax.set_ylabel("force (N)")
        ax.grid(True, alpha=0.3)
    for ax in axes[n:]:
        ax.set_visible(False)
    for ax in axes[max(0, n - cols):n]:
        ax.set_xlabel("time (s)")
    axes[0].legend(fontsize=7, loc="upper right")
    return fig


def outcome_figure(grids: Sequence[OutcomeGrid], metric: str, row_name: str = "mass (kg)",
                   col_name: str = "friction coefficient") -> Figure:
    """Heatmaps of one outcome over two factors, one panel per facet (``grid.label``).

    Each cell shows its value and, below, the number of episodes behind it;
    empty cells stay blank.
    """
    attr, label, limits = OUTCOME_METRICS[metric]
    values = [getattr(g, attr) for g in grids]
    finite = np.concatenate([v[np.isfinite(v)] for v in values])
    vmin, vmax = limits if limits else (0.0, max(1.0, float(finite.max(initial=0.0))))
    norm = Normalize(vmin, vmax)
    n = len(grids)
    g0 = grids[0]
    n_rows, n_cols = len(g0.row_levels), len(g0.col_levels)
    cols = min(n, 3 if n_cols <= 4 else 2)
    rows = int(np.ceil(n / cols))
    cell_w = 0.75 * max(n_cols, 2)
    cell_h = 0.55 * max(n_rows, 2)
    fig = Figure(figsize=(cols * (cell_w + 1.4) + 1.2, rows * (cell_h + 1.4) + 0.3),
                 layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    image = None
    for ax, grid, value in zip(axes, grids, values, strict=False):
        image = ax.imshow(value, origin="lower", cmap="viridis" if metric == "slip" else "Reds",
                          norm=norm, aspect="auto")
        for (i, j), v in np.ndenumerate(value):
            if grid.n_episodes[i, j]:
                shade = "white" if norm(v) > 0.6 else "black"
                ax.text(j, i, f"{v:.2g}\nn={grid.n_episodes[i, j]}", ha="center", va="center",
                        fontsize=9, color=shade)
        ax.set_xticks(range(n_cols), [level_text(f) for f in grid.col_levels], fontsize=9,
                      rotation=30 if n_cols > 4 else 0)
        ax.set_yticks(range(n_rows), [level_text(m) for m in grid.row_levels], fontsize=9)
        ax.set_xlabel(col_name, fontsize=10)
        ax.set_ylabel(row_name, fontsize=10)
        ax.set_title(short_title(grid.label or str(grid.key), 30), fontsize=10)
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.colorbar(image, ax=axes[:n].tolist(), label=label, shrink=0.9)
    return fig


def trace_figure(traces: Mapping[str, np.ndarray], title: str = "") -> Figure:
    """Intent, reference and grip force vs time of one episode."""
    fig = Figure(figsize=(7.0, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.plot(traces["t_s"], traces["intent_n"], color="0.5", lw=1, label="intent")
    ax.plot(traces["t_s"], traces["reference_n"], color="C1", lw=1, label="reference")
    ax.plot(traces["t_s"], traces["grip_force_n"], color="C0", lw=1.2, label="grip force")
    if title:
        ax.set_title(short_title(title, 60), fontsize=10)
    ax.set_xlabel("time (s)", fontsize=10)
    ax.set_ylabel("force (N)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=9, loc="lower right", ncols=3)
    return fig


def margins_vs_force_figure(episodes: list[dict]) -> Figure:
    """Phase and gain margin at the force each episode held, one colour per controller.

    Each point is one episode: the margins of the loop that ran at the force it
    held in the air (the scheduled design there, on the plant linearized there);
    the open marker below it is the worst over the forces the episode visited.
    """
    fig = Figure(figsize=(8, 5.5), layout="constrained")
    ax_pm, ax_gm = fig.subplots(2, 1, sharex=True)
    kinds = sorted({str(e["result"]["controller"]) for e in episodes})
    for i, kind in enumerate(kinds):
        rows = [e["result"] for e in episodes if e["result"]["controller"] == kind
                and e["result"].get("held_force_n") is not None
                and e["result"].get("phase_margin_deg") is not None]
        if not rows:
            continue
        f = np.array([r["held_force_n"] for r in rows], float)
        pm = np.array([r["phase_margin_deg"] for r in rows], float)
        gm = np.array([np.nan if r.get("gain_margin_db") is None else r["gain_margin_db"]
                       for r in rows], float)
        wpm = np.array([np.nan if r.get("worst_phase_margin_deg") is None
                        else r["worst_phase_margin_deg"] for r in rows], float)
        color = f"C{i}"
        ax_pm.plot(f, pm, "o", color=color, label=f"{kind}: at the held force")
        ax_pm.plot(f, wpm, "v", mfc="none", color=color, label=f"{kind}: worst visited")
        ax_gm.plot(f, gm, "o", color=color)
    ax_pm.axhline(45.0, color="0.5", lw=0.8, ls="--")
    ax_pm.set_ylabel("phase margin (deg)", fontsize=11)
    ax_gm.set_ylabel("gain margin (dB)", fontsize=11)
    ax_gm.set_xlabel("grip force held in the air (N)", fontsize=11)
    ax_pm.legend(fontsize=8, ncols=2)
    for ax in (ax_pm, ax_gm):
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
    return fig
