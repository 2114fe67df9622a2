"""Lab Streaming Layer plumbing: liblsl loading, streams by name, outlets, the player.

pylsl's Linux x86-64 wheels (glibc >= 2.35) carry liblsl inside them; elsewhere pip
installs a pylsl without it, and importing pylsl fails. :func:`pylsl_module` turns
that into one line with the fix (:class:`~scenarios.live.errors.LslUnavailableError`),
and silences liblsl's own INFO logging, which otherwise prints on stderr.

A session publishes three outlets beside the EMG (:class:`SessionOutlets`), so that
LabRecorder records them in the same XDF file: ``griploop.reference`` and
``griploop.grip`` (N, one sample per control step, stamped on the EMG stream's
clock) and ``griploop.events`` (string markers: lift, slip, drop, crush, gap_start,
gap_end, session_start, session_end).
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.live.errors import LslUnavailableError, StreamMismatchError, StreamNotFoundError
from sim.recording import Recording

LSL_FIX = ("pip install pylsl on a Linux x86-64 machine with glibc >= 2.35 (its wheel carries "
           "liblsl), or install the system liblsl (https://github.com/sccn/liblsl/releases) and "
           "set PYLSL_LIB to its file")
_LOG_CONFIG = "[log]\nlevel = -3\n"  # liblsl: fatal errors only (it logs INFO and ERR lines,
# such as a stream breaking off, on stderr; griploop reports those itself)
_configured = False

EMG_TYPE = "EMG"
FORCE_TYPE = "Force"
FORCE_SUFFIX = ".force"
OUTLET_PREFIX = "griploop"


def pylsl_module() -> Any:
    """The :mod:`pylsl` module with liblsl loaded and its logging set to fatal errors only.

    Raises
    ------
    LslUnavailableError
        pylsl is missing or cannot load liblsl; the message says how to fix it.
    """
    global _configured
    try:
        import pylsl
    except Exception as exc:  # ImportError, or RuntimeError/OSError when liblsl is missing
        reason = " ".join(str(exc).split())[:100] or type(exc).__name__
        raise LslUnavailableError(
            f"Lab Streaming Layer unavailable: liblsl could not be loaded ({reason}); fix: "
            f"{LSL_FIX}"
        ) from None
    if not _configured:
        try:
            pylsl.set_config_content(_LOG_CONFIG)
        except Exception:  # noqa: S110 - logging configuration is cosmetic
            pass
        _configured = True
    return pylsl


def format_name(channel_format: int) -> str:
    """``"int8"``, ``"float32"``, ... for a pylsl channel format constant."""
    lsl = pylsl_module()
    names = {lsl.cf_float32: "float32", lsl.cf_double64: "double64", lsl.cf_string: "string",
             lsl.cf_int32: "int32", lsl.cf_int16: "int16", lsl.cf_int8: "int8",
             lsl.cf_int64: "int64"}
    return names.get(channel_format, f"format {channel_format}")


def describe(info: Any) -> str:
    """``'name' (type, 8 ch, 200 Hz, int8)`` for a stream's info."""
    rate = info.nominal_srate()
    rate_text = f"{rate:g} Hz" if rate > 0 else "irregular rate"
    return (f"{info.name()!r} ({info.type() or 'no type'}, {info.channel_count()} ch, {rate_text}, "
            f"{format_name(info.channel_format())})")


def resolve(name: str, timeout_s: float, *, what: str = "stream") -> Any:
    """The first LSL stream named ``name`` that appears within ``timeout_s``.

    Raises
    ------
    StreamNotFoundError
        None did; the message lists every stream seen meanwhile.
    """
    lsl = pylsl_module()
    resolver = lsl.ContinuousResolver(forget_after=max(5.0, 2 * timeout_s))
    try:
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            seen = resolver.results()
            match = [s for s in seen if s.name() == name]
            if match:
                return match[0]
            if time.monotonic() >= deadline:
                break
            time.sleep(0.05)
    finally:
        del resolver
    listed = ", ".join(sorted({describe(s) for s in seen})) or "none"
    raise StreamNotFoundError(
        f"no LSL {what} named {name!r} within {timeout_s:g} s; streams seen: {listed}"
    )


def find_force_stream(emg_name: str, timeout_s: float) -> Any | None:
    """A force stream to go with ``emg_name``: ``NAME.force``, else the only ``Force`` one.

    Returns ``None`` when there is none (or several, none named ``NAME.force``).
    """
    lsl = pylsl_module()
    named = lsl.resolve_byprop("name", emg_name + FORCE_SUFFIX, 1, timeout_s)
    if named:
        return named[0]
    found = lsl.resolve_byprop("type", FORCE_TYPE, 2, 0.25)
    return found[0] if len({s.name() for s in found}) == 1 else None


def check_stream(info: Any, *, n_channels: int, fs_hz: float, source: str) -> None:
    """Refuse a stream whose channel count or nominal rate differs from the calibration's.

    Raises
    ------
    StreamMismatchError
        One line naming both.
    """
    count, rate = info.channel_count(), info.nominal_srate()
    if count != n_channels or abs(rate - fs_hz) > 1e-6 * fs_hz:
        raise StreamMismatchError(
            f"LSL stream {info.name()!r} has {count} channels at {rate:g} Hz but the "
            f"calibration recording {source} has {n_channels} channels at {fs_hz:g} Hz; "
            "expected the same channel count and rate"
        )


def open_inlet(info: Any, *, buffer_s: float = 30.0, open_timeout_s: float = 5.0,
               prime_clock: bool = True) -> Any:
    """An inlet for real-time use, connected before it is returned.

    One-sample transmission granularity (``max_chunklen=1``), timestamps mapped
    to this machine's clock (``proc_clocksync``), recovery when a stream with a
    source id comes back. With ``prime_clock`` the clock offset is measured before
    the data connection opens: its first estimate takes about half a second, during
    which samples would otherwise queue (a real-time session wants that done first).
    """
    lsl = pylsl_module()
    inlet = lsl.StreamInlet(info, max_buflen=max(1, int(np.ceil(buffer_s))), max_chunklen=1,
                            recover=True, processing_flags=lsl.proc_clocksync)
    if prime_clock:
        try:
            inlet.time_correction(timeout=open_timeout_s)
        except Exception:  # noqa: BLE001 - a timeout here leaves the correction to the stream
            pass
    inlet.open_stream(timeout=open_timeout_s)
    return inlet


def _set_channels(info: Any, labels: Sequence[str], unit: str, kind: str) -> None:
    channels = info.desc().append_child("channels")
    for label in labels:
        ch = channels.append_child("channel")
        ch.append_child_value("label", str(label))
        ch.append_child_value("unit", unit)
        ch.append_child_value("type", kind)


def _source_id(name: str) -> str:
    return f"{OUTLET_PREFIX}:{name}@{socket.gethostname()}"


class SessionOutlets:
    """The outlets a live session publishes: reference, grip and events.

    Parameters
    ----------
    control_hz : float
        Nominal rate of the reference and grip streams (the control rate), Hz.
    prefix : str
        Stream name prefix (``griploop``: ``griploop.reference`` ...).
    """

    def __init__(self, control_hz: float, *, prefix: str = OUTLET_PREFIX,
                 feedback: str | None = None) -> None:
        lsl = pylsl_module()
        self.names = (f"{prefix}.reference", f"{prefix}.grip", f"{prefix}.events")
        self._feedback = None
        if feedback is not None:
            # the stimulator's intensity (0..1) for a lab's tactor driver
            name = f"{prefix}.feedback"
            info = lsl.StreamInfo(name, "Stimulus", 1, float(control_hz), lsl.cf_float32,
                                  _source_id(name))
            _set_channels(info, [feedback], "intensity", "Vibration")
            self._feedback = lsl.StreamOutlet(info, chunk_size=1)
            self.names = (*self.names, name)
        outlets = []
        for name, label in zip(self.names[:2], ("reference", "grip"), strict=True):
            info = lsl.StreamInfo(name, FORCE_TYPE, 1, float(control_hz), lsl.cf_float32,
                                  _source_id(name))
            _set_channels(info, [label], "N", "Force")
            outlets.append(lsl.StreamOutlet(info, chunk_size=1))
        events = lsl.StreamInfo(self.names[2], "Markers", 1, lsl.IRREGULAR_RATE, lsl.cf_string,
                                _source_id(self.names[2]))
        outlets.append(lsl.StreamOutlet(events))
        self._reference, self._grip, self._events = outlets
        self._one = [0.0]

    def step(self, timestamp: float, reference_n: float, grip_n: float,
             feedback: float = 0.0) -> None:
        """Publish one control step's reference and grip force (N), and the feedback
        intensity (0..1) if there is a feedback outlet, at ``timestamp``."""
        one = self._one
        one[0] = reference_n
        self._reference.push_sample(one, timestamp)
        one[0] = grip_n
        self._grip.push_sample(one, timestamp)
        if self._feedback is not None:
            one[0] = feedback
            self._feedback.push_sample(one, timestamp)

    def event(self, timestamp: float, marker: str) -> None:
        """Publish one event marker."""
        self._events.push_sample([marker], timestamp)

    def close(self) -> None:
        """Withdraw the outlets."""
        self._reference = self._grip = self._events = self._feedback = None


@dataclass(frozen=True)
class Dropout:
    """A stretch of a played recording that is not sent (a wireless dropout).

    Attributes
    ----------
    at_s : float
        Stream time at which sending stops, s from the first sample.
    duration_s : float
        How long nothing is sent, s; the samples in between are lost.
    """

    at_s: float
    duration_s: float


def play(recording: Recording, name: str, *, loop: bool = False, speed: float = 1.0,
         dropouts: Sequence[Dropout] = (), wait_for_consumer: bool = True,
         lead_s: float = 0.05, log: Callable[[str], None] = print,
         stop: Callable[[], bool] | None = None) -> int:
    """Play a recording as an LSL outlet at its own rate (and its force, if it has one).

    The EMG outlet is named ``name`` (type ``EMG``; ``int8`` for MYO counts, else
    ``float32``; channel labels and unit in its description); the force, if the
    recording has one, goes to ``name.force`` (type ``Force``, N). Sample ``i`` is
    stamped ``t0 + i / (speed * fs_hz)`` on the LSL clock and pushed at that time.

    Parameters
    ----------
    recording : Recording
    name : str
        Stream name.
    loop : bool
        Start again at the end, for ever (stamps keep increasing).
    speed : float
        Play this many times faster than real time (tests, demos).
    dropouts : sequence of Dropout
        Stretches not sent (stream time, s).
    wait_for_consumer : bool
        Start playing only once an inlet has connected, so it gets the first sample.
    lead_s : float
        Delay between the start and the first sample, s.
    log : callable
        Where progress lines go.
    stop : callable, optional
        Polled between samples; playing ends when it returns True.

    Returns
    -------
    int
        Samples sent.
    """
    lsl = pylsl_module()
    fs, n = recording.fs_hz, recording.n_samples
    integer = recording.emg.dtype == np.int8
    fmt = lsl.cf_int8 if integer else lsl.cf_float32
    info = lsl.StreamInfo(name, EMG_TYPE, recording.n_channels, fs, fmt, _source_id(name))
    _set_channels(info, recording.channel_names, recording.emg_unit, EMG_TYPE)
    outlet = lsl.StreamOutlet(info, chunk_size=1)
    force_outlet = None
    if recording.force_n is not None:
        finfo = lsl.StreamInfo(name + FORCE_SUFFIX, FORCE_TYPE, 1, fs, lsl.cf_float32,
                               _source_id(name + FORCE_SUFFIX))
        _set_channels(finfo, ["force"], "N", FORCE_TYPE)
        force_outlet = lsl.StreamOutlet(finfo, chunk_size=1)
    log(f"streaming {recording.source} as LSL {describe(info)}"
        + (f" and its force as {name + FORCE_SUFFIX!r}" if force_outlet else "")
        + f", {recording.duration_s:.1f} s" + (" looped" if loop else "")
        + (f" at {speed:g}x" if speed != 1 else ""))
    if wait_for_consumer:
        log(f"waiting for a consumer of {name!r} ...")
        while not outlet.wait_for_consumers(0.25):
            if stop is not None and stop():
                return 0
    rows = recording.emg.tolist()
    forces = None if recording.force_n is None else recording.force_n.tolist()
    period = 1.0 / (fs * speed)
    skip = [(int(np.floor(d.at_s * fs)), int(np.ceil((d.at_s + d.duration_s) * fs)))
            for d in dropouts]
    clock, sleep = lsl.local_clock, time.sleep
    t0 = clock() + lead_s
    sent = i = 0
    one = [0.0]
    while True:
        for j in range(n):
            if stop is not None and stop():
                return sent
            if any(a <= i < b for a, b in skip):
                i += 1
                continue
            t = t0 + i * period
            delay = t - clock()
            if delay > 0:
                sleep(delay)
            outlet.push_sample(rows[j], t)
            if force_outlet is not None:
                one[0] = forces[j]
                force_outlet.push_sample(one, t)
            sent += 1
            i += 1
        if not loop:
            break
    log(f"sent {sent} samples in {clock() - t0:.2f} s")
    return sent
