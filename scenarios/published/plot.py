"""The board as one figure: per finding, the published range beside griploop's interval."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

VERDICT_COLOURS = {"agrees": "#1b7837", "disagrees": "#b2182b", "inconclusive": "#8c6d1f",
                   "failed": "#777777"}


def plot_board(board: Mapping[str, Any], path: Path) -> Path:
    """Write the board's figure to ``path`` (PNG): one panel per finding, in order, each
    with the published range (grey band) and griploop's figure with its 95 % interval,
    coloured by verdict. A failed finding's panel says so."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = board["rows"]
    cols = 2
    n_rows = math.ceil(len(rows) / cols)
    fig, axes = plt.subplots(n_rows, cols, figsize=(11, 1.35 * n_rows + 0.8), squeeze=False)
    for ax, row in zip(axes.flat, rows, strict=False):
        _panel(ax, row)
    for ax in list(axes.flat)[len(rows):]:
        ax.axis("off")
    fig.suptitle(f"griploop published: {board['agree']} of {board['total']} findings agree "
                 f"({board['subjects']} subjects, seed {board['seed']})", fontsize=11)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _panel(ax: Any, row: Mapping[str, Any]) -> None:
    lo, hi = row["published_range"]
    figure, ci = row["figure"], row["ci95"]
    values = [v for v in (lo, hi, figure, *(ci or [])) if v is not None and math.isfinite(v)]
    span = (max(values) - min(values)) if len(values) > 1 else 1.0
    left = min(values) - 0.15 * span - 1e-9
    right = max(values) + 0.15 * span + 1e-9
    ax.axvspan(lo if math.isfinite(lo) else left, hi if math.isfinite(hi) else right,
               color="0.85", label="published")
    colour = VERDICT_COLOURS.get(row["verdict"], "#000000")
    if figure is not None:
        err = None if ci is None else [[figure - ci[0]], [ci[1] - figure]]
        ax.errorbar([figure], [0], xerr=err, fmt="o", color=colour, capsize=4)
    else:
        ax.text(0.5, 0.5, row["error"] or "no figure", transform=ax.transAxes, ha="center",
                va="center", fontsize=7, color=colour, wrap=True)
    ax.set_xlim(left, right)
    ax.set_yticks([])
    ax.set_title(f"{row['id']} ({row['unit']}): {row['verdict']}", fontsize=8, color=colour)
    ax.tick_params(labelsize=7)
