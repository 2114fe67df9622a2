"""``griploop stream``: a recording played as the armband's LSL outlets.

:func:`play` publishes the sEMG (``NAME``), its force (``NAME.force``) and its forearm
pitch (``NAME.imu``, the orientation quaternion at 50 Hz) at the recording's own rate,
stamped on the LSL clock, each outlet with its own
:func:`~scenarios.live.lsl.outlet_source_id`; dropouts of the whole link or of the IMU
alone, and a player that goes away, are the faults a session must survive.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.live.lsl import (
    EMG_TYPE,
    FORCE_SUFFIX,
    FORCE_TYPE,
    IMU_FS_HZ,
    IMU_SUFFIX,
    IMU_TYPE,
    QUATERNION_LABELS,
    describe,
    outlet_source_id,
    pylsl_module,
    set_channels,
)
from sim.recording import Recording


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


@dataclass(frozen=True)
class Playback:
    """How :func:`play` plays a recording: its pace, what it publishes, its faults.

    Attributes
    ----------
    loop : bool
        Start again at the end, for ever (stamps keep increasing).
    speed : float
        Play this many times faster than real time (tests, demos).
    imu : bool
        Publish the pitch as the orientation stream, when the recording has one.
    wait_for_consumer : bool
        Start playing only once an inlet has connected, so it gets the first sample.
    lead_s : float
        Delay between the start and the first sample, s.
    dropouts : sequence of Dropout
        Stretches when nothing is sent (the armband's link), stream time, s.
    imu_dropouts : sequence of Dropout
        Stretches when the orientation alone is not sent (its stream stalls), s.
    stop_after_s : float, optional
        Stop after this much stream time, s, and withdraw the outlets (a streamer
        that goes away).
    """

    loop: bool = False
    speed: float = 1.0
    imu: bool = True
    wait_for_consumer: bool = True
    lead_s: float = 0.05
    dropouts: Sequence[Dropout] = ()
    imu_dropouts: Sequence[Dropout] = ()
    stop_after_s: float | None = None


def quaternion_of_pitch(pitch_rad: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` of rotations by ``pitch_rad`` about the y axis.

    The armband's orientation when the forearm (its x axis) is pitched by that
    angle; shape ``(n, 4)`` for ``n`` angles.
    """
    half = 0.5 * np.asarray(pitch_rad, dtype=float)
    zero = np.zeros_like(half)
    return np.stack([np.cos(half), zero, np.sin(half), zero], axis=1)


@dataclass
class _Outlet:
    """An outlet and its info."""

    outlet: Any
    info: Any


def _outlets(recording: Recording, name: str, imu: bool
             ) -> tuple[_Outlet, _Outlet | None, _Outlet | None, int]:
    """The sEMG, force and orientation outlets of a recording, and the sEMG samples per
    orientation sample."""
    lsl = pylsl_module()
    fs = recording.fs_hz
    fmt = lsl.cf_int8 if recording.emg.dtype == np.int8 else lsl.cf_float32

    def make(stream: str, kind: str, n: int, rate: float, cf: int, labels: Sequence[str],
             unit: str, channel_type: str) -> _Outlet:
        info = lsl.StreamInfo(stream, kind, n, rate, cf, outlet_source_id(stream))
        set_channels(info, labels, unit, channel_type)
        return _Outlet(lsl.StreamOutlet(info, chunk_size=1), info)

    emg = make(name, EMG_TYPE, recording.n_channels, fs, fmt, recording.channel_names,
               recording.emg_unit, EMG_TYPE)
    force = (None if recording.force_n is None else
             make(name + FORCE_SUFFIX, FORCE_TYPE, 1, fs, lsl.cf_float32, ["force"], "N",
                  FORCE_TYPE))
    every = max(1, int(round(fs / IMU_FS_HZ)))
    orientation = (None if not imu or recording.pitch_rad is None else
                   make(name + IMU_SUFFIX, IMU_TYPE, 4, fs / every, lsl.cf_float32,
                        QUATERNION_LABELS, "normalized", "Orientation"))
    return emg, force, orientation, every


def _skipped(dropouts: Sequence[Dropout], fs: float) -> list[tuple[int, int]]:
    return [(int(np.floor(d.at_s * fs)), int(np.ceil((d.at_s + d.duration_s) * fs)))
            for d in dropouts]


def play(recording: Recording, name: str, playback: Playback = Playback(), *,
         log: Callable[[str], None] = print, stop: Callable[[], bool] | None = None) -> int:
    """Play a recording as LSL outlets at its own rate: sEMG, force and orientation.

    The EMG outlet is named ``name`` (type ``EMG``; ``int8`` for MYO counts, else
    ``float32``; channel labels and unit in its description); the force, if the
    recording has one, goes to ``name.force`` (type ``Force``, N); the forearm pitch,
    if it has one (and ``playback.imu``), goes to ``name.imu`` as the armband's orientation
    (type ``IMU``, the unit quaternion ``qw, qx, qy, qz`` of a rotation by the pitch
    about the y axis, float32, at :data:`scenarios.live.lsl.IMU_FS_HZ`: every ``round(fs / 50)``-th
    sample). Sample ``i`` is stamped ``t0 + i / (speed * fs_hz)`` on the LSL clock
    and pushed at that time; an orientation sample carries the stamp of the sEMG
    sample it goes with. Every outlet has its own :func:`scenarios.live.lsl.outlet_source_id`.

    Parameters
    ----------
    recording : Recording
    name : str
        Stream name.
    playback : Playback
        Pace, outlets and faults (default: once, in real time, with the orientation,
        after a consumer connects, no fault).
    log : callable
        Where progress lines go.
    stop : callable, optional
        Polled between samples; playing ends when it returns True.

    Returns
    -------
    int
        sEMG samples sent.
    """
    lsl = pylsl_module()
    loop, speed, lead_s = playback.loop, playback.speed, playback.lead_s
    fs, n = recording.fs_hz, recording.n_samples
    outlet, force_outlet, imu_outlet, every = _outlets(recording, name, playback.imu)
    log(f"streaming {recording.source} as LSL {describe(outlet.info)}, source_id "
        f"{outlet.info.source_id()!r}"
        + (f"; its force as {name + FORCE_SUFFIX!r}" if force_outlet else "")
        + (f"; its forearm pitch as {name + IMU_SUFFIX!r} (orientation quaternion, "
           f"{fs / every:g} Hz, source_id {imu_outlet.info.source_id()!r})" if imu_outlet else "")
        + f"; {recording.duration_s:.1f} s" + (" looped" if loop else "")
        + (f" at {speed:g}x" if speed != 1 else ""))
    if playback.wait_for_consumer:
        log(f"waiting for a consumer of {name!r} ...")
        while not outlet.outlet.wait_for_consumers(0.25):
            if stop is not None and stop():
                return 0
        log("a consumer connected: playing")
    rows = recording.emg.tolist()
    forces = None if recording.force_n is None else recording.force_n.tolist()
    quats = (None if imu_outlet is None
             else quaternion_of_pitch(recording.pitch_rad).astype(np.float32).tolist())
    period = 1.0 / (fs * speed)
    skip, imu_skip = _skipped(playback.dropouts, fs), _skipped(playback.imu_dropouts, fs)
    last = math.inf if playback.stop_after_s is None else playback.stop_after_s * fs
    clock, sleep = lsl.local_clock, time.sleep
    t0 = clock() + lead_s
    sent = i = 0
    one = [0.0]
    playing = True
    while playing:
        for j in range(n):
            if i >= last or (stop is not None and stop()):
                playing = False
                break
            if any(a <= i < b for a, b in skip):
                i += 1
                continue
            t = t0 + i * period
            delay = t - clock()
            if delay > 0:
                sleep(delay)
            outlet.outlet.push_sample(rows[j], t)
            if force_outlet is not None:
                one[0] = forces[j]
                force_outlet.outlet.push_sample(one, t)
            if quats is not None and j % every == 0 and not any(a <= i < b for a, b in imu_skip):
                imu_outlet.outlet.push_sample(quats[j], t)
            sent += 1
            i += 1
        playing = playing and loop
    log(f"sent {sent} samples in {clock() - t0:.2f} s")
    return sent
