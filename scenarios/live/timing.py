"""What a live session's report says about the machine and the stream keeping up."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


def percentile(values: np.ndarray, q: float) -> float | None:
    """The ``q``-th percentile of ``values``, ``None`` when there are none."""
    return float(np.percentile(values, q)) if values.size else None


def warnings_for(report: Mapping[str, Any]) -> list[str]:
    """What a session's report says about the machine or the stream keeping up."""
    out = []
    steps = report["control_steps"]
    dt_ms = 1e3 * report["control_dt_s"]
    if steps and report["deadline_misses"] > 0.01 * steps:
        out.append(f"the machine cannot keep up: {report['deadline_misses']} of {steps} control "
                   f"steps ({100 * report['deadline_misses'] / steps:.1f} %) took longer than "
                   f"the {dt_ms:g} ms control period")
    p99 = report["latency_ms"]["p99"]
    if p99 is not None and p99 > 0.5 * dt_ms:
        out.append(f"latency p99 {p99:.1f} ms is over half the {dt_ms:g} ms control period")
    rtf = report["realtime_factor"]["physics"]
    if rtf is not None and rtf < 2.0:
        out.append(f"the physics runs at only {rtf:.1f}x real time: little headroom")
    samples = report["samples"]
    if samples["expected"] and samples["lost"] > 0.01 * samples["expected"]:
        out.append(f"{samples['lost']} of {samples['expected']} samples "
                   f"({100 * samples['lost'] / samples['expected']:.1f} %) were lost: "
                   "check the stream's link")
    bad = report["bad_samples"]
    if bad["non_numeric"] or bad["out_of_range"]:
        out.append(f"{bad['non_numeric']} non-numeric and {bad['out_of_range']} out-of-range "
                   "samples were replaced by 0 or clipped")
    return out
