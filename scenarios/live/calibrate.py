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
and the file says so (``metadata["force_source"] == "cues"``). Cue labels follow the
cues' clock, sample ``n`` at ``n / fs`` (lost samples counted), as the cues are given.

The armband's IMU stream, when there is one, is recorded beside the sEMG: the
forearm's pitch interpolated at each sEMG sample's time stamp (``pitch_rad``). After
the squeezes the person is then asked for two arm poses (:func:`arm_cues`): the
forearm at rest as when the hand is at the object, and raised as to lift it; the
median pitch of the last 2 s of each becomes ``metadata["arm_poses"]``
(:class:`~scenarios.live.arm.ArmPoses`), which ``griploop live`` maps the pitch to the
wrist's height with. The poses are asked for after the calibration's duration, and
their sEMG is not kept: the estimator's fit sees the same session with or without an
IMU.

With ``open_levels`` (``griploop calibrate --open``), open contractions follow the
squeezes (:data:`OPEN_LEVELS`: open small, medium, strong, each held and followed by a
rest), cued in the terminal as the squeezes are, and the recording gains ``open_intent``:
the level each open cue asks for (a fraction of the person's largest opening), a
prompted label as the cue force is. The force label is the squeezes' only (0 while the
hand opens, or the force stream's reading). ``metadata["open_from_s"]`` says where the
open contractions begin: the estimator is fitted on the squeezes before it
(:func:`scenarios.live.calibration_fit.fit_calibration`), an open/close decoder on the whole
recording. Without open levels the session, its cues and its file are the paper's.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.live.arm import ARM_POSE_READ_S, ARM_POSE_S, LIFT_HEIGHT_M, ArmPoses
from scenarios.live.errors import ArmPosesError, SessionError
from scenarios.live.samples import SampleGuard
from sim.recording import EMG_UNITS, Recording

LEVELS = (("small", 0.25), ("medium", 0.5), ("strong", 0.9))
"""Squeezes of the session and the share of the strongest grip each asks for."""
OPEN_LEVELS = (("small", 0.3), ("medium", 0.6), ("strong", 1.0))
"""Open contractions of ``griploop calibrate --open`` and the share of the person's largest
opening (finger extension) each asks for."""
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
        ``"rest"``, ``"squeeze small"`` ..., ``"open small"`` ...
    level : float
        Share of the strongest grip (a squeeze) or of the largest opening (an open
        cue) asked for (0 at rest).
    duration_s : float
        How long it lasts, s.
    """

    t_s: float
    label: str
    level: float
    duration_s: float

    @property
    def action(self) -> str:
        """What the cue asks for: ``"rest"``, ``"squeeze"``, ``"open"`` or ``"arm"``."""
        return self.label.split()[0]


def cue_schedule(*, first_rest_s: float = 3.0, squeeze_s: float = 4.0, rest_s: float = 4.0,
                 final_rest_s: float = 5.0, levels: Sequence[tuple[str, float]] = LEVELS,
                 open_levels: Sequence[tuple[str, float]] = ()) -> tuple[list[Cue], float]:
    """The cues of a calibration session and its duration (default 28 s).

    Rest, then each squeeze for ``squeeze_s`` followed by a rest (``final_rest_s``
    after the last), so that the paper's 50 % identification split falls inside
    the medium squeeze. Then each open contraction of ``open_levels`` (``(name,
    level)``, e.g. :data:`OPEN_LEVELS`) for ``squeeze_s``, each followed by ``rest_s``
    (default: none; with :data:`OPEN_LEVELS`, 24 s more).

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
    for name, level in open_levels:
        cues.append(Cue(t, f"open {name}", float(level), squeeze_s))
        t += squeeze_s
        cues.append(Cue(t, "rest", 0.0, rest_s))
        t += rest_s
    return cues, t


def open_from_s(cues: Sequence[Cue]) -> float | None:
    """When the first open cue is given, s (``None``: a schedule of squeezes only)."""
    return next((c.t_s for c in cues if c.action == "open"), None)


def arm_cues(start_s: float, *, pose_s: float = ARM_POSE_S) -> list[Cue]:
    """The two arm poses asked for from ``start_s``: at rest, then raised (``pose_s`` each)."""
    return [Cue(float(start_s), "arm rest", 0.0, pose_s),
            Cue(float(start_s) + pose_s, "arm raised", 0.0, pose_s)]


def cue_levels(cues: Sequence[Cue], t_s: np.ndarray, action: str = "squeeze") -> np.ndarray:
    """The level the ``action`` cues (``"squeeze"`` or ``"open"``) ask for at each time
    (a step function of the cues; 0 under any other cue)."""
    starts = np.array([c.t_s for c in cues])
    idx = np.clip(np.searchsorted(starts, t_s, side="right") - 1, 0, len(cues) - 1)
    return np.array([c.level if c.action == action else 0.0 for c in cues])[idx]


def say_cue(cue: Cue) -> str:
    """The terminal line of a cue."""
    if cue.label == "arm rest":
        return (f"[{cue.t_s:5.1f} s] ARM AT REST: relax your hand, forearm as when the hand is "
                f"at the object, for {cue.duration_s:g} s")
    if cue.label == "arm raised":
        return (f"[{cue.t_s:5.1f} s] ARM RAISED: keep your hand relaxed and raise your forearm "
                f"as to lift an object {100 * LIFT_HEIGHT_M:g} cm, for {cue.duration_s:g} s")
    if cue.action == "open":
        return (f"[{cue.t_s:5.1f} s] OPEN {cue.label.split()[-1].upper()}: open your hand "
                f"(stretch your fingers out), about {100 * cue.level:.0f} % of your widest "
                f"opening, hold it for {cue.duration_s:g} s")
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


@dataclass(frozen=True)
class CalibrationStreams:
    """The open inlets a calibration session reads, and their names.

    Attributes
    ----------
    emg_inlet : pylsl.StreamInlet
        The sEMG, open, time stamps on this machine's clock.
    force_inlet : pylsl.StreamInlet or None
        A force stream in N (same clock), or ``None`` for cue labels.
    stream_name : str
        The sEMG stream's name (in errors and the metadata).
    force_name : str, optional
        The force stream's name.
    imu_inlet : pylsl.StreamInlet, optional
        The armband's orientation (same clock): recorded, and the arm poses asked for.
    imu_channels : scenarios.live.arm.OrientationChannels, optional
        Where its pitch is (required with ``imu_inlet``).
    imu_name : str, optional
        The orientation stream's name.
    stream_identity : dict, optional
        The sEMG stream's :func:`scenarios.live.lsl.identity`, kept in the metadata.
    """

    emg_inlet: Any
    force_inlet: Any | None
    stream_name: str = ""
    force_name: str | None = None
    imu_inlet: Any | None = None
    imu_channels: Any = None
    imu_name: str | None = None
    stream_identity: dict[str, Any] | None = None


def record_calibration(streams: CalibrationStreams, *, cues: Sequence[Cue], duration_s: float,
                       say: Callable[[str], None] = print, mvc_n: float = DEFAULT_MVC_N,
                       timeout_s: float = 5.0, source: str = "lsl") -> Recording:
    """Record a calibration session from open inlets (and the arm poses, with an IMU).

    Parameters
    ----------
    streams : CalibrationStreams
        The sEMG inlet, the force and orientation inlets if any, and their names.
    cues, duration_s
        From :func:`cue_schedule`.
    say : callable
        Where cue lines go.
    mvc_n, timeout_s : float
        Label of a 100 % squeeze without a force stream, N; no sEMG for this
        long stops the session with an error, s.
    source : str
        The recording's ``source``.

    Returns
    -------
    Recording
        The sEMG received over ``duration_s``, in order (lost samples are not
        filled; their count is in ``metadata["lost_samples"]``), with the force
        label, and with an IMU the pitch (``pitch_rad``) and ``metadata["arm_poses"]``
        (``None``, with ``arm_poses_error`` saying why, when the poses were unusable).
        With open cues, ``open_intent`` (each open cue's level) and
        ``metadata["open_from_s"]``.

    Raises
    ------
    SessionError
        The stream stopped for ``timeout_s``, or the force or IMU stream sent nothing.
    """
    from scenarios.live.lsl import pylsl_module

    emg_inlet, force_inlet, imu_inlet = streams.emg_inlet, streams.force_inlet, streams.imu_inlet
    stream_name, force_name, imu_name = streams.stream_name, streams.force_name, streams.imu_name
    imu_channels, stream_identity = streams.imu_channels, streams.stream_identity
    lsl = pylsl_module()
    fs = emg_inlet.info(timeout=2.0).nominal_srate()
    if not fs > 0:
        raise SessionError(f"stream {stream_name!r} has no nominal rate; expected a regular "
                           "sEMG stream")
    integer = emg_inlet.channel_format == lsl.cf_int8
    guard = SampleGuard(integer)
    n_target = int(round(duration_s * fs))
    cues = list(cues)
    n_total = n_target
    if imu_inlet is not None:
        cues += arm_cues(duration_s)
        n_total = n_target + int(round(2 * ARM_POSE_S * fs))
    force = _Side(force_inlet, lambda x: np.array([float(v[0]) for v in x], dtype=float))
    imu = _Side(imu_inlet, None if imu_channels is None else imu_channels.pitch_rad)
    got, next_cue, last_arrival = _Samples(fs, n_target, guard), 0, time.monotonic()
    while got.n + 1 < n_total:
        samples, ts = emg_inlet.pull_chunk(timeout=0.05, max_samples=256)
        force.pull()
        imu.pull()
        now = time.monotonic()
        if not ts:
            if now - last_arrival > timeout_s:
                raise SessionError(f"stream {stream_name!r} sent nothing for {timeout_s:g} s "
                                   f"at {max(got.n, 0) / fs:.1f} s of the session; nothing "
                                   "written")
            continue
        last_arrival = now
        got.take(samples, ts)
        while next_cue < len(cues) and cues[next_cue].t_s <= (got.n + 1) / fs:
            say(say_cue(cues[next_cue]))
            next_cue += 1
    emg, t_emg = np.concatenate(got.chunks), np.concatenate(got.stamps)
    t_cues = np.concatenate(got.kept) / fs  # the cues' clock: sample n at n / fs
    if force_inlet is not None:
        force_n = _force_on(t_emg, force, force_name)
    else:
        force_n = cue_levels(cues, t_cues) * mvc_n
    opens_at = open_from_s(cues)
    metadata = {
        "source": "lsl", "stream": stream_name, "protocol": "paper_protocol (live)",
        **_cue_metadata([c for c in cues if c.action != "arm"]),
        "force_source": "cues" if force_inlet is None else f"lsl:{force_name}",
        "mvc_n_cues": mvc_n if force_inlet is None else None, "lost_samples": got.lost,
        "bad_samples": {"non_numeric": guard.non_numeric, "out_of_range": guard.out_of_range},
        "first_timestamp": got.ts0,
    }
    if stream_identity is not None:
        metadata["stream_identity"] = dict(stream_identity)
    extra = {}
    if opens_at is not None:  # the open contractions' label: the level each open cue asks
        extra["open_intent"] = cue_levels(cues, t_cues, "open")
        metadata.update({"protocol": "paper_protocol + open contractions (live)",
                         "open_from_s": opens_at, "open_intent_source": "cues"})
    pitch = None if imu_inlet is None else _arm_on(
        t_emg, got.stream_s(), imu, duration_s, imu_name, metadata, say,
        list(imu_channels.labels))
    return Recording(emg=emg.astype(np.int8) if integer else emg, fs_hz=fs,
                     force_n=np.clip(force_n, 0.0, None),
                     emg_unit=stream_unit(emg_inlet, integer), pitch_rad=pitch,
                     metadata=metadata, source=source, **extra)


class _Samples:
    """The sEMG samples of a session as they arrive: kept up to ``n_target``, counted.

    Sample ``n`` is at stream time ``n / fs`` from the first; a jump between stamps of
    more than 1.5 periods counts the samples lost in it.
    """

    def __init__(self, fs: float, n_target: int, guard: SampleGuard) -> None:
        self.fs, self.n_target, self.guard = fs, n_target, guard
        self.chunks: list[np.ndarray] = []
        self.stamps: list[np.ndarray] = []
        self.kept: list[np.ndarray] = []  # each kept sample's index (n: stream time n / fs)
        self._every: list[tuple[np.ndarray, np.ndarray]] = []  # each sample's stamp, index
        self.received = self.lost = 0
        self.n = -1
        self.ts0 = self._ts_last = 0.0

    def take(self, samples: Any, ts: Sequence[float]) -> None:
        """A chunk that arrived."""
        fs = self.fs
        x = self.guard.clean(samples)
        t = np.asarray(ts, dtype=float)
        if self.n < 0:
            self.ts0, self._ts_last = float(t[0]), float(t[0]) - 1.0 / fs
        jumps = np.diff(np.concatenate([[self._ts_last], t])) * fs
        gaps = np.where(jumps > 1.5, np.rint(jumps) - 1, 0).astype(int)
        index = self.n + np.cumsum(1 + gaps)
        keep = index < self.n_target
        self.chunks.append(x[keep])
        self.stamps.append(t[keep])
        self.kept.append(index[keep])
        self._every.append((t, index))
        self.received += int(keep.sum())
        self.lost += int(gaps[keep].sum())
        self.n, self._ts_last = int(index[-1]), float(t[-1])

    def stream_s(self) -> tuple[np.ndarray, np.ndarray]:
        """Every sample's stamp and its stream time, s."""
        return (np.concatenate([e[0] for e in self._every]),
                np.concatenate([e[1] for e in self._every]) / self.fs)


class _Side:
    """A stream read beside the sEMG (force, IMU), never waiting for it: values and stamps."""

    def __init__(self, inlet: Any, read: Callable[[Any], np.ndarray] | None) -> None:
        self.inlet, self.read = inlet, read
        self.values: list[np.ndarray] = []
        self.stamps: list[float] = []

    def pull(self, timeout_s: float = 0.0) -> None:
        """What has arrived (waiting up to ``timeout_s`` for it)."""
        if self.inlet is None:
            return
        x, ts = self.inlet.pull_chunk(timeout=timeout_s, max_samples=1024)
        if ts:
            self.values.append(self.read(x))
            self.stamps += list(ts)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Values and stamps, in stamp order."""
        values = np.concatenate(self.values) if self.values else np.zeros(0)
        stamps = np.asarray(self.stamps, dtype=float)
        order = np.argsort(stamps, kind="stable")
        return values[order], stamps[order]


def _arm_on(t_emg: np.ndarray, stream_s: tuple[np.ndarray, np.ndarray], imu: _Side,
            duration_s: float, imu_name: str | None, metadata: dict[str, Any],
            say: Callable[[str], None], labels: list[str]) -> np.ndarray:
    """The pitch at the sEMG times (rad); the arm poses (or why there are none) go to
    ``metadata``, and a pose that could not be read to ``say`` as a warning.

    ``stream_s`` holds every sEMG sample's stamp and its stream time (the cues' time
    base): an orientation sample's stream time is interpolated from them.

    Raises
    ------
    SessionError
        The IMU stream sent no orientation that is a number.
    """
    values, stamps = imu.arrays()
    good = np.isfinite(values)
    if not good.any():
        raise SessionError(f"IMU stream {imu_name!r} sent no orientation that is a number "
                           "during the session; nothing written")
    pitch = np.interp(t_emg, stamps[good], values[good])
    t_imu = np.interp(stamps, *stream_s)
    rest, raised = arm_cues(duration_s)

    def held(cue: Cue) -> np.ndarray:
        end = cue.t_s + cue.duration_s
        return values[(t_imu >= end - ARM_POSE_READ_S) & (t_imu < end)]

    metadata.update({"imu_stream": imu_name, "imu_channels": labels, "arm_poses": None})
    try:
        metadata["arm_poses"] = ArmPoses.from_pitches(held(rest), held(raised)).to_metadata()
    except ArmPosesError as exc:
        metadata["arm_poses_error"] = str(exc)
        say(f"warning: no arm poses recorded: {exc}; griploop live will need them (record "
            "again, or give them by hand)")
    return pitch


def _force_on(t_emg: np.ndarray, force: _Side, force_name: str | None) -> np.ndarray:
    """The force stream, read up to the last sEMG sample (1 s at most), at the sEMG times, N.

    Raises
    ------
    SessionError
        The force stream sent nothing during the session.
    """
    deadline = time.monotonic() + 1.0
    while (not force.stamps or max(force.stamps) < t_emg[-1]) and time.monotonic() < deadline:
        force.pull(0.05)
    if not force.stamps:
        raise SessionError(f"force stream {force_name!r} sent nothing during the session; "
                           "nothing written")
    values, stamps = force.arrays()
    return np.interp(t_emg, stamps, values)


def _cue_metadata(cues: Sequence[Cue]) -> dict[str, Any]:
    """The cues of a live session as a recording's metadata (the squeezes' ``cues`` and
    ``levels`` as the paper's session has them; every cue in ``cue_labels``; the open
    contractions' levels, if any, in ``open_levels``)."""
    opens_at = open_from_s(cues)
    squeezes = [c for c in cues if opens_at is None or c.t_s < opens_at]
    out = {"cues": [[("start" if c.level > 0 else "end"), c.t_s] for c in squeezes[1:]],
           "cue_labels": [[c.label, c.t_s, c.level] for c in cues],
           "levels": [c.level for c in squeezes if c.level > 0]}
    opens = [c.level for c in cues if c.action == "open"]
    if opens:
        out["open_levels"] = opens
    return out
