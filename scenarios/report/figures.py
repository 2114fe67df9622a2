"""The report's figures, drawn on :class:`matplotlib.figure.Figure` (no pyplot) and rendered
to SVG in memory (vector: sharp at any zoom, and smaller than a PNG of the same figure).

The loop figure overlays the designs' stored loops (:mod:`controllers.response`, numpy
only); the force traces are inline SVG charts of :mod:`scenarios.report.svg`.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.text import Text

from controllers.response import closed_loop_poles, state_space_response
from estimation.paper import SECTION_4_2, TABLE2_SUMMARY
from estimation.registry import MODES
from scenarios.report.loops import LoopDesign
from scenarios.report.reproduction_data import ScoreTable
from scenarios.report.summaries import PAIRED_METRICS, PairedDifference

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


def fixed_margins(fig: Figure, left: float, right: float, bottom: float, top: float,
                  **spacing: float) -> None:
    """Place the axes with margins in inches (constrained layout would cost as much as
    drawing the figure again); ``spacing``: ``wspace`` and ``hspace`` as fractions."""
    width, height = fig.get_size_inches()
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height,
                        top=1 - top / height, **spacing)


def plain_log(ax: Any, axis: str = "x") -> None:
    """Log scale on ``axis`` with plain tick labels (``0.01``, ``10``; no mathtext, whose
    parser costs the report about half a second to build); on a span of less than 20x the
    minor ticks at 2 and 5 are labelled too, on a wider one there are no minor ticks.
    Call it after plotting (the span is the axis's data limits)."""
    from matplotlib.ticker import FuncFormatter, NullLocator

    scale = ax.xaxis if axis == "x" else ax.yaxis
    (ax.set_xscale if axis == "x" else ax.set_yscale)("log")

    def minor(value: float, _: int) -> str:
        low, high = sorted(scale.get_view_interval())
        if low <= 0 or high / low > 20 or value <= 0:
            return ""
        mantissa = value / 10 ** np.floor(np.log10(value) + 1e-9)
        return f"{value:g}" if round(mantissa, 6) in (2.0, 5.0) else ""

    scale.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    low, high = sorted(ax.get_xlim() if axis == "x" else ax.get_ylim())
    if low > 0 and high / low > 20:  # no minor label: no minor ticks (each costs a Tick)
        scale.set_minor_locator(NullLocator())
    else:
        scale.set_minor_formatter(FuncFormatter(minor))


def heat_colors(value: float, vmin: float, vmax: float, cmap: str = "Reds") -> tuple[str, str]:
    """Background colour of ``value`` on the colour map ``cmap`` over ``[vmin, vmax]``, and a
    text colour readable on it (white on dark, black on light): two ``#rrggbb`` strings."""
    from matplotlib import colormaps
    from matplotlib.colors import to_hex

    t = 0.0 if vmax <= vmin else float(np.clip((value - vmin) / (vmax - vmin), 0.0, 1.0))
    r, g, b, _ = colormaps[cmap](0.05 + 0.85 * t)
    luminance = 0.2126 * r + 0.7152 * g + 0.0722 * b
    return to_hex((r, g, b)), "#ffffff" if luminance < 0.5 else "#000000"


def readable(fig: Figure, min_pt: float = MIN_FONT_PT) -> Figure:
    """Raise every text of ``fig`` (labels, ticks, legends, annotations) to at least ``min_pt``.

    Tick labels are raised through ``tick_params``, which also sizes the ticks made when
    the figure is drawn (walking the figure's artists instead would make every tick now,
    which cost the report a quarter of a second per figure).
    """
    from matplotlib.axis import Axis
    from matplotlib.font_manager import FontProperties
    from matplotlib.legend import Legend

    texts: list[Text] = []

    def collect(artist: Any) -> None:
        if isinstance(artist, Text):
            texts.append(artist)
        elif isinstance(artist, Legend):
            texts.extend([*artist.get_texts(), artist.get_title()])
        elif isinstance(artist, Axis):
            texts.extend([artist.label, artist.get_offset_text()])

    for artist in [*fig.texts, *fig.legends]:
        collect(artist)
    for ax in fig.axes:
        for artist in ax.get_children():
            collect(artist)
        for axis in ("x", "y"):
            size = FontProperties(size=matplotlib.rcParams[f"{axis}tick.labelsize"])
            if size.get_size_in_points() < min_pt:
                ax.tick_params(axis=axis, which="both", labelsize=min_pt)
    for text in texts:
        if text.get_fontsize() < min_pt:
            text.set_fontsize(min_pt)
    return fig


def svg_bytes(fig: Figure) -> bytes:
    """The figure as SVG bytes, every text at least :data:`MIN_FONT_PT` (:func:`readable`).

    Text stays text (``svg.fonttype`` none: smaller, selectable), and the file carries no
    date and fixed element ids, so the same figure gives the same bytes.
    """
    readable(fig)
    buffer = io.BytesIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "griploop-report"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None})
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
    fig = Figure(figsize=(max(6.0, 0.9 * len(names) + 2), 5.5))
    axes = fig.subplots(2, 1, sharex=True)
    longest = max((len(n) for n in names), default=4)
    fixed_margins(fig, 0.75, 0.2, 0.35 + 0.065 * longest, 0.75, hspace=0.08)
    for ax, (metric, label) in zip(axes, (("r2", "R²"), ("nrmse", "NRMSE fit")), strict=True):
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
    fig.legend(handles, labels, fontsize=9, loc="upper right", ncols=3, frameon=False)
    axes[1].set_xticks(x, names, rotation=30, ha="right")
    axes[0].set_title(title or "Validation scores, mean and SD over subjects", loc="left")
    return fig


def margins_vs_force_figure(episodes: list[dict]) -> Figure:
    """Phase and gain margin at the force each episode held, one colour per controller.

    Each point is one episode: the margins of the loop that ran at the force it
    held in the air (the scheduled design there, on the plant linearized there);
    the open marker below it is the worst over the forces the episode visited.
    """
    fig = Figure(figsize=(8, 5.5))
    ax_pm, ax_gm = fig.subplots(2, 1, sharex=True)
    fixed_margins(fig, 0.8, 0.15, 0.6, 0.15, hspace=0.08)
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
    ax_pm.legend(fontsize=9, ncols=2, loc="lower right")
    for ax in (ax_pm, ax_gm):
        plain_log(ax)
        ax.grid(True, which="both", alpha=0.3)
    return fig


def forest_figure(diffs: Sequence[PairedDifference]) -> Figure:
    """Paired controller differences ``B - A``: one panel per metric, one row per pair.

    Each row is the mean paired difference with its 95 % t interval (a bare point below
    two pairs); the dashed line is no difference. The held rate is in percentage points,
    the slip distance in mm.
    """
    from matplotlib.ticker import MaxNLocator

    metrics = list(dict.fromkeys(d.metric for d in diffs))
    pairs = list(dict.fromkeys((d.baseline, d.other) for d in diffs))
    cols = 2 if len(metrics) > 1 else 1
    rows = int(np.ceil(len(metrics) / cols))
    fig = Figure(figsize=(6.6, 0.55 + rows * (0.32 * len(pairs) + 0.95)))
    axes = fig.subplots(rows, cols, squeeze=False)
    longest = max(len(a) + len(b) + 3 for a, b in pairs)
    fixed_margins(fig, 0.25 + 0.075 * longest, 0.15, 0.35, 0.55, wspace=0.12, hspace=0.75)
    y = np.arange(len(pairs))[::-1]
    for k, (ax, metric) in enumerate(zip(axes.ravel(), metrics, strict=False)):
        scale = 100.0 if metric == "held" else 1e3 if metric == "slip_distance_m" else 1.0
        for yi, pair in zip(y, pairs, strict=True):
            d = next((d for d in diffs if d.metric == metric
                      and (d.baseline, d.other) == pair), None)
            if d is None or not np.isfinite(d.mean_diff):
                continue
            mean = d.mean_diff * scale
            if np.isfinite(d.ci_low):
                ax.errorbar(mean, yi, xerr=[[mean - d.ci_low * scale], [d.ci_high * scale - mean]],
                            fmt="o", color="C0", ms=4, capsize=3, lw=1.2)
            else:
                ax.plot(mean, yi, "o", color="C0", ms=4)
        ax.axvline(0.0, color="0.5", lw=0.8, ls="--")
        ax.set_ylim(-0.6, len(pairs) - 0.4)
        labels = [f"{b} − {a}" for a, b in pairs] if k % cols == 0 else [""] * len(pairs)
        ax.set_yticks(y, labels)
        label = ("held rate (points)" if metric == "held" else "slip distance (mm)"
                 if metric == "slip_distance_m" else PAIRED_METRICS[metric][0])
        ax.set_title(label, fontsize=10)
        ax.grid(True, axis="x", alpha=0.3)
        ax.xaxis.set_major_locator(MaxNLocator(4))
    for ax in axes.ravel()[len(metrics):]:
        ax.set_visible(False)
    fig.suptitle("Paired controller differences B − A, 95 % CI", fontsize=10)
    return fig


def held_rate_figure(x_name: str, x_levels: Sequence[str],
                     series: Sequence[tuple[str, Sequence[tuple[int, int]]]],
                     series_name: str = "") -> Figure:
    """Held rate (%) with 95 % Wilson intervals at each level of one factor, one line per
    level of another.

    Parameters
    ----------
    x_name : str
        The factor on the x axis.
    x_levels : sequence of str
        Its levels, in order.
    series : sequence of (str, sequence of (int, int))
        Per series: its label and, per x level, ``(held, episodes)``; a level with no
        episode (0 episodes) is left out.
    series_name : str
        The factor of the series (legend title); empty for one unlabelled series.
    """
    from scenarios.stats import wilson_interval

    fig = Figure(figsize=(5.6, 3.7))
    ax = fig.subplots()
    fixed_margins(fig, 0.7, 1.45 if series_name else 0.15, 0.6, 0.35)
    x = np.arange(len(x_levels), dtype=float)
    width = 0.35 if len(series) > 1 else 0.0
    markers = "osD^vP*X"
    for j, (label, counts) in enumerate(series):
        shift = (j / max(len(series) - 1, 1) - 0.5) * width if width else 0.0
        pts = [(xi + shift, k, n) for xi, (k, n) in zip(x, counts, strict=True) if n]
        if not pts:
            continue
        px = np.array([p[0] for p in pts])
        rate = np.array([100.0 * k / n for _, k, n in pts])
        ci = np.array([wilson_interval(k, n) for _, k, n in pts]) * 100.0
        ax.errorbar(px, rate, yerr=[rate - ci[:, 0], ci[:, 1] - rate], fmt=f"-{markers[j % 8]}",
                    color=f"C{j}", ms=5, capsize=3, lw=1.3, label=label or None)
    ax.set_xticks(x, list(x_levels))
    ax.set_xlim(-0.5, len(x_levels) - 0.5)
    ax.set_ylim(-4, 104)
    ax.set_xlabel(x_name)
    ax.set_ylabel("episodes held (%)")
    ax.grid(True, axis="y", alpha=0.3)
    if series_name:
        ax.legend(title=series_name, fontsize=9, title_fontsize=9, loc="upper left",
                  bbox_to_anchor=(1.0, 1.0), frameon=False)
    ax.set_title(f"Held rate by {x_name}" + (f" and {series_name}" if series_name else "")
                 + ", 95 % Wilson CI", fontsize=10)
    return fig


def loop_figure(designs: Sequence[LoopDesign]) -> Figure:
    """Bode magnitude and phase, Nyquist curve and closed-loop poles of several loops, overlaid.

    Each loop is evaluated from its stored matrices
    (:func:`controllers.response.state_space_response`), from a thousandth of its gain
    crossover (or 0.01 rad/s) to the Nyquist frequency; the legend gives each design's
    stored phase and gain margin, and the dot on each magnitude curve is its stored gain
    crossover.
    """
    fig = Figure(figsize=(10.5, 7.2))  # fixed margins: constrained layout doubles the cost
    (ax_mag, ax_nyq), (ax_ph, ax_pole) = fig.subplots(2, 2)
    fixed_margins(fig, 0.75, 0.15, 0.55, 0.35, wspace=0.22, hspace=0.28)
    theta = np.linspace(0.0, 2.0 * np.pi, 181)
    span = 2.0
    for i, d in enumerate(designs):
        color = f"C{i % 10}"
        wc = d.stored.get("crossover_rad_s")
        top = np.pi / d.dt_s * (1 - 1e-6)
        low = min(1e-2, 1e-3 * wc) if wc else 1e-2
        omega = np.geomspace(low, top, 250)
        resp = state_space_response(*d.matrices, d.dt_s, omega)
        pm, gm = d.stored.get("phase_margin_deg"), d.stored.get("gain_margin_db")
        label = (f"{d.label}: PM {_num(pm, '.0f')} deg, GM {_num(gm, '.1f')} dB")
        with np.errstate(divide="ignore"):
            ax_mag.plot(omega, 20 * np.log10(np.abs(resp)), color=color, lw=1.1)
        ax_ph.plot(omega, np.rad2deg(np.unwrap(np.angle(resp))), color=color, lw=1.1,
                   label=label)
        if wc:
            ax_mag.plot([wc], [0.0], "o", color=color, ms=4)
        ax_nyq.plot(resp.real, resp.imag, color=color, lw=1.1)
        span = max(span, float(np.clip(1.1 * np.max(np.abs(resp[omega >= (wc or 0) / 10])),
                                       2.0, 5.0)))
        poles = closed_loop_poles(*d.matrices)
        ax_pole.plot(poles.real, poles.imag, "x", color=color, ms=6)
    ax_mag.axhline(0.0, color="0.5", lw=0.8, ls="--")
    ax_ph.axhline(-180.0, color="0.5", lw=0.8, ls="--")
    for ax in (ax_mag, ax_ph):
        plain_log(ax)
    ax_mag.set_ylabel("|L| (dB)")
    ax_ph.set_ylabel("phase of L (deg)")
    ax_ph.set_xlabel("frequency (rad/s)")
    ax_mag.set_title("Bode: open loop L = C P", fontsize=10)
    ax_ph.legend(fontsize=9, loc="lower left")
    ax_nyq.plot(np.cos(theta), np.sin(theta), color="0.6", lw=0.8)
    ax_nyq.plot([-1], [0], "k+", ms=12)
    ax_nyq.set_xlim(-span, span)
    ax_nyq.set_ylim(-span, span)
    ax_nyq.set_aspect("equal")
    ax_nyq.set_xlabel("Re L")
    ax_nyq.set_ylabel("Im L")
    ax_nyq.set_title("Nyquist (w > 0); + is -1", fontsize=10)
    ax_pole.plot(np.cos(theta), np.sin(theta), color="0.6", lw=0.8)
    ax_pole.set_aspect("equal")
    ax_pole.set_xlabel("Re z")
    ax_pole.set_ylabel("Im z")
    ax_pole.set_title("Closed-loop poles (stable inside the unit circle)", fontsize=10)
    for ax in (ax_mag, ax_ph, ax_nyq, ax_pole):
        ax.grid(True, which="major", alpha=0.3)
    return fig


def _num(value: float | None, spec: str) -> str:
    if value is None or not np.isfinite(value):
        return "inf" if value is not None and value > 0 else "n/a"
    return format(value, spec)
