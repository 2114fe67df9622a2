"""Which estimator a deployed prosthesis should use, decided from the numbers.

A prosthesis has no force sensor, so only ``free_run`` (sEMG-only) figures count. Among
the estimators that ran on every subject, those whose mean R^2 is within
:data:`MEAN_TOLERANCE` of the best mean are the contenders; the one with the best worst
subject wins (then the best mean): an estimator that fails one person in ten is not
recommended over one that is almost as good on average and never fails.

:func:`recommend` returns the JSON contract of ``griploop reproduce --json``
(``recommendation``); its ``reason`` is the one sentence the command, the report and the
results (docs/results/realism.md) show.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

#: Mean R^2 within which contenders are compared by their worst subject.
MEAN_TOLERANCE = 0.02


def _label(name: str) -> str:
    from estimation.registry import estimator_label

    return estimator_label(name)


def channels_phrase(channels: str | Sequence[str] | None) -> str:
    """``"on all 8 channels"``, ``"on channels 6,7,8"`` or ``""``."""
    if channels is None:
        return ""
    if channels == "all":
        return " on all 8 channels"
    return f" on channels {','.join(str(c) for c in channels)}"


def recommend(free_run: Mapping[str, Mapping[str, Any]], *,
              channels: str | Sequence[str] | None = None,
              one_step_reference: float | None = None,
              where: str = "") -> dict[str, Any] | None:
    """The recommended estimator and why.

    Parameters
    ----------
    free_run : mapping
        Estimator name -> ``{"r2_mean", "r2_min", "n_ok", "n"}`` over subjects in free_run
        (``n_ok``: subjects where it ran; ``n``: subjects).
    channels : "all", sequence of str or None
        The channel set of the figures (for the sentence and the contract).
    one_step_reference : float, optional
        The paper's SS_KF one_step mean, for context in the sentence.
    where : str
        Which subjects the figures come from, for the sentence (e.g. ``" on 10 virtual
        subjects none of them was trained on (...)"``).

    Returns
    -------
    dict or None
        ``{"estimator", "channels", "mode", "r2_mean", "r2_min", "runner_up", "reason"}``,
        or None when no estimator ran in free_run on every subject.
    """
    full = {n: e for n, e in free_run.items()
            if e.get("r2_mean") is not None and e.get("r2_min") is not None
            and e.get("n") and e.get("n_ok") == e.get("n")}
    if not full:
        return None
    best_mean = max(e["r2_mean"] for e in full.values())
    contenders = [n for n, e in full.items() if e["r2_mean"] >= best_mean - MEAN_TOLERANCE]
    pick = max(contenders, key=lambda n: (full[n]["r2_min"], full[n]["r2_mean"]))
    others = sorted((n for n in full if n != pick), key=lambda n: -full[n]["r2_mean"])
    runner = others[0] if others else None
    e = full[pick]
    reason = (f"A deployed prosthesis has no force sensor, so it should use {_label(pick)} "
              f"in free_run{channels_phrase(channels)}: mean R2 {e['r2_mean']:.3f} and worst "
              f"subject {e['r2_min']:.3f}{where}")
    if runner is not None:
        r = full[runner]
        reason += (f"; the next best mean is {_label(runner)}'s ({r['r2_mean']:.3f}, worst "
                   f"{r['r2_min']:.3f})")
    if pick != max(full, key=lambda n: full[n]["r2_mean"]):
        top = max(full, key=lambda n: full[n]["r2_mean"])
        reason += (f"; {_label(top)}'s mean is higher by {full[top]['r2_mean'] - e['r2_mean']:.3f}"
                   f" but its worst subject is {full[top]['r2_min']:.3f}")
    if one_step_reference is not None:
        verdict = "above" if e["r2_mean"] >= one_step_reference else "below"
        reason += (f"; that is {verdict} the paper's SS_KF one_step figure "
                   f"({one_step_reference:.3f}), which needs the measured force at k-1")
    return {"estimator": pick, "channels": channels, "mode": "free_run",
            "r2_mean": float(e["r2_mean"]), "r2_min": float(e["r2_min"]),
            "runner_up": runner, "reason": reason + "."}
