"""The paper's calibration session recorded from a live person over LSL.

The person follows cues (rest, squeeze small, medium, strong, each squeeze held
and followed by a rest, as in the paper's protocol) printed in the terminal as the
stream's time reaches them. The session is paced by the sEMG samples, like a live
session: it lasts :func:`cue_schedule`'s duration in stream time.

The force label comes from an LSL force stream when one exists (``NAME.force``, or
the only stream of type ``Force``; an FSR through an ADC streamer), interpolated at
each sEMG sample's time stamp. Without one, the label is the level each cue asks
for (a fraction of MVC) times ``mvc_n``: a prompted-force label, coarser than a
measured force (the person's reaction time and their actual effort are not in it),
and the file says so (``metadata["force_source"] == "cues"``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.live.errors import SessionError
from scenarios.live.samples import SampleGuard
from sim.recording import EMG_UNITS, Recording

LEVELS = (("small", 0.25), ("medium", 0.5), ("strong", 0.9))
"""Squeezes of the session and the share of the strongest grip each asks for."""
DEFAULT_MVC_N = 40.0
"""Force label of a 100 % squeeze without a force stream, N (virtual subjects: 30-50 N)."""


@dataclass(frozen=True)
class Cue:
    """One instruction of the calibration session.

    Attributes
    ----------
    t_s : float
        When it is given, s of stream time from the first sample.
    label : str
        ``"rest"`` or ``"squeeze small"`` ...
    level : float
        Share of the strongest grip asked for (0 at rest).
    duration_s : float
        How long it lasts, s.
    """

    t_s: float
    label: str
    level: float
    duration_s: float


def cue_schedule(*, first_rest_s: float = 3.0, squeeze_s: float = 4.0, rest_s: float = 4.0,
                 final_rest_s: float = 5.0,
                 levels: Sequence[tuple[str, float]] = LEVELS) -> tuple[list[Cue], float]:
    """The cues of a calibration session and its duration (default 28 s).

    Rest, then each squeeze for ``squeeze_s`` followed by a rest (``final_rest_s``
    after the last), so that the paper's 50 % identification split falls inside
    the medium squeeze.

    Returns
    -------
    cues : list of Cue
    duration_s : float
    """
    if min(first_rest_s, squeeze_s, rest_s, final_rest_s) <= 0:
        raise SessionError("calibration timing: expected positive rest and squeeze "
                           f"durations, found {first_rest_s}, {squeeze_s}, {rest_s}, "
                           f"{final_rest_s}")
    cues = [Cue(0.0, "rest", 0.0, first_rest_s)]
    t = first_rest_s
    for i, (name, level) in enumerate(levels):
        rest = final_rest_s if i == len(levels) - 1 else rest_s
        cues.append(Cue(t, f"squeeze {name}", float(level), squeeze_s))
        t += squeeze_s
        cues.append(Cue(t, "rest", 0.0, rest))
        t += rest
    return cues, t


def cue_levels(cues: Sequence[Cue], t_s: np.ndarray) -> np.ndarray:
    """The level asked for at each time (a step function of the cues)."""
    starts = np.array([c.t_s for c in cues])
    idx = np.clip(np.searchsorted(starts, t_s, side="right") - 1, 0, len(cues) - 1)
    return np.array([c.level for c in cues])[idx]


def say_cue(cue: Cue) -> str:
    """The terminal line of a cue."""
    if cue.level > 0:
        return (f"[{cue.t_s:5.1f} s] SQUEEZE {cue.label.split()[-1].upper()}: about "
                f"{100 * cue.level:.0f} % of your strongest grip, hold it for "
                f"{cue.duration_s:g} s")
    return f"[{cue.t_s:5.1f} s] rest: relax your hand for {cue.duration_s:g} s"


def stream_unit(inlet: Any, integer: bool) -> str:
    """The sEMG unit of a stream: int8 for int8 counts, else its channels' unit or a.u."""
    if integer:
        return "int8"
    try:
        units = inlet.info(timeout=1.0).get_channel_units() or []
    except Exception:  # noqa: BLE001 - a description is optional
        units = []
    unit = units[0] if units else None
    return unit if unit in EMG_UNITS and unit != "int8" else "a.u."


def record_calibration(emg_inlet: Any, force_inlet: Any | None, *, cues: Sequence[Cue],
                       duration_s: float, say: Callable[[str], None] = print,
                       mvc_n: float = DEFAULT_MVC_N, timeout_s: float = 5.0,
                       source: str = "lsl", stream_name: str = "",
                       force_name: str | None = None) -> Recording:
    """Record a calibration session from open inlets.

    Parameters
    ----------
    emg_inlet : pylsl.StreamInlet
        The sEMG, open, time stamps on this machine's clock.
    force_inlet : pylsl.StreamInlet or None
        A force stream in N (same clock), or ``None`` for cue labels.
    cues, duration_s
        From :func:`cue_schedule`.
    say : callable
        Where cue lines go.
    mvc_n, timeout_s : float
        Label of a 100 % squeeze without a force stream, N; no sEMG for this
        long stops the session with an error, s.

    Returns
    -------
    Recording
        The sEMG received, in order (lost samples are not filled; their count is
        in ``metadata["lost_samples"]``), with the force label.

    Raises
    ------
    SessionError
        The stream stopped for ``timeout_s``, or the force stream sent nothing.
    """
    from scenarios.live.lsl import pylsl_module

    lsl = pylsl_module()
    fs = emg_inlet.info(timeout=2.0).nominal_srate()
    if not fs > 0:
        raise SessionError(f"stream {stream_name!r} has no nominal rate; expected a regular "
                           "sEMG stream")
    integer = emg_inlet.channel_format == lsl.cf_int8
    guard = SampleGuard(integer)
    n_target = int(round(duration_s * fs))
    chunks: list[np.ndarray] = []
    stamps: list[np.ndarray] = []
    f_vals: list[float] = []
    f_stamps: list[float] = []
    received = lost = 0
    n = -1
    ts_last = ts0 = 0.0
    next_cue = 0
    last_arrival = time.monotonic()
    while n + 1 < n_target:
        samples, ts = emg_inlet.pull_chunk(timeout=0.05, max_samples=256)
        if force_inlet is not None:
            fx, fts = force_inlet.pull_chunk(timeout=0.0, max_samples=1024)
            f_vals += [float(v[0]) for v in fx]
            f_stamps += list(fts)
        now = time.monotonic()
        if not ts:
            if now - last_arrival > timeout_s:
                raise SessionError(f"stream {stream_name!r} sent nothing for {timeout_s:g} s "
                                   f"at {max(n, 0) / fs:.1f} s of the session; nothing written")
            continue
        last_arrival = now
        x = guard.clean(samples)
        t = np.asarray(ts, dtype=float)
        if n < 0:
            ts0, ts_last = float(t[0]), float(t[0]) - 1.0 / fs
        jumps = np.diff(np.concatenate([[ts_last], t])) * fs
        gaps = np.where(jumps > 1.5, np.rint(jumps) - 1, 0).astype(int)
        index = n + np.cumsum(1 + gaps)
        keep = index < n_target
        chunks.append(x[keep])
        stamps.append(t[keep])
        received += int(keep.sum())
        lost += int(gaps[keep].sum())
        n, ts_last = int(index[keep][-1]) if keep.any() else n_target, float(t[-1])
        while next_cue < len(cues) and cues[next_cue].t_s <= (n + 1) / fs:
            say(say_cue(cues[next_cue]))
            next_cue += 1
    emg = np.concatenate(chunks)
    t_emg = np.concatenate(stamps)
    if force_inlet is not None:
        force = _force_on(t_emg, force_inlet, f_vals, f_stamps, force_name)
        force_source = f"lsl:{force_name}"
    else:
        force = cue_levels(cues, t_emg - ts0) * mvc_n
        force_source = "cues"
    unit = stream_unit(emg_inlet, integer)
    metadata = {
        "source": "lsl", "stream": stream_name, "protocol": "paper_protocol (live)",
        **_cue_metadata(cues), "force_source": force_source,
        "mvc_n_cues": mvc_n if force_inlet is None else None, "lost_samples": lost,
        "bad_samples": {"non_numeric": guard.non_numeric, "out_of_range": guard.out_of_range},
        "first_timestamp": ts0,
    }
    return Recording(emg=emg.astype(np.int8) if integer else emg, fs_hz=fs,
                     force_n=np.clip(force, 0.0, None), emg_unit=unit, metadata=metadata,
                     source=source)


def _force_on(t_emg: np.ndarray, force_inlet: Any, f_vals: list[float], f_stamps: list[float],
              force_name: str | None) -> np.ndarray:
    """The force stream, read up to the last sEMG sample (1 s at most), at the sEMG times, N.

    Raises
    ------
    SessionError
        The force stream sent nothing during the session.
    """
    deadline = time.monotonic() + 1.0
    while (not f_stamps or f_stamps[-1] < t_emg[-1]) and time.monotonic() < deadline:
        fx, fts = force_inlet.pull_chunk(timeout=0.05, max_samples=1024)
        f_vals += [float(v[0]) for v in fx]
        f_stamps += list(fts)
    if not f_stamps:
        raise SessionError(f"force stream {force_name!r} sent nothing during the session; "
                           "nothing written")
    order = np.argsort(f_stamps, kind="stable")
    return np.interp(t_emg, np.asarray(f_stamps)[order], np.asarray(f_vals)[order])


def _cue_metadata(cues: Sequence[Cue]) -> dict[str, Any]:
    """The cues of a live session as a recording's metadata (as the paper's session has them)."""
    return {"cues": [[("start" if c.level > 0 else "end"), c.t_s] for c in cues[1:]],
            "cue_labels": [[c.label, c.t_s, c.level] for c in cues],
            "levels": [c.level for c in cues if c.level > 0]}
