"""Lab Streaming Layer plumbing: liblsl loading, streams by identity, inlets and outlets.

pylsl's Linux x86-64 wheels (glibc >= 2.35) carry liblsl inside them; elsewhere pip
installs a pylsl without it, and importing pylsl fails. :func:`pylsl_module` turns
that into one line with the fix (:class:`~scenarios.live.errors.LslUnavailableError`),
and silences liblsl's own INFO logging, which otherwise prints on stderr.

A session publishes three outlets beside the EMG (:class:`SessionOutlets`), so that
LabRecorder records them in the same XDF file: ``griploop.reference`` and
``griploop.grip`` (N, one sample per control step, stamped on the EMG stream's
clock) and ``griploop.events`` (string markers: lift, slip, drop, crush, gap_start,
gap_end, session_start, session_end, source_changed, imu_gap_start, imu_gap_end,
key_lift, key_lower).

**Which stream.** LSL carries no authentication: any machine on the network can
publish a stream of any name. A session therefore pins one stream, by identity:
:func:`resolve_streams` collects every stream of the names (until
:data:`RESOLVE_SETTLE_S` after each had appeared), keeps those on the host and with
the ``source_id`` asked for (:class:`StreamQuery`), and refuses several matches
(:class:`~scenarios.live.errors.AmbiguousStreamError`, listing each one's host,
``source_id``, channels, rate and format) and a stream from another host unless
remote streams are allowed (:class:`~scenarios.live.errors.RemoteStreamError`). A
stream keeps its identity for the whole session: liblsl recovers an inlet only to a
stream of the same ``source_id`` (none without one), and :class:`SourceWatch` tells a
session when its source is gone from the network while another source serves the
name. griploop's own outlets carry a ``source_id`` unique to the outlet and its process
(:func:`outlet_source_id`), so two players on one host are told apart.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import socket
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.live.errors import (
    AmbiguousStreamError,
    LslUnavailableError,
    RemoteStreamError,
    StreamMismatchError,
    StreamNotFoundError,
    StreamSpecError,
)

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
IMU_TYPE = "IMU"
IMU_SUFFIX = ".imu"
IMU_FS_HZ = 50.0
"""Rate of the orientation stream :func:`scenarios.live.player.play` publishes, Hz (the
MYO's IMU rate)."""
QUATERNION_LABELS = ("qw", "qx", "qy", "qz")
RESOLVE_SETTLE_S = 1.0
"""Once a stream of the name has appeared, look this much longer for others, s (liblsl
queries the network every 0.5 s: two rounds)."""
MAX_SOURCE_ID = 255
#: A source_id as given on the command line: printable, no spaces and no quotes (liblsl's
#: queries quote values with ``'``).
_SOURCE_ID = re.compile(rf"[^\s'\"]{{1,{MAX_SOURCE_ID}}}")
SOURCE_ID_FORM = ("1 to 255 printable characters without spaces or quotes, such as "
                  "griploop:myo@lab-pc:4242.1a2b3c4d.1")
NAME_FORM = "NAME or NAME@HOST (a stream name, optionally with the host it must come from)"
#: Every outlet this process makes gets a source_id with this tag and its own number.
_PROCESS_TAG = f"{os.getpid()}.{time.time_ns() // 1_000_000 % 16 ** 8:08x}"
_outlet_numbers = itertools.count(1)


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


def local_host() -> str:
    """This machine's host name, as liblsl reports it in a stream's ``hostname()``."""
    return socket.gethostname()


def check_source_id(text: str) -> str:
    """``text`` as a source_id to look for.

    Raises
    ------
    StreamSpecError
        Empty, too long, or with spaces, quotes or control characters; the message
        names the expected form.
    """
    if not isinstance(text, str) or not _SOURCE_ID.fullmatch(text) or not text.isprintable():
        raise StreamSpecError(f"expected a source_id of {SOURCE_ID_FORM}, found {text!r}")
    return text


@dataclass(frozen=True)
class StreamQuery:
    """Which stream a session takes: a name, and optionally its host and source_id.

    Attributes
    ----------
    name : str
        The stream's name.
    host : str or None
        The host it must come from (``hostname()`` of its info).
    source_id : str or None
        The ``source_id`` it must have.
    allow_remote : bool
        Accept a stream from another host than this one.
    """

    name: str
    host: str | None = None
    source_id: str | None = None
    allow_remote: bool = False

    @classmethod
    def parse(cls, text: str, *, source_id: str | None = None,
              allow_remote: bool = False) -> StreamQuery:
        """``NAME`` or ``NAME@HOST`` (split at the last ``@``), with an optional source_id.

        Raises
        ------
        StreamSpecError
            An empty name or host, or a malformed source_id; one line naming the form.
        """
        text = str(text)
        name, at, host = text.rpartition("@") if "@" in text else (text, "", "")
        if not name.strip() or (at and not host.strip()) or host != host.strip():
            raise StreamSpecError(f"expected {NAME_FORM}, found {text!r}")
        return cls(name, host or None, None if source_id is None else check_source_id(source_id),
                   bool(allow_remote))

    def __str__(self) -> str:
        text = repr(self.name) + (f" on host {self.host!r}" if self.host else "")
        return text + (f" with source_id {self.source_id!r}" if self.source_id else "")


def identity(info: Any) -> dict[str, Any]:
    """What identifies a stream and what it carries (JSON-ready)."""
    return {"name": info.name(), "type": info.type(), "host": info.hostname(),
            "source_id": info.source_id(), "n_channels": info.channel_count(),
            "fs_hz": info.nominal_srate(), "format": format_name(info.channel_format())}


def source_of(info: Any) -> str:
    """``host 'h', source_id 's'`` for a stream's info."""
    return f"host {info.hostname()!r}, source_id {info.source_id() or '(none)'!r}"


def describe_source(info: Any) -> str:
    """``host 'h', source_id 's' (EMG, 8 ch, 200 Hz, int8)`` for a stream's info."""
    rate = info.nominal_srate()
    rate_text = f"{rate:g} Hz" if rate > 0 else "irregular rate"
    return (f"{source_of(info)} ({info.type() or 'no type'}, {info.channel_count()} ch, "
            f"{rate_text}, {format_name(info.channel_format())})")


def resolve_named(names: Sequence[str], timeout_s: float, *,
                  settle_s: float = RESOLVE_SETTLE_S,
                  optional: Sequence[str] = ()) -> tuple[dict[str, list[Any]], list[Any]]:
    """Every LSL stream of each name, and every stream seen meanwhile.

    Looks for up to ``timeout_s``; once every name not in ``optional`` has a stream,
    goes on for ``settle_s`` more, so that several streams of a name already on the
    network are all found (and an optional one that is there).

    Returns
    -------
    matches : dict of str to list of pylsl.StreamInfo
        The streams of each name (empty when none appeared in time).
    seen : list of pylsl.StreamInfo
        Every stream seen.
    """
    lsl = pylsl_module()
    names = list(names)
    required = [n for n in names if n not in optional] or names
    resolver = lsl.ContinuousResolver(forget_after=max(5.0, 2 * (timeout_s + settle_s)))
    try:
        deadline = time.monotonic() + max(0.0, timeout_s)
        while True:
            seen = resolver.results()
            now = time.monotonic()
            present = {s.name() for s in seen}
            if all(n in present for n in required) and deadline > now + settle_s:
                deadline = now + settle_s
            if now >= deadline:
                break
            time.sleep(0.05)
    finally:
        del resolver
    return {n: [s for s in seen if s.name() == n] for n in names}, seen


def choose_stream(matches: Sequence[Any], query: StreamQuery, *, what: str = "stream",
                  here: str | None = None, seen: Sequence[Any] = ()) -> Any:
    """The one stream of ``matches`` that ``query`` asks for.

    Parameters
    ----------
    matches : sequence of pylsl.StreamInfo
        The streams named ``query.name``.
    query : StreamQuery
    what : str
        What the stream is, for the messages (``stream``, ``IMU stream``).
    here : str, optional
        This machine's host name (default :func:`local_host`).
    seen : sequence of pylsl.StreamInfo
        Every stream seen, listed when none matches.

    Raises
    ------
    StreamNotFoundError
        No stream of the name, or none on the host or with the source_id asked for.
    AmbiguousStreamError
        Several streams match; the message lists each one's host, source_id,
        channels, rate and format.
    RemoteStreamError
        The match is on another host and remote streams are not allowed.
    """
    here = local_host() if here is None else here
    if not matches:
        listed = ", ".join(sorted({describe(s) for s in seen})) or "none"
        raise StreamNotFoundError(f"no LSL {what} named {query.name!r}; streams seen: {listed}")
    found = list(matches)
    if query.host is not None:
        found = [s for s in found if s.hostname() == query.host]
    if query.source_id is not None:
        found = [s for s in found if s.source_id() == query.source_id]
    if not found:
        listed = "; ".join(describe_source(s) for s in matches)
        raise StreamNotFoundError(f"no LSL {what} {query}; the streams named {query.name!r} "
                                  f"are: {listed}")
    if len(found) > 1:
        listed = "; ".join(describe_source(s) for s in found)
        raise AmbiguousStreamError(
            f"{len(found)} LSL {what}s match {query}: {listed}; expected one: choose it by "
            "its host or its source_id")
    info = found[0]
    if info.hostname() != here and not query.allow_remote:
        raise RemoteStreamError(
            f"LSL {what} {query.name!r} ({describe_source(info)}) comes from another host than "
            f"this one ({here!r}); LSL has no authentication, so a remote stream is taken "
            "only when remote streams are allowed, on a lab network you trust")
    return info


def resolve_streams(queries: Sequence[StreamQuery], timeout_s: float, *,
                    whats: Sequence[str] | None = None, optional: Sequence[str] = (),
                    settle_s: float = RESOLVE_SETTLE_S) -> list[Any]:
    """The one LSL stream each query asks for, resolved together.

    Parameters
    ----------
    queries : sequence of StreamQuery
    timeout_s, settle_s : float
        See :func:`resolve_named`, s.
    whats : sequence of str, optional
        What each stream is, for the messages (default ``stream``).
    optional : sequence of str
        Names that need not exist: ``None`` in their place when none does.

    Raises
    ------
    StreamNotFoundError, AmbiguousStreamError, RemoteStreamError
        As :func:`choose_stream`, for the first query refused.
    """
    whats = list(whats) if whats is not None else ["stream"] * len(queries)
    matches, seen = resolve_named([q.name for q in queries], timeout_s, settle_s=settle_s,
                                  optional=optional)
    out = []
    for query, what in zip(queries, whats, strict=True):
        found = matches[query.name]
        if not found and query.name in optional:
            out.append(None)
            continue
        try:
            out.append(choose_stream(found, query, what=what, seen=seen))
        except StreamNotFoundError as exc:
            if found:
                raise
            raise StreamNotFoundError(f"{exc} (looked for {timeout_s:g} s)") from None
    return out


def resolve_stream(query: StreamQuery, timeout_s: float, *, what: str = "stream",
                   settle_s: float = RESOLVE_SETTLE_S) -> Any:
    """The one LSL stream ``query`` asks for (:func:`resolve_streams` of one query)."""
    return resolve_streams([query], timeout_s, whats=[what], settle_s=settle_s)[0]


class SourceWatch:
    """Whether a session's stream has been replaced by another source of its name.

    A continuous resolver follows the streams of the name. The pinned stream is
    known by its ``source_id`` (a restarted streamer with the same source_id is the
    same source: liblsl reconnects the inlet to it), or by its ``uid`` when it has
    no source_id. :meth:`replacement` returns another stream of the name when the
    pinned one is no longer on the network; a stream that merely stops sending
    (a wireless dropout) stays on the network and is not replaced.

    Parameters
    ----------
    info : pylsl.StreamInfo
        The pinned stream (its :func:`identity` is kept as :attr:`identity`).
    forget_after_s : float
        A stream that has not answered liblsl's queries for this long is gone, s.
    every_s : float
        Ask the resolver at most this often, s.
    """

    def __init__(self, info: Any, *, forget_after_s: float = 1.5, every_s: float = 0.25) -> None:
        lsl = pylsl_module()
        self.name, self.source_id, self.uid = info.name(), info.source_id(), info.uid()
        self.identity = identity(info)
        self.every_s = float(every_s)
        self._resolver = lsl.ContinuousResolver(prop="name", value=self.name,
                                                forget_after=float(forget_after_s))
        self._next = -math.inf

    def pinned(self, info: Any) -> bool:
        """Whether ``info`` is the pinned source."""
        if self.source_id:
            return info.source_id() == self.source_id
        return info.uid() == self.uid

    def replacement(self, now: float) -> Any | None:
        """Another source serving the name while the pinned one is gone, else ``None``.

        ``now`` is a monotonic time, s: the resolver is asked at most every ``every_s``.
        """
        if now < self._next or self._resolver is None:
            return None
        self._next = now + self.every_s
        streams = [s for s in self._resolver.results() if s.name() == self.name]
        if not streams or any(self.pinned(s) for s in streams):
            return None
        return streams[0]

    def close(self) -> None:
        """Stop following the name."""
        self._resolver = None


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
    to this machine's clock (``proc_clocksync``), recovery when a stream with the
    same source_id comes back (liblsl recovers only to the same source_id, and a
    stream without one not at all: its inlet reports it lost). With ``prime_clock``
    the clock offset is measured before the data connection opens: its first
    estimate takes about half a second, during which samples would otherwise queue
    (a real-time session wants that done first).
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


def set_channels(info: Any, labels: Sequence[str], unit: str, kind: str) -> None:
    """Describe a stream's channels (label, unit, type) in its info, as LSL's XDF meta-data does."""
    channels = info.desc().append_child("channels")
    for label in labels:
        ch = channels.append_child("channel")
        ch.append_child_value("label", str(label))
        ch.append_child_value("unit", unit)
        ch.append_child_value("type", kind)


def outlet_source_id(name: str) -> str:
    """A source_id for an outlet named ``name``, unique to the outlet and this process.

    ``griploop:NAME@HOST:PID.TAG.N``: the host, the process id, a tag from the
    process's start time (a later process with a reused id gets another one) and
    the outlet's number in the process.
    """
    return f"{OUTLET_PREFIX}:{name}@{local_host()}:{_PROCESS_TAG}.{next(_outlet_numbers)}"



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
                                  outlet_source_id(name))
            set_channels(info, [feedback], "intensity", "Vibration")
            self._feedback = lsl.StreamOutlet(info, chunk_size=1)
            self.names = (*self.names, name)
        outlets = []
        for name, label in zip(self.names[:2], ("reference", "grip"), strict=True):
            info = lsl.StreamInfo(name, FORCE_TYPE, 1, float(control_hz), lsl.cf_float32,
                                  outlet_source_id(name))
            set_channels(info, [label], "N", "Force")
            outlets.append(lsl.StreamOutlet(info, chunk_size=1))
        events = lsl.StreamInfo(self.names[2], "Markers", 1, lsl.IRREGULAR_RATE, lsl.cf_string,
                                outlet_source_id(self.names[2]))
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
