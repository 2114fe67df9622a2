"""Replays through C and Python, sample for sample: features, estimate, controller command.

:func:`replay_estimator` pushes every int8 frame of a recording through the C feature
window and the C estimator, and the same recording through
:func:`estimation.features.extract_features` and the fitted pipeline's stream; each
feeds its own features to its own estimator (``one_step``: both get the recording's
force at the previous window's end). :func:`hand_observations` replays the recording in
a trial (the one trial loop, :mod:`scenarios.runners.trial_loop`: the recording's sEMG
drives the hand, its forearm's pitch moves the wrist) and records what the designed
Python controller saw and commanded; :func:`replay_controller` feeds those observations
to the C controller and compares the commands. :func:`replay_reference` feeds the C
estimates to the runtime's reference (rest threshold, force mapping, paradigm) and to
:func:`python_reference`, the same chain of griploop's own parts
(:class:`~estimation.rest_gate.RestGate`, :mod:`controllers.paradigms`).

With an open/close decoder, :func:`replay_decoder` pushes the frames through the C MAV
window of every channel and the C decoder, and the same recording through
:class:`estimation.feature_window.FeatureWindow` (MAV, all channels) and the decoder's
stream; :func:`replay_shaping` feeds the C estimates and the C decoder's levels to the C
reference and to the Python paradigm (``velocity``: its held grip and ``command_range``).

Tolerances (docs/DEPLOY.md): features within one unit in the last place of float32 (the
C divides and takes square roots in float32, Python in float64), estimate, reference and
command within 1e-3 (N, command units), decoder levels within 1e-5 with every label
equal, command bounds within 1e-6.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from controllers.base import Observation
from controllers.paradigms import Decoded, command_range, make_paradigm, uses_decoder
from estimation.features import extract_features
from estimation.rest_gate import RestGate
from scenarios.deploy.library import (
    CompiledController,
    CompiledDecoder,
    CompiledDecoderWindow,
    CompiledFeatures,
    CompiledLibrary,
    CompiledReference,
    CompiledStream,
)
from scenarios.live.arm import LIFT_HEIGHT_M
from scenarios.live.recorded import RecordedPerson, ReplaySpec, check_layout
from scenarios.runners.episode import HAND_FORCE_AT_MVC_N
from scenarios.runners.semg_reference import HandReference
from scenarios.runners.trial_loop import (
    DEFAULT_HAND,
    HandSettings,
    TrialHooks,
    TrialLoop,
    TrialTiming,
)
from sim.c_source import ExportError
from sim.hand.objects import ObjectSpec
from sim.recording import Recording

#: What the equivalence tests and ``export-c --check`` accept.
ESTIMATE_TOLERANCE_N = 1e-3
REFERENCE_TOLERANCE_N = 1e-3
COMMAND_TOLERANCE = 1e-3
FEATURE_TOLERANCE_ULPS = 1.0
DECODER_TOLERANCE = 1e-5
RANGE_TOLERANCE = 1e-6


@dataclass
class EstimatorReplay:
    """A recording through C and Python.

    Attributes
    ----------
    samples, windows : int
        Frames pushed, feature windows compared.
    features_c, features_py : ndarray, shape (windows, n_features)
    estimate_c_n, estimate_py_n : ndarray, shape (windows,)
    t_s : ndarray, shape (windows,)
        Each window's end, s.
    """

    samples: int
    windows: int
    features_c: np.ndarray
    features_py: np.ndarray
    estimate_c_n: np.ndarray
    estimate_py_n: np.ndarray
    t_s: np.ndarray

    @property
    def feature_ulps(self) -> float:
        """Largest feature difference in units of the last place of the float32 Python value."""
        ulp = np.spacing(np.abs(self.features_py).astype(np.float32)).astype(np.float64)
        return float(np.max(np.abs(self.features_c - self.features_py) / ulp, initial=0.0))

    @property
    def feature_error(self) -> float:
        """Largest absolute feature difference (feature units)."""
        return float(np.max(np.abs(self.features_c - self.features_py), initial=0.0))

    @property
    def estimate_error_n(self) -> float:
        """Largest absolute estimate difference, N."""
        return float(np.max(np.abs(self.estimate_c_n - self.estimate_py_n), initial=0.0))


def int8_frames(recording: Recording) -> np.ndarray:
    """The recording's sEMG as int8 frames (n_samples, n_channels).

    Raises
    ------
    ExportError
        Samples that are not whole 8-bit counts: the C window reads int8.
    """
    emg = np.asarray(recording.emg)
    if emg.dtype == np.int8:
        return emg
    as_int = np.rint(emg)
    if not (np.all(as_int == emg) and as_int.min() >= -128 and as_int.max() <= 127):
        raise ExportError(f"{recording.source}: the C feature window reads signed 8-bit counts; "
                          f"found {emg.dtype} samples outside them")
    return as_int.astype(np.int8)


def replay_estimator(library: CompiledLibrary, recording: Recording, pipeline: Any, mode: str,
                     *, channels: Sequence[int | str] | None, window_ms: float, step_ms: float,
                     uses_force: bool) -> EstimatorReplay:
    """Replay ``recording`` through the compiled and the Python feature window and estimator.

    Raises
    ------
    ExportError
        The recording's samples are not 8-bit counts.
    """
    frames = int8_frames(recording)
    fs = extract_features(recording, channels=channels, window_ms=window_ms, step_ms=step_ms)
    c_features = CompiledFeatures(library, fs.X.shape[1]).run(frames)
    stream = pipeline.streaming(mode)
    stream.reset()
    c_stream = CompiledStream(library, mode=mode, uses_force=uses_force)
    n = fs.n_windows
    py, cc = np.empty(n), np.empty(n)
    for k in range(n):
        y_prev = (float(fs.y[k - 1]) if k > 0 else 0.0) if uses_force else None
        py[k] = stream.step(fs.X[k], y_prev)
        cc[k] = c_stream.step(c_features[k], y_prev)
    return EstimatorReplay(int(frames.shape[0]), n, c_features.astype(np.float64), fs.X, cc, py,
                          fs.t_s)


@dataclass
class DecoderReplay:
    """A recording through the C and the Python decoder (each on its own MAV window).

    Attributes
    ----------
    windows : int
    mav_c, mav_py : ndarray, shape (windows, n_channels)
        Every channel's MAV per window, counts.
    levels_c, levels_py : ndarray, shape (windows, 2)
        Close and open levels, 0..1.
    labels_c, labels_py : ndarray of int, shape (windows,)
        0 rest, 1 close, 2 open.
    """

    windows: int
    mav_c: np.ndarray
    mav_py: np.ndarray
    levels_c: np.ndarray
    levels_py: np.ndarray
    labels_c: np.ndarray
    labels_py: np.ndarray

    @property
    def level_error(self) -> float:
        """Largest close or open level difference."""
        return float(np.max(np.abs(self.levels_c - self.levels_py), initial=0.0))

    @property
    def mav_ulps(self) -> float:
        """Largest MAV difference in float32 units in the last place of the Python value."""
        ulp = np.spacing(np.abs(self.mav_py).astype(np.float32)).astype(np.float64)
        return float(np.max(np.abs(self.mav_c - self.mav_py) / ulp, initial=0.0))

    @property
    def label_mismatches(self) -> int:
        """Windows whose C and Python labels differ."""
        return int(np.sum(self.labels_c != self.labels_py))

    def summary(self) -> dict[str, Any]:
        """JSON-ready: windows, errors and how many windows each side decoded as open."""
        return {"windows": self.windows, "max_abs_error": self.level_error,
                "mav_max_ulps": self.mav_ulps, "label_mismatches": self.label_mismatches,
                "open_windows": int(np.sum(self.labels_py == 2)),
                "close_windows": int(np.sum(self.labels_py == 1))}


def replay_decoder(library: CompiledLibrary, recording: Recording, decoder: Any, *,
                   window_ms: float, step_ms: float) -> DecoderReplay:
    """Replay ``recording`` through the compiled and the Python open/close decoder.

    Raises
    ------
    ExportError
        The recording's samples are not 8-bit counts.
    """
    from estimation.feature_window import FeatureWindow

    frames = int8_frames(recording)
    n_ch = int(frames.shape[1])
    mav_c = CompiledDecoderWindow(library, n_ch).run(frames).astype(np.float64)
    window = FeatureWindow(recording.fs_hz, range(n_ch), window_ms=window_ms, step_ms=step_ms,
                           features=("mav",), integer=True)
    mav_py = np.asarray(window.push(frames)[0], dtype=np.float64).reshape(-1, n_ch)
    n = min(len(mav_c), len(mav_py))
    c_dec, stream = CompiledDecoder(library), decoder.stream()
    c_dec.reset()
    stream.reset()
    levels_c, levels_py = np.zeros((n, 2)), np.zeros((n, 2))
    labels_c, labels_py = np.zeros(n, dtype=int), np.zeros(n, dtype=int)
    for k in range(n):
        close, open_, labels_c[k] = c_dec.step(mav_c[k])
        levels_c[k] = close, open_
        levels_py[k] = stream.step(mav_py[k])
        labels_py[k] = stream.label()
    return DecoderReplay(n, mav_c[:n], mav_py[:n], levels_c, levels_py, labels_c, labels_py)


@dataclass
class ShapingReplay:
    """The hand reference and the paradigm's command bounds of the C runtime and of Python.

    Attributes
    ----------
    reference_c_n, reference_py_n : ndarray, shape (windows,)
        N.
    range_c, range_py : ndarray, shape (windows, 2)
        The command's lower and upper bound after each window (``(-1, 1)``: none).
    """

    reference_c_n: np.ndarray
    reference_py_n: np.ndarray
    range_c: np.ndarray
    range_py: np.ndarray

    @property
    def reference_error_n(self) -> float:
        """Largest reference difference, N."""
        return float(np.max(np.abs(self.reference_c_n - self.reference_py_n), initial=0.0))

    @property
    def range_error(self) -> float:
        """Largest command bound difference."""
        return float(np.max(np.abs(self.range_c - self.range_py), initial=0.0))


def python_shaping(estimates_n: np.ndarray, reference: HandReference, levels: np.ndarray,
                   grip_at_full_close_n: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`python_reference` with the decoder's levels: each window's
    :class:`~controllers.paradigms.Decoded` (grip = close x ``grip_at_full_close_n``) reaches
    the paradigm, as a trial hands it over (:mod:`scenarios.runners.semg_reference`).

    Returns
    -------
    reference_n : ndarray, shape (n,)
    ranges : ndarray, shape (n, 2)
        ``command_range`` after each step (``(-1, 1)`` for a paradigm without one).
    """
    decoded = [Decoded(float(c), float(o), float(c) * float(grip_at_full_close_n))
               for c, o in np.asarray(levels, dtype=float).reshape(-1, 2)]
    return _shaped(estimates_n, reference, decoded)


def _shaped(estimates_n: np.ndarray, reference: HandReference,
            decoded: Sequence[Decoded] | None) -> tuple[np.ndarray, np.ndarray]:
    gate = RestGate(reference.rest_on_n, reference.rest_off_n)
    paradigm = make_paradigm(reference.paradigm)
    with_decoded = decoded is not None and uses_decoder(paradigm)
    to_hand = 1.0 if reference.to_hand is None else float(reference.to_hand)
    ceiling = np.inf if reference.reference_max_n is None else float(reference.reference_max_n)
    held, out, ranges = 0.0, [], []
    for k, estimate in enumerate(np.asarray(estimates_n, dtype=float)):
        value = gate.step(float(estimate)) * to_hand
        if value == value:
            held = min(max(value, 0.0), ceiling)
        out.append(paradigm.step(held, decoded[k]) if with_decoded else paradigm.step(held))
        ranges.append(command_range(paradigm))
    return np.array(out), np.array(ranges, dtype=float).reshape(-1, 2)


def replay_shaping(library: CompiledLibrary, estimates_n: np.ndarray, reference: HandReference,
                   levels: np.ndarray, grip_at_full_close_n: float) -> ShapingReplay:
    """The C runtime's and Python's reference and command bounds for the same estimates and
    decoder levels (``levels``: the C decoder's, shape (n, 2))."""
    c = CompiledReference(library)
    ref_c, range_c = [], []
    for estimate, (close, open_) in zip(np.asarray(estimates_n, dtype=float),
                                        np.asarray(levels, dtype=float), strict=True):
        ref_c.append(c.step(estimate, close, open_))
        range_c.append(c.command_range())
    ref_py, range_py = python_shaping(estimates_n, reference, levels, grip_at_full_close_n)
    return ShapingReplay(np.array(ref_c), ref_py, np.array(range_c, dtype=float), range_py)


@dataclass
class DecoderCheck:
    """The decoder's replay and the paradigm's shaping on it, C against Python.

    Attributes
    ----------
    replay : DecoderReplay
    shaping : ShapingReplay
        The C estimates and the C decoder's levels through the C reference and the
        Python paradigm.
    """

    replay: DecoderReplay
    shaping: ShapingReplay

    @classmethod
    def of(cls, library: CompiledLibrary, recording: Recording, export: Any,
           estimates: EstimatorReplay) -> DecoderCheck:
        """Both replays of ``recording`` for an export with a decoder
        (:class:`scenarios.deploy.writer.CExport`)."""
        part = export.decoder_part
        dec = replay_decoder(library, recording, part.decoder,
                             window_ms=export.window.window_ms, step_ms=export.window.step_ms)
        if dec.windows != estimates.windows:
            raise ExportError(f"decoder replay: {dec.windows} windows; expected the feature "
                              f"window's {estimates.windows}")
        shaping = replay_shaping(library, estimates.estimate_c_n, export.reference,
                                 dec.levels_c, part.grip_at_full_close_n)
        return cls(dec, shaping)

    def summary(self) -> dict[str, Any]:
        """JSON-ready: :meth:`DecoderReplay.summary` and the shaping's largest errors."""
        return {**self.replay.summary(), "reference_max_abs_error_n":
                self.shaping.reference_error_n,
                "command_range_max_abs_error": self.shaping.range_error}


def python_reference(estimates_n: np.ndarray, reference: HandReference) -> np.ndarray:
    """The hand reference griploop's Python parts make of a sequence of estimates, N.

    The rest gate, the force mapping (clipped to ``0 .. reference_max_n``; a NaN
    estimate holds the reference) and the paradigm of ``reference``, as a trial applies
    them (:mod:`scenarios.runners.semg_reference`,
    :class:`~scenarios.runners.trial_loop.TrialLoop`).

    Returns
    -------
    ndarray, shape (n,)
    """
    return _shaped(estimates_n, reference, None)[0]


def replay_reference(library: CompiledLibrary, estimates_n: np.ndarray,
                     reference: HandReference) -> tuple[np.ndarray, np.ndarray]:
    """The C runtime's and the Python hand reference for the same estimates, N.

    Returns
    -------
    c_n, python_n : ndarray, shape (n,)
    """
    c = CompiledReference(library)
    return c.run(estimates_n), python_reference(estimates_n, reference)


@dataclass
class HandRun:
    """What the Python controller saw and commanded in a trial (:func:`hand_run`).

    Attributes
    ----------
    observations : list of Observation
    commands : ndarray, shape (n_run,)
        The commands, within the paradigm's bounds.
    bounds : ndarray, shape (n_run, 2)
        The paradigm's bounds on each step's command (``(-1, 1)``: none).
    """

    observations: list[Observation]
    commands: np.ndarray
    bounds: np.ndarray


class _RangeRecorder:
    """A paradigm that records its ``command_range`` after every step."""

    def __init__(self, paradigm: Any) -> None:
        self._paradigm = paradigm
        self.ranges: list[tuple[float, float]] = []

    def step(self, *args: Any) -> float:
        out = self._paradigm.step(*args)
        self.ranges.append(command_range(self._paradigm))
        return out

    @property
    def command_range(self) -> tuple[float, float]:
        return command_range(self._paradigm)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["_paradigm"], name)


def hand_observations(design: Any, obj: ObjectSpec, recording: Recording, fitted: Any, *,
                      hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N, duration_s: float,
                      seed: int = 0, hand: HandSettings = DEFAULT_HAND,
                      ) -> tuple[list[Observation], np.ndarray]:
    """:func:`hand_run`'s observations and commands."""
    run = hand_run(design, obj, recording, fitted, hand_force_at_mvc_n=hand_force_at_mvc_n,
                   duration_s=duration_s, seed=seed, hand=hand)
    return run.observations, run.commands


def hand_run(design: Any, obj: ObjectSpec, recording: Recording, fitted: Any, *,
             hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N, duration_s: float,
             seed: int = 0, hand: HandSettings = DEFAULT_HAND) -> HandRun:
    """What the design's Python controller saw and commanded in a trial on ``recording``.

    The trial starts 1 s before the first window whose reference exceeds 0.5 N (a
    calibration recording's rest is skipped; the earlier samples warm the estimator up)
    and lasts ``duration_s`` (shorter if the recording ends first). The wrist follows
    the recording's forearm pitch when it has one
    (:class:`~scenarios.live.recorded.RecordedPerson`), else the
    hand holds the object on the table, so the run covers closing, approach, force
    control and release.

    Parameters
    ----------
    design : controllers.design.ControllerDesign
    obj : ObjectSpec
    recording : Recording
        The calibration's layout.
    fitted : scenarios.live.recorded.RecordedCalibration
        The fitted estimator.
    hand_force_at_mvc_n : float
        The force mapping's scale, N.
    duration_s : float
        The longest run, s.
    seed : int
        The environment's seed.
    hand : HandSettings
        The hand's drive and paradigm (its slip response is in ``design``).

    Returns
    -------
    HandRun
    """
    check_layout(recording, fitted)
    dt = float(design.core.dt_s)
    pitched = recording.pitch_rad is not None
    spec = ReplaySpec(control_dt_s=dt, hand_force_at_mvc_n=hand_force_at_mvc_n,
                      lift_height_m=LIFT_HEIGHT_M if pitched else None)
    start_s = _grasp_start_s(recording, fitted, spec)
    limit_s = min(duration_s, recording.duration_s - start_s)
    spec = replace(spec, episode_s=limit_s)
    person = RecordedPerson(recording, fitted, spec, start_s=start_s)
    loop = TrialLoop(obj, design, person, TrialTiming(limit_s, dt),
                     lift_height_m=spec.lift_height_m, seed=seed,
                     hooks=TrialHooks(keep_observations=True), hand=hand)
    recorder = None
    if hasattr(loop.paradigm, "command_range"):  # velocity: record its bounds on the motor
        loop.paradigm = recorder = _RangeRecorder(loop.paradigm)
    loop.run()
    rec = loop.recorder
    observations = list(rec.observations)
    bounds = (np.array(recorder.ranges, dtype=float).reshape(-1, 2)[:len(observations)]
              if recorder is not None else
              np.tile(np.array([-1.0, 1.0]), (len(observations), 1)))
    return HandRun(observations, np.asarray(rec.computed), bounds)


def _grasp_start_s(recording: Recording, fitted: Any, spec: Any) -> float:
    """1 s before the first window of ``recording`` whose reference exceeds 0.5 N, s."""
    person = RecordedPerson(recording, fitted, spec)
    person.samples_to(recording.duration_s)
    chain = person.reference
    values, t = np.asarray(chain.window_values_n), np.asarray(chain.window_t_s)
    above = np.flatnonzero(values > 0.5)
    return max(0.0, float(t[above[0]]) - 1.0) if above.size else 0.0


def replay_controller(library: CompiledLibrary, design: Any,
                      observations: Sequence[Observation]) -> np.ndarray:
    """The compiled controller's commands for an observation sequence (from a reset)."""
    c = CompiledController(library, dt_s=design.core.dt_s, name=design.kind)
    return np.array([c.act(o) for o in observations])


def clip_commands(commands: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """``commands`` clipped to each step's ``bounds`` (n, 2) in float32, as the runtime
    clips the controller's command to the paradigm's range (``gl_clip``)."""
    out = np.asarray(commands, dtype=float)
    if not out.size:
        return out
    b = np.asarray(bounds, dtype=np.float32).astype(float).reshape(-1, 2)
    return np.where(out < b[:, 0], b[:, 0], np.where(out > b[:, 1], b[:, 1], out))
