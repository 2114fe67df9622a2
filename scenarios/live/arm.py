"""The person's own arm in a live session: the forearm's pitch from the armband's IMU, or a key.

A transradial prosthesis user lifts with their own elbow and shoulder, so in
``griploop live`` the simulated wrist follows the person, as the user-paced trial's
wrist follows its virtual user (:class:`~sim.hand.grasp_env.GraspEnv` made with
``wrist="commanded"``, moved by :meth:`~sim.hand.grasp_env.GraspEnv.move_wrist`).
Never the clock: a session has no scheduled lift.

**Orientation channels** (:class:`OrientationChannels`). An armband's IMU stream
(the MYO streams its orientation at 50 Hz) must carry the orientation in channels
labelled either ``pitch`` (``pitch_rad``, ``pitch_deg``, ``forearm_pitch``; in
radians, or degrees when the label ends in ``deg`` or the channel's unit is
``deg``/``degrees``) or as a quaternion ``qw, qx, qy, qz`` (also ``w, x, y, z``,
``quat_w`` ..., ``quaternion_w`` ..., ``orientation_w`` ...; any scale, as raw
integer quaternions are). The forearm's pitch of a quaternion is its rotation about
the armband's y axis, the forearm lying along x (Tait-Bryan z-y'-x'' angles):
``asin(2 (w y - z x) / |q|^2)``.

**Arm poses** (:class:`ArmPoses`). The pitch is mapped to the wrist's height by two
poses the person held during ``griploop calibrate``: at rest (the hand at the
object: height 0) and raised as for a lift (the lift height, 8 cm). The share
``u = (pitch - rest) / (raised - rest)`` of the way up, less a dead band of
:data:`DEAD_BAND` of it at the rest pose (so that the IMU's noise does not move
the wrist), sets the height: ``lift_height * (u - DEAD_BAND) / (1 - DEAD_BAND)``,
clipped to the table and to :data:`~sim.hand.wrist.MAX_WRIST_HEIGHT_M`.

**Following** (:class:`PitchArm`). The pitch is smoothed by a first-order low-pass of
time constant :data:`SMOOTH_S`, restarted at the first sample after a stall. Each
orientation sample gives a height at its time stamp. While the wrist follows, the
control step at or after that time moves the wrist towards it with a ``follow`` move
(:class:`sim.hand.wrist.CommandedWrist`: a critically damped approach of time constant
:data:`FOLLOW_S` from where the wrist is, at the speed it has, sampled at every physics
substep), so that the wrist's position and speed stay continuous from one sample to the
next. On a virtual subject's lift with 0.2 deg of IMU noise, straight segments between
the 50 Hz samples jolted the can at each sample and counted 7-10 slip onsets where the
scripted lift counts 1; the follow moves count 1, with the wrist trembling by 0.2 mm
in the hold. When following starts (the session's start, or the end of a stall) and
the wrist is more than :data:`FOLLOW_TOLERANCE_M` from the arm, it first moves there
along a minimum-jerk path in :data:`REACQUIRE_S`, then follows. No orientation sample
for :data:`IMU_GAP_S` is a stall: the wrist holds still where it is (its last move
ends within a few time constants) and ``imu_gap_start`` is logged; ``imu_gap_end``
when samples come back. The grip is not touched: the person's sEMG keeps driving the
hand.

**The key** (:class:`KeyArm`, :class:`LineKeys`). Without an IMU, each press of
Enter (a line read from the terminal, or from any text stream, without blocking the
session) lifts the wrist to the lift height along the scripted lift's minimum-jerk
path, and the next puts it down.
"""

from __future__ import annotations

import math
import re
import threading
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TextIO

import numpy as np

from scenarios.live.errors import ArmPosesError, ImuChannelError
from scenarios.live.samples import parse_numbers
from sim.hand.wrist import LIFT_HEIGHT_M, MAX_WRIST_HEIGHT_M
from sim.user.operator import OperatorParams, WristMove

LIFT_S = OperatorParams().lift_s
"""Duration of a key's lift and set-down, s (a user's lift)."""
TREMOR_M = 0.01
"""A measured arm held still trembles and drifts by up to this much, m: the in-air hold
ends when the wrist comes down by more (:func:`scenarios.runners.trial_outcome.hold_window`)."""
DEAD_BAND = 0.05
"""Share of the way from the rest pose to the raised one that leaves the wrist on the table."""
MIN_POSE_RANGE_RAD = math.radians(5.0)
"""The raised pose must differ from the rest pose by at least this much, rad."""
IMU_GAP_S = 0.2
"""No orientation sample for this long: the wrist holds still (a stall), s."""
SMOOTH_S = 0.03
"""Time constant of the low-pass on the forearm's pitch (IMU noise, tremor), s."""
FOLLOW_S = 0.05
"""Time constant of the wrist's critically damped approach to the arm's height, s."""
REACQUIRE_S = 0.4
"""A wrist away from the arm joins it along a minimum-jerk path this long, s."""
FOLLOW_TOLERANCE_M = 0.005
"""A wrist this close to the arm's height follows it directly, m."""
FOREARM_M = 0.27
"""Elbow-to-wrist length of a virtual subject's forearm, m (an adult's: 0.25-0.29 m)."""
ARM_POSE_S = 3.0
"""How long ``griploop calibrate`` asks for each arm pose, s; the pose is the median
pitch of its last :data:`ARM_POSE_READ_S`."""
ARM_POSE_READ_S = 2.0
"""The last part of each arm pose whose median pitch is the pose, s."""

_PITCH_LABELS = {"pitch", "pitchrad", "pitchdeg", "forearmpitch"}
_DEGREES = {"deg", "degree", "degrees", "°"}
_QUAT_PREFIXES = ("", "q", "quat", "quaternion", "orientation")


def _norm(label: str) -> str:
    return re.sub(r"[^a-z0-9°]", "", str(label).lower())


def pitch_of_quaternion(q: np.ndarray) -> np.ndarray:
    """The forearm's pitch of orientation quaternions ``(w, x, y, z)``, rad.

    Parameters
    ----------
    q : ndarray, shape (n, 4)
        Quaternions in any scale (normalized here); a zero quaternion gives NaN.

    Returns
    -------
    ndarray, shape (n,)
        ``asin(2 (w y - z x) / |q|^2)``: the rotation about y of the z-y'-x'' angles.
    """
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    norm2 = w * w + x * x + y * y + z * z
    with np.errstate(invalid="ignore", divide="ignore"):
        s = 2.0 * (w * y - z * x) / norm2
    return np.arcsin(np.clip(s, -1.0, 1.0))


@dataclass(frozen=True)
class OrientationChannels:
    """Where the forearm's pitch is in an IMU stream's samples (module notes).

    Attributes
    ----------
    kind : {"pitch", "quaternion"}
    index : tuple of int
        The pitch channel, or the ``w, x, y, z`` channels.
    rad_per_unit : float
        Scale of a pitch channel (1, or pi/180 for degrees).
    labels : tuple of str
        The channels used, as labelled.
    """

    kind: str
    index: tuple[int, ...]
    rad_per_unit: float = 1.0
    labels: tuple[str, ...] = ()

    @classmethod
    def find(cls, labels: Sequence[str], units: Sequence[str] = (), *,
             stream: str = "IMU stream") -> OrientationChannels:
        """The orientation channels of a stream with these channel labels and units.

        Raises
        ------
        ImuChannelError
            No pitch channel and no complete quaternion; the message names the
            channels the stream has.
        """
        labels = [str(label) for label in labels]
        names = [_norm(label) for label in labels]
        units = [_norm(u) for u in units] + [""] * max(0, len(labels) - len(units))
        for i, name in enumerate(names):
            if name in _PITCH_LABELS:
                degrees = name.endswith("deg") or units[i] in _DEGREES
                return cls("pitch", (i,), math.pi / 180.0 if degrees else 1.0, (labels[i],))
        for prefix in _QUAT_PREFIXES:
            wanted = [prefix + c for c in "wxyz"]
            if all(names.count(w) == 1 for w in wanted):
                index = tuple(names.index(w) for w in wanted)
                return cls("quaternion", index, 1.0, tuple(labels[i] for i in index))
        have = ", ".join(repr(label) if label else "(unlabelled)" for label in labels)
        raise ImuChannelError(
            f"{stream} has no orientation channel: expected a channel labelled pitch (rad, or "
            f"deg by its unit) or four labelled qw, qx, qy, qz; found {len(labels)} channels: "
            f"{have or 'none'}")

    @classmethod
    def of_inlet(cls, inlet: Any, *, stream: str, timeout_s: float = 2.0) -> OrientationChannels:
        """The orientation channels of an open inlet's stream (its full description).

        Raises
        ------
        ImuChannelError
            As :meth:`find`.
        """
        full = inlet.info(timeout=timeout_s)
        labels = full.get_channel_labels() or [""] * full.channel_count()
        units = [u or "" for u in (full.get_channel_units() or [])]
        return cls.find([label or "" for label in labels], units, stream=stream)

    def pitch_rad(self, samples: Any) -> np.ndarray:
        """The pitch of each sample, rad (NaN where the channels are not numbers)."""
        x = np.asarray(samples)
        x = x.reshape(x.shape[0], -1)
        x = x.astype(float) if x.dtype.kind in "iuf" else parse_numbers(x)
        if self.kind == "pitch":
            return x[:, self.index[0]] * self.rad_per_unit
        return pitch_of_quaternion(x[:, list(self.index)])


@dataclass(frozen=True)
class ArmPoses:
    """The forearm's pitch at rest and raised, and the wrist height each stands for.

    Attributes
    ----------
    rest_pitch_rad, raised_pitch_rad : float
        Pitch with the hand at the object, and raised as for a lift, rad.
    lift_height_m : float
        Wrist height of the raised pose, m.
    source : str
        Where the poses come from (``calibrate``, ``virtual subject``, ``given``).
    """

    rest_pitch_rad: float
    raised_pitch_rad: float
    lift_height_m: float = LIFT_HEIGHT_M
    source: str = "given"

    def __post_init__(self) -> None:
        rest, raised = self.rest_pitch_rad, self.raised_pitch_rad
        if not (math.isfinite(rest) and math.isfinite(raised)):
            raise ArmPosesError(f"arm poses: expected finite pitches, found rest {rest!r} and "
                                f"raised {raised!r}")
        if abs(raised - rest) < MIN_POSE_RANGE_RAD:
            raise ArmPosesError(
                f"arm poses: the raised pose differs from the rest pose by "
                f"{math.degrees(abs(raised - rest)):.1f} deg; expected at least "
                f"{math.degrees(MIN_POSE_RANGE_RAD):g} deg (the forearm raised as for a lift)")
        if not 0 < self.lift_height_m <= MAX_WRIST_HEIGHT_M:
            raise ArmPosesError(f"arm poses: expected a lift height in (0, "
                                f"{MAX_WRIST_HEIGHT_M:g}] m, found {self.lift_height_m!r}")

    def height_m(self, pitch_rad: float) -> float:
        """The wrist height for a pitch, m (module notes)."""
        u = (pitch_rad - self.rest_pitch_rad) / (self.raised_pitch_rad - self.rest_pitch_rad)
        h = self.lift_height_m * (u - DEAD_BAND) / (1.0 - DEAD_BAND)
        return 0.0 if not h > 0.0 else MAX_WRIST_HEIGHT_M if h > MAX_WRIST_HEIGHT_M else h

    def to_metadata(self) -> dict[str, Any]:
        """JSON-ready, as a calibration recording's ``metadata["arm_poses"]``."""
        return {"rest_pitch_rad": self.rest_pitch_rad, "raised_pitch_rad": self.raised_pitch_rad,
                "lift_height_m": self.lift_height_m, "source": self.source}

    @classmethod
    def from_metadata(cls, metadata: Mapping[str, Any], where: str) -> ArmPoses | None:
        """The poses in a recording's metadata, ``None`` when it has none.

        Raises
        ------
        ArmPosesError
            ``arm_poses`` is there but not two usable pitches.
        """
        poses = metadata.get("arm_poses")
        if poses is None:
            return None
        try:
            return cls(float(poses["rest_pitch_rad"]), float(poses["raised_pitch_rad"]),
                       float(poses.get("lift_height_m", LIFT_HEIGHT_M)),
                       str(poses.get("source", "calibrate")))
        except (TypeError, KeyError, ValueError) as exc:
            if isinstance(exc, ArmPosesError):
                raise ArmPosesError(f"{where}: {exc}") from None
            raise ArmPosesError(f"{where}: arm_poses: expected rest_pitch_rad and "
                                f"raised_pitch_rad in rad, found {poses!r}"[:300]) from None

    @classmethod
    def from_pitches(cls, rest: np.ndarray, raised: np.ndarray, *,
                     source: str = "calibrate") -> ArmPoses:
        """The medians of pitches read while each pose was held, rad.

        Raises
        ------
        ArmPosesError
            A pose without a reading, or poses too close together.
        """
        rest, raised = np.asarray(rest, dtype=float), np.asarray(raised, dtype=float)
        rest, raised = rest[np.isfinite(rest)], raised[np.isfinite(raised)]
        if rest.size == 0 or raised.size == 0:
            which = "rest" if rest.size == 0 else "raised"
            raise ArmPosesError(f"arm poses: no orientation sample while the {which} pose was "
                                "held; expected the IMU stream to send")
        return cls(float(np.median(rest)), float(np.median(raised)), source=source)

    @classmethod
    def from_text(cls, text: str) -> ArmPoses:
        """Poses given as ``REST_DEG:RAISED_DEG`` (degrees), such as ``0:17``.

        Raises
        ------
        ArmPosesError
            Not two numbers, or poses too close together.
        """
        try:
            rest, raised = (float(v) for v in str(text).split(":"))
        except ValueError:
            raise ArmPosesError(f"expected REST_DEG:RAISED_DEG such as 0:17, found "
                                f"{text!r}") from None
        return cls(math.radians(rest), math.radians(raised), source="given")


def forearm_pitch_rad(height_m: np.ndarray, *, forearm_m: float = FOREARM_M,
                      rest_pitch_rad: float = 0.0) -> np.ndarray:
    """A virtual subject's forearm pitch when the wrist is ``height_m`` above the object, rad.

    The forearm pivots at the elbow: ``rest + asin(height / forearm)``.
    """
    return rest_pitch_rad + np.arcsin(np.clip(np.asarray(height_m, dtype=float) / forearm_m,
                                              -1.0, 1.0))


def virtual_arm_poses(*, forearm_m: float = FOREARM_M, rest_pitch_rad: float = 0.0) -> ArmPoses:
    """The poses ``griploop calibrate`` would read from a virtual subject's arm."""
    return ArmPoses(rest_pitch_rad, float(forearm_pitch_rad(LIFT_HEIGHT_M, forearm_m=forearm_m,
                                                            rest_pitch_rad=rest_pitch_rad)),
                    source="virtual subject")


# ----------------------------------------------------------------------------- arms
class Arm(Protocol):
    """What moves the wrist of a person's trial (a live session, or the replay of one).

    ``reset()`` before a session; ``command(t_s, setpoint_m)`` before each control
    step (the wrist's set-point then, m) returns the move to start, or ``None``;
    ``tick(now, t_s)`` lets the wall clock act (stalls); ``bind(emit, notify)`` gives
    it the session's event and terminal line callbacks; ``summary()`` is its part of
    the report. ``tremor_m`` is how much the wrist moves when the person holds still.
    """

    source: str
    tremor_m: float

    def reset(self) -> None: ...

    def bind(self, emit: Callable[[str], None], notify: Callable[[str], None]) -> None: ...

    def command(self, t_s: float, setpoint_m: float) -> WristMove | None: ...

    def tick(self, now: float, t_s: float) -> None: ...

    def summary(self) -> dict[str, Any]: ...


def _quiet(_: str) -> None:
    return None


class BoundArm:
    """What every :class:`Arm` shares: the session's callbacks (silent until :meth:`bind`),
    and a :meth:`reset` when made (a subclass sets its own attributes first)."""

    def __init__(self) -> None:
        self._emit: Callable[[str], None] = _quiet
        self._notify: Callable[[str], None] = _quiet
        self.reset()

    def bind(self, emit: Callable[[str], None], notify: Callable[[str], None]) -> None:
        """Where events (markers) and terminal lines go."""
        self._emit, self._notify = emit, notify

    def reset(self) -> None:
        """Before a session (each arm says what it forgets)."""
        raise NotImplementedError


class PitchArm(BoundArm):
    """The wrist follows the forearm's pitch from the IMU stream (module notes).

    Parameters
    ----------
    poses : ArmPoses
    channels : OrientationChannels
    imu_fs_hz : float
        The IMU stream's nominal rate, Hz (0: irregular), for the report.
    gap_s, reacquire_s, smooth_s, follow_s : float
        See the module notes, s.

    Attributes
    ----------
    received : int
        Orientation samples taken; ``bad`` of them were not numbers (ignored).
    in_gap : bool
        The IMU stream is stalled.
    gaps : list of dict
        ``t_s`` (session time of the first missing sample: the last one's plus one
        period) and ``duration_s`` (the silence beyond one period: from the last
        sample's arrival to the next's, less a period).
    latest_pitch_rad : float
        The last pitch received (NaN before the first).
    """

    source = "imu"
    tremor_m = TREMOR_M

    def __init__(self, poses: ArmPoses, channels: OrientationChannels, *, imu_fs_hz: float,
                 gap_s: float = IMU_GAP_S, reacquire_s: float = REACQUIRE_S,
                 smooth_s: float = SMOOTH_S, follow_s: float = FOLLOW_S) -> None:
        self.poses, self.channels = poses, channels
        self.smooth_s, self.follow_s = float(smooth_s), float(follow_s)
        self.imu_fs_hz = float(imu_fs_hz)
        self.gap_s, self.reacquire_s = float(gap_s), float(reacquire_s)
        super().__init__()

    def reset(self) -> None:
        """Before a session: nothing received, not following."""
        self._pending: deque[tuple[float, float]] = deque()
        self.latest_pitch_rad = math.nan
        self._smooth = math.nan  # the low-passed pitch, rad
        self._smooth_ts = math.nan
        self._latest_m: float | None = None
        self.following = False
        self._joined_s = -math.inf  # a move joining the arm ends then, s
        self.in_gap = False
        self.gaps: list[dict[str, float]] = []
        self.received = self.bad = 0
        self.last_arrival = math.nan
        self._last_t_s = math.nan  # session time of the last sample, s
        self._t_now = 0.0

    def feed(self, samples: Any, stamps: np.ndarray, arrival: float, ts0: float | None) -> None:
        """Take orientation samples that arrived at ``arrival`` (wall clock, s).

        ``stamps`` are on the sEMG stream's clock; ``ts0`` is the first sEMG
        sample's stamp (session time 0), ``None`` before it: those samples only set
        where the arm is when the session starts.
        """
        pitch = self.channels.pitch_rad(samples)
        good = np.isfinite(pitch)
        self.bad += int(pitch.size - good.sum())
        if not good.any():
            return
        if self.in_gap:
            self.in_gap = False
            self.following = False  # rejoin the arm where it is now
            self._smooth = math.nan  # and smooth from there
            period = 1.0 / self.imu_fs_hz if self.imu_fs_hz > 0 else 0.0
            self.gaps[-1]["duration_s"] = float(arrival - self.last_arrival - period)
            self._emit("imu_gap_end")
            self._notify(f"the arm's IMU stream is back at {self._t_now:.2f} s: the wrist "
                         "follows the forearm again")
        self.last_arrival = arrival
        for p, ts in zip(pitch[good].tolist(),
                         np.asarray(stamps, dtype=float)[good].tolist(), strict=True):
            self.received += 1
            self.latest_pitch_rad = p
            if not self._smooth == self._smooth:
                self._smooth = p
            elif ts > self._smooth_ts:
                self._smooth += (1.0 - math.exp((self._smooth_ts - ts) / self.smooth_s)) * (
                    p - self._smooth)
            self._smooth_ts = ts
            h = self.poses.height_m(self._smooth)
            if ts0 is None:
                self._latest_m = h
            else:
                self._last_t_s = ts - ts0
                self._pending.append((ts - ts0, h))

    def tick(self, now: float, t_s: float) -> None:
        """A stall when no orientation sample arrived for ``gap_s`` (wall clock ``now``)."""
        self._t_now = t_s
        if self.in_gap or not self.last_arrival == self.last_arrival:
            return
        if now - self.last_arrival >= self.gap_s:
            self.in_gap = True
            self.following = False
            period = 1.0 / self.imu_fs_hz if self.imu_fs_hz > 0 else 0.0
            start = self._last_t_s + period if self._last_t_s == self._last_t_s else t_s
            self.gaps.append({"t_s": float(start), "duration_s": math.nan})
            self._emit("imu_gap_start")
            self._notify(f"the arm's IMU stream stalled at {start:.2f} s: the wrist holds still "
                         "until it sends again")

    def close(self, now: float) -> None:
        """At the session's end: a stall still open lasted until ``now``."""
        if self.in_gap and self.gaps and math.isnan(self.gaps[-1]["duration_s"]):
            self.gaps[-1]["duration_s"] = float(now - self.last_arrival)

    def command(self, t_s: float, setpoint_m: float) -> WristMove | None:
        """The move to start at control step ``t_s`` (module notes)."""
        pending = self._pending
        fresh = False
        while pending and pending[0][0] <= t_s + 1e-9:
            self._latest_m = pending.popleft()[1]
            fresh = True
        latest = self._latest_m
        if latest is None or self.in_gap:
            return None
        if self.following:
            return WristMove(latest, self.follow_s, "follow") if fresh else None
        if t_s < self._joined_s:  # joining the arm: let that move end
            return None
        if abs(latest - setpoint_m) <= FOLLOW_TOLERANCE_M:
            self.following = True
            return WristMove(latest, self.follow_s, "follow")
        self._joined_s = t_s + self.reacquire_s - 1e-9
        return WristMove(latest, self.reacquire_s, "min_jerk")

    def summary(self) -> dict[str, Any]:
        """The arm's part of the report."""
        return {"source": self.source, "poses": self.poses.to_metadata(),
                "channels": {"kind": self.channels.kind, "labels": list(self.channels.labels)},
                "imu_fs_hz": self.imu_fs_hz, "imu_samples": int(self.received),
                "imu_bad_samples": int(self.bad),
                "imu_gaps": [{"t_s": round(g["t_s"], 4), "duration_s": round(g["duration_s"], 4)}
                             for g in self.gaps]}


class LineKeys:
    """Key presses as lines read from a text stream in a thread (the session never waits).

    Each line (Enter on a terminal) is one press. Reading stops at the end of the
    stream or on an error; :attr:`closed` then says why.

    Parameters
    ----------
    stream : text stream
        ``sys.stdin``, or a pipe in tests.
    """

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._count = 0
        self._seen = 0
        self.closed: str | None = None
        self._thread = threading.Thread(target=self._read, name="griploop-keys", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            while True:
                line = self._stream.readline()
                if not line:
                    self.closed = "end of input"
                    return
                self._count += 1
        except (OSError, ValueError) as exc:  # closed, or not readable (pytest's capture)
            self.closed = " ".join(str(exc).split())[:80] or type(exc).__name__

    def presses(self) -> int:
        """Presses since the last call."""
        count = self._count
        new, self._seen = count - self._seen, count
        return new


class KeyArm(BoundArm):
    """Each key press lifts the wrist, or puts it down (module notes).

    Parameters
    ----------
    presses : callable
        Presses since the last call (:meth:`LineKeys.presses`).
    lift_height_m, move_s : float
        Where a lift goes (m) and how long each move takes (s).
    closed : callable, optional
        Why the key's input ended (``None`` while it is open): said once.
    """

    source = "key"
    tremor_m = 0.0

    def __init__(self, presses: Callable[[], int], *, lift_height_m: float = LIFT_HEIGHT_M,
                 move_s: float = LIFT_S,
                 closed: Callable[[], str | None] | None = None) -> None:
        self._presses, self._closed = presses, closed
        self.lift_height_m, self.move_s = float(lift_height_m), float(move_s)
        super().__init__()

    def reset(self) -> None:
        """Before a session: the wrist down, no press counted."""
        self.up = False
        self.n_presses = 0
        self._said_closed = False

    def command(self, t_s: float, setpoint_m: float) -> WristMove | None:
        """A move when the key was pressed (an odd number of times) since the last step."""
        n = self._presses()
        if n <= 0:
            return None
        self.n_presses += n
        if n % 2 == 0:
            return None
        self.up = not self.up
        self._emit("key_lift" if self.up else "key_lower")
        return WristMove(self.lift_height_m if self.up else 0.0, self.move_s)

    def tick(self, now: float, t_s: float) -> None:
        """Say once when the key's input has ended."""
        if self._closed is not None and not self._said_closed:
            why = self._closed()
            if why is not None:
                self._said_closed = True
                self._notify(f"the lift key's input ended ({why}) at {t_s:.2f} s: the wrist "
                             "stays where it is")

    def summary(self) -> dict[str, Any]:
        """The arm's part of the report."""
        return {"source": self.source, "presses": int(self.n_presses),
                "lift_height_m": self.lift_height_m, "move_s": self.move_s}
