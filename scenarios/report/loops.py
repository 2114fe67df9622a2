"""Loop designs the episodes ran, read from the store (margins stored; matrices in the traces)."""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from scenarios.report.data import LOOP_TRACES, check_traces

if TYPE_CHECKING:  # python-control is imported only to re-analyse loops (recheck)
    import control

    from controllers.analysis import LoopMargins


# ---------------------------------------------------------------- loop designs


#: Margin fields of an episode row: the episode runner computed them with
#: :func:`controllers.analysis.loop_margins` of the loop it ran at the held force.
STORED_MARGINS = ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_rad_s",
                  "n_crossovers", "ms", "stable", "bandwidth_rad_s")


@dataclass(frozen=True)
class LoopDesign:
    """One distinct analysed open loop of the episodes, with its margins.

    Attributes
    ----------
    label : str
        ``"D1 pid"``: number in order of appearance and controller.
    controller : str
        Controller family.
    matrices : tuple of ndarray
        The loop's ``(A, B, C, D)`` as stored with the first episode.
    dt_s : float
        Its sampling period, s.
    stored : dict
        The first episode's stored margins (:data:`STORED_MARGINS`, ``None`` where absent).
    hashes : list of str
        Store hashes of the episodes that share this loop.
    conditions : list of str
        ``"object m=0.2 kg mu=0.8"`` of those episodes (distinct, in order).
    margins : LoopMargins or None
        :func:`controllers.analysis.loop_margins` of the rebuilt loop, when re-analysed
        (``loop_designs(..., recheck=True)``).
    row_agrees : bool or None
        Whether the stored scalars (gain and phase margin, Ms, stable) match the
        re-analysed margins (rtol 1e-3); ``None`` when not re-analysed.
    """

    label: str
    controller: str
    matrices: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    dt_s: float
    stored: dict[str, Any]
    hashes: list[str]
    conditions: list[str]
    margins: LoopMargins | None = None
    row_agrees: bool | None = None


def loop_matrices(traces: Mapping[str, np.ndarray]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of the analysed loop in an episode's traces, each 2-D."""
    a, b, c, d = (np.atleast_2d(np.asarray(traces[n], dtype=float)) for n in LOOP_TRACES)
    return a, b, c, d


def rebuild_loop(traces: Mapping[str, np.ndarray], dt_s: float) -> control.StateSpace:
    """The analysed open loop ``control.ss(A, B, C, D, dt)`` from an episode's loop traces."""
    import control

    return control.ss(*loop_matrices(traces), float(dt_s))


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
                 traces: Mapping[str, Mapping[str, np.ndarray]],
                 label: Any = None, *, recheck: bool = True) -> list[LoopDesign]:
    """Distinct analysed loops of the episodes, in order of first appearance.

    Parameters
    ----------
    episodes : sequence of dict
        ``ok`` episode rows.
    traces : dict of str to dict
        Store hash -> that row's traces (must hold :data:`~scenarios.report.data.LOOP_TRACES`).
    label : callable, optional
        Condition text of an episode row (default: :func:`condition_label` of
        its result).
    recheck : bool
        Re-analyse each loop with :func:`controllers.analysis.loop_margins` (imports
        python-control; about 0.1 s a loop) and compare with the stored margins; otherwise
        the designs carry the stored margins only.

    Episodes that never held a force in the air (``held_force_n`` is None: not
    lifted, or crushed on the way) and carry no loop traces are skipped.

    Raises
    ------
    ReportInputError
        A row that held a force lacks a loop trace, or has only some of them.
    """
    found: dict[str, dict[str, Any]] = {}
    for row in episodes:
        res, tr = row["result"], traces[row["hash"]]
        if not any(n in tr for n in LOOP_TRACES) and res.get("held_force_n") is None:
            continue  # never held a force in the air: the episode analysed no loop
        check_traces(row, tr, LOOP_TRACES)
        key = loop_fingerprint(tr, res["loop_dt_s"])
        entry = found.setdefault(key, {"row": row, "hashes": [], "conditions": []})
        entry["hashes"].append(row["hash"])
        text = label(row) if label is not None else condition_label(res)
        if text not in entry["conditions"]:
            entry["conditions"].append(text)
    designs = []
    for i, entry in enumerate(found.values(), start=1):
        row = entry["row"]
        res = row["result"]
        margins, agrees = None, None
        if recheck:
            from controllers.analysis import loop_margins

            margins = loop_margins(rebuild_loop(traces[row["hash"]], res["loop_dt_s"]))
            agrees = (_close(res["gain_margin_db"], margins.gain_margin_db)
                      and _close(res["phase_margin_deg"], margins.phase_margin_deg)
                      and _close(res["ms"], margins.ms)
                      and bool(res["stable"]) == margins.stable)
        designs.append(LoopDesign(
            f"D{i} {res['controller']}", str(res["controller"]),
            loop_matrices(traces[row["hash"]]), float(res["loop_dt_s"]),
            {k: res.get(k) for k in STORED_MARGINS}, entry["hashes"], entry["conditions"],
            margins, agrees))
    return designs
