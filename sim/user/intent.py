"""Intent profiles: what the subject tries to do, as normalized grip force over time.

An :class:`IntentProfile` is a smooth curve in 0..1 (fraction of MVC) with the
cues the subject followed. Profiles are built from segments (hold a level, or
move to a new level along a raised-cosine ramp), so every profile shares the
same machinery:

* :func:`paper_protocol`: the paper's session: rounds of three squeezes at
  small, medium and highest force after start cues, released after end cues,
  with rests between (timing, levels and reaction times jittered per session);
* :func:`open_protocol`: an added calibration protocol of opening contractions (finger
  extension at three efforts), for a hand that opens on a second signal; the close
  intent is 0 and the profile's ``open_intent`` carries them;
* :func:`ramp_profile`: slow trapezoidal ramps (force tracking);
* :func:`grasp_lift_hold`: rest, ramp to a hold level, hold, release (the
  intent of a closed-loop grasp-and-lift episode; durations in a
  :class:`GraspLiftTiming`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sim.errors import GriploopError


class ProfileError(GriploopError, ValueError):
    """An intent profile was asked for with impossible timing or levels."""


def as_rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    """A ``numpy.random.Generator`` from a generator, a seed or ``None`` (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


@dataclass(frozen=True)
class IntentProfile:
    """Normalized grip intent sampled at ``fs_hz`` with the cues that shaped it.

    Attributes
    ----------
    intent : ndarray, shape (n_samples,)
        Intended grip force as a fraction of MVC, 0..1.
    fs_hz : float
        Sampling rate in hertz.
    cues : tuple of (str, float)
        ``("start", t_s)`` / ``("end", t_s)`` cue times in seconds, in order
        (``open_start`` / ``open_end`` for opening contractions).
    levels : tuple of float
        Target level of each contraction (fraction of MVC).
    name : str
        Which builder made it.
    open_intent : ndarray, shape (n_samples,), optional
        Intended opening (finger extension) as a fraction of the subject's largest
        opening contraction, 0..1 (``None``: the subject never opens).
    """

    intent: np.ndarray
    fs_hz: float
    cues: tuple[tuple[str, float], ...]
    levels: tuple[float, ...]
    name: str
    open_intent: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.open_intent is not None:
            v = np.asarray(self.open_intent, dtype=float)
            if v.shape != np.shape(self.intent):
                raise ProfileError(f"open_intent: expected shape {np.shape(self.intent)} like "
                                   f"intent, found {v.shape}")
            if v.size and not (np.all(np.isfinite(v)) and 0.0 <= v.min() and v.max() <= 1.0):
                raise ProfileError(f"open_intent: expected finite values in 0..1, found "
                                   f"{v.min():.6g}..{v.max():.6g}")

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.intent.size)

    @property
    def duration_s(self) -> float:
        """Duration in seconds."""
        return self.n_samples / self.fs_hz

    @property
    def t_s(self) -> np.ndarray:
        """Sample times in seconds, shape (n_samples,)."""
        return np.arange(self.n_samples) / self.fs_hz

    def cue_times(self, kind: str) -> np.ndarray:
        """Times in seconds of the cues of one kind (``"start"`` or ``"end"``)."""
        return np.array([t for k, t in self.cues if k == kind])

    def resampled(self, fs_hz: float) -> IntentProfile:
        """The same profile at another sampling rate (linear interpolation)."""
        if fs_hz == self.fs_hz:
            return self
        n = int(round(self.duration_s * fs_hz))
        intent = np.interp(np.arange(n) / fs_hz, self.t_s, self.intent)
        opening = (None if self.open_intent is None else
                   np.interp(np.arange(n) / fs_hz, self.t_s, self.open_intent))
        return IntentProfile(intent, float(fs_hz), self.cues, self.levels, self.name, opening)

    def to_metadata(self) -> dict:
        """JSON-ready description (name, levels, cues)."""
        return {
            "name": self.name,
            "levels": [float(v) for v in self.levels],
            "cues": [[k, float(t)] for k, t in self.cues],
        }


def from_segments(
    segments: Sequence[tuple[float, float]],
    *,
    fs_hz: float,
    cues: Sequence[tuple[str, float]] = (),
    levels: Sequence[float] = (),
    name: str = "segments",
) -> IntentProfile:
    """Build a profile from ``(duration_s, end_level)`` segments starting at 0.

    Each segment moves from the previous level to ``end_level`` along a
    raised-cosine ramp lasting ``duration_s`` (a hold when the levels are
    equal), so the intent and its slope are continuous.

    Raises
    ------
    ProfileError
        For a negative duration, a level outside 0..1 or ``fs_hz <= 0``.
    """
    if fs_hz <= 0:
        raise ProfileError(f"fs_hz must be positive, found {fs_hz}")
    durations = np.array([d for d, _ in segments], dtype=float)
    ends = np.array([v for _, v in segments], dtype=float)
    if durations.size == 0 or np.any(durations < 0) or np.any((ends < 0) | (ends > 1)):
        raise ProfileError(
            "segments must be non-empty (duration_s >= 0, end_level in 0..1), found "
            f"{list(segments)}"
        )
    edges = np.concatenate([[0.0], np.cumsum(durations)])
    starts = np.concatenate([[0.0], ends[:-1]])
    n = int(round(edges[-1] * fs_hz))
    t = np.arange(n) / fs_hz
    seg = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, durations.size - 1)
    span = np.where(durations[seg] > 0, durations[seg], 1.0)
    frac = np.clip((t - edges[seg]) / span, 0.0, 1.0)
    shape = 0.5 - 0.5 * np.cos(np.pi * frac)
    intent = starts[seg] + (ends[seg] - starts[seg]) * shape
    return IntentProfile(intent, float(fs_hz), tuple((k, float(c)) for k, c in cues),
                         tuple(float(v) for v in levels), name)


#: Cued rounds of (small, medium, strong) squeezes in one calibration session. The paper
#: describes one round; its real recordings (shared/REAL_RECORDINGS.md) hold 6-9 squeezes
#: (two rounds, plus re-crossings of the 20 % line), with a duty of 0.32-0.54.
PROTOCOL_ROUNDS = 2


def _session_levels(g: np.random.Generator, rounds: int) -> list[tuple[float, float, float]]:
    """Squeeze levels of each round as a person produces them without force feedback.

    The strongest squeeze of the first round is 85-100 % MVC; later rounds reach 75-100 %
    of it. The small squeeze is 30-70 % of the round's strongest (people grade their
    effort less than instructed: the real recordings' peaks vary with a CV of 0.17-0.63),
    the medium one halfway. Each level is then scaled by a log-normal error whose SD
    (0.05-0.3) is drawn per session.
    """
    small = g.uniform(0.30, 0.70)
    spread = g.uniform(0.05, 0.30)
    strong0 = g.uniform(0.85, 1.00)
    out = []
    for r in range(rounds):
        strong = strong0 if r == 0 else strong0 * g.uniform(0.75, 1.00)
        out.append(tuple(float(np.clip(strong * f * np.exp(spread * g.standard_normal()),
                                       0.05, 1.0))
                         for f in (small, 0.5 * (1.0 + small), 1.0)))
    return out


def paper_protocol(
    rng: np.random.Generator | int | None = None,
    *,
    fs_hz: float = 200.0,
    levels: Sequence[float] | None = None,
    rounds: int = PROTOCOL_ROUNDS,
) -> IntentProfile:
    """The paper's calibration session: rounds of three squeezes (small, medium, strongest).

    Timing (uniform jitter per call): an initial rest of 3-4 s; for each squeeze a start
    cue, a reaction time of 0.2-0.4 s, a 0.6-1.0 s ramp up, a hold so that cue-to-cue
    lasts the session's hold time (3-6 s, each squeeze within 15 % of it), an end cue,
    the reaction time again, a 0.5-0.9 s ramp down and a rest (the session's rest time,
    2.5-5.5 s, within 15 %; 4-6 s after the last squeeze). With two rounds the 50 % split
    of the paper's protocol falls near the end of the first round, so identification
    sees one round and validation the other. A two-round session lasts about 45-75 s.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        Source of the jitter.
    fs_hz : float
        Sampling rate in hertz.
    levels : sequence of 3 floats, optional
        Fixed squeeze levels (every round) instead of the drawn ones
        (:func:`_session_levels`).
    rounds : int
        Rounds of three cued squeezes (default :data:`PROTOCOL_ROUNDS`).

    Returns
    -------
    IntentProfile
        With cues ``start, end`` for each squeeze, in time order, and one level per squeeze.

    Raises
    ------
    ProfileError
        ``levels`` not of length 3, or ``rounds < 1``.
    """
    g = as_rng(rng)
    if int(rounds) < 1:
        raise ProfileError(f"paper_protocol needs at least 1 round, found {rounds}")
    if levels is None:
        per_round = _session_levels(g, int(rounds))
    else:
        lv = tuple(float(v) for v in levels)
        if len(lv) != 3:
            raise ProfileError(f"paper_protocol needs 3 levels, found {len(lv)}")
        per_round = [lv] * int(rounds)
    hold_s = g.uniform(3.0, 6.0)
    rest_s = g.uniform(2.5, 5.5)
    t = g.uniform(3.0, 4.0)
    segments: list[tuple[float, float]] = [(t, 0.0)]
    cues: list[tuple[str, float]] = []
    flat = [level for lv in per_round for level in lv]
    for i, level in enumerate(flat):
        reaction = g.uniform(0.2, 0.4)
        rise = g.uniform(0.6, 1.0)
        squeeze = max(hold_s * g.uniform(0.85, 1.15), rise + 0.5)
        fall = g.uniform(0.5, 0.9)
        rest = rest_s * g.uniform(0.85, 1.15) if i < len(flat) - 1 else g.uniform(4.0, 6.0)
        cues.append(("start", t))
        segments += [(reaction, 0.0), (rise, level), (squeeze - rise, level)]
        cues.append(("end", t + reaction + squeeze))
        segments += [(reaction, level), (fall, 0.0), (rest, 0.0)]
        t += reaction + squeeze + reaction + fall + rest
    return from_segments(segments, fs_hz=fs_hz, cues=cues, levels=flat, name="paper_protocol")


#: Efforts of the open protocol's contractions, fractions of the largest opening.
OPEN_LEVELS = (0.3, 0.6, 1.0)


def open_protocol(rng: np.random.Generator | int | None = None, *, fs_hz: float = 200.0,
                  levels: Sequence[float] = OPEN_LEVELS, hold_s: float = 3.0,
                  rest_s: float = 3.0, rise_s: float = 0.5) -> IntentProfile:
    """A calibration session of opening contractions, beside the paper's squeezes.

    griploop's protocol (the paper has none): a rest of 3-4 s, then for each level an
    ``open_start`` cue, a reaction time of 0.2-0.4 s, a raised-cosine rise of ``rise_s``
    (within 20 %), a hold so that cue to cue lasts ``hold_s`` (within 15 %), an
    ``open_end`` cue, the reaction time again, a fall of ``rise_s`` (within 20 %) and a rest
    of ``rest_s`` (within 15 %; 3-4 s after the last contraction). The timing is jittered
    per call as :func:`paper_protocol`'s is; the levels are kept as given.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        Source of the jitter.
    fs_hz : float
        Sampling rate in hertz.
    levels : sequence of float
        Effort of each contraction, fractions of the largest opening, in (0, 1]
        (default :data:`OPEN_LEVELS`: 0.3, 0.6, 1.0).
    hold_s, rest_s, rise_s : float
        Cue-to-cue hold, rest between contractions and rise (and fall) time, seconds.

    Returns
    -------
    IntentProfile
        ``intent`` 0 throughout, ``open_intent`` the contractions, ``levels`` theirs, cues
        ``open_start, open_end`` per contraction in time order.

    Raises
    ------
    ProfileError
        A level outside (0, 1], none at all, non-positive ``hold_s``, ``rest_s`` or
        ``rise_s``, or a ``rise_s`` as long as the hold.
    """
    g = as_rng(rng)
    lv = tuple(float(v) for v in levels)
    if not lv or any(not 0.0 < v <= 1.0 for v in lv) or min(hold_s, rest_s, rise_s) <= 0 \
            or rise_s * 1.2 >= hold_s * 0.85:
        raise ProfileError(f"open_protocol needs levels in (0, 1] and positive hold_s, rest_s "
                           f"and rise_s (rise shorter than the hold), found {lv}, {hold_s}, "
                           f"{rest_s}, {rise_s}")
    t = g.uniform(3.0, 4.0)
    segments: list[tuple[float, float]] = [(t, 0.0)]
    cues: list[tuple[str, float]] = []
    for i, level in enumerate(lv):
        reaction = g.uniform(0.2, 0.4)
        rise = rise_s * g.uniform(0.8, 1.2)
        hold = hold_s * g.uniform(0.85, 1.15)
        fall = rise_s * g.uniform(0.8, 1.2)
        rest = rest_s * g.uniform(0.85, 1.15) if i < len(lv) - 1 else g.uniform(3.0, 4.0)
        cues.append(("open_start", t))
        segments += [(reaction, 0.0), (rise, level), (hold - rise, level)]
        cues.append(("open_end", t + reaction + hold))
        segments += [(reaction, level), (fall, 0.0), (rest, 0.0)]
        t += reaction + hold + reaction + fall + rest
    opening = from_segments(segments, fs_hz=fs_hz, cues=cues, levels=lv, name="open_protocol")
    return IntentProfile(np.zeros(opening.n_samples), opening.fs_hz, opening.cues, lv,
                         "open_protocol", opening.intent)


def ramp_profile(
    rng: np.random.Generator | int | None = None,
    *,
    fs_hz: float = 200.0,
    peaks: Sequence[float] = (0.5, 0.9),
    rise_s: float = 4.0,
    hold_s: float = 1.0,
    fall_s: float = 4.0,
    rest_s: float = 2.0,
    jitter: float = 0.1,
) -> IntentProfile:
    """Slow trapezoidal ramps to each of ``peaks`` (force-tracking task).

    Durations are scaled by ``1 + U(-jitter, jitter)`` each; cues mark the
    start of each rise and the start of each fall.
    """
    g = as_rng(rng)

    def j(d: float) -> float:
        return d * (1.0 + g.uniform(-jitter, jitter))

    t = j(rest_s)
    segments: list[tuple[float, float]] = [(t, 0.0)]
    cues: list[tuple[str, float]] = []
    for peak in peaks:
        r, h, f, s = j(rise_s), j(hold_s), j(fall_s), j(rest_s)
        cues += [("start", t), ("end", t + r + h)]
        segments += [(r, float(peak)), (h, float(peak)), (f, 0.0), (s, 0.0)]
        t += r + h + f + s
    return from_segments(segments, fs_hz=fs_hz, cues=cues, levels=peaks, name="ramp_profile")


@dataclass(frozen=True)
class GraspLiftTiming:
    """Nominal phase durations of :func:`grasp_lift_hold`, s (each jittered per profile).

    Attributes
    ----------
    rest_s : float
        Rest before the ramp.
    ramp_s : float
        Ramp from rest to the hold level.
    hold_s : float
        Hold at the hold level.
    release_s : float
        Release from the hold level to rest.
    final_rest_s : float
        Rest after the release.
    """

    rest_s: float = 1.0
    ramp_s: float = 0.5
    hold_s: float = 4.0
    release_s: float = 0.5
    final_rest_s: float = 1.0


def grasp_lift_hold(
    rng: np.random.Generator | int | None = None,
    *,
    fs_hz: float = 200.0,
    hold_level: float = 0.3,
    timing: GraspLiftTiming | None = None,
    jitter: float = 0.1,
) -> IntentProfile:
    """Rest, ramp to ``hold_level``, hold, release, rest: one grasp-and-lift.

    Parameters
    ----------
    rng : numpy.random.Generator, int or None
        Draws the duration jitter.
    fs_hz : float
        Sampling rate of the profile, Hz.
    hold_level : float
        Intent during the hold, fraction of MVC (0..1).
    timing : GraspLiftTiming, optional
        Nominal phase durations, s (default ``GraspLiftTiming()``).
    jitter : float
        Each duration is scaled by ``1 + U(-jitter, jitter)``.

    Returns
    -------
    IntentProfile
        Cues: ``start`` at the ramp onset, ``end`` at the release onset.
    """
    g = as_rng(rng)
    tm = GraspLiftTiming() if timing is None else timing
    d = [v * (1.0 + g.uniform(-jitter, jitter))
         for v in (tm.rest_s, tm.ramp_s, tm.hold_s, tm.release_s, tm.final_rest_s)]
    segments = [(d[0], 0.0), (d[1], hold_level), (d[2], hold_level), (d[3], 0.0), (d[4], 0.0)]
    cues = [("start", d[0]), ("end", d[0] + d[1] + d[2])]
    return from_segments(segments, fs_hz=fs_hz, cues=cues, levels=(hold_level,),
                         name="grasp_lift_hold")
