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
(:class:`~estimation.rest_gate.RestGate`, :mod:`controllers.paradigms`). Tolerances
(docs/DEPLOY.md): features within one unit in the last place of float32 (the C divides
and takes square roots in float32, Python in float64), estimate, reference and command
within 1e-3 (N, command units).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from controllers.base import Observation
from controllers.paradigms import make_paradigm
from estimation.features import extract_features
from estimation.rest_gate import RestGate
from scenarios.deploy.library import (
    CompiledController,
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
    gate = RestGate(reference.rest_on_n, reference.rest_off_n)
    paradigm = make_paradigm(reference.paradigm)
    to_hand = 1.0 if reference.to_hand is None else float(reference.to_hand)
    ceiling = np.inf if reference.reference_max_n is None else float(reference.reference_max_n)
    held, out = 0.0, []
    for estimate in np.asarray(estimates_n, dtype=float):
        value = gate.step(float(estimate)) * to_hand
        if value == value:
            held = min(max(value, 0.0), ceiling)
        out.append(paradigm.step(held))
    return np.array(out)


def replay_reference(library: CompiledLibrary, estimates_n: np.ndarray,
                     reference: HandReference) -> tuple[np.ndarray, np.ndarray]:
    """The C runtime's and the Python hand reference for the same estimates, N.

    Returns
    -------
    c_n, python_n : ndarray, shape (n,)
    """
    c = CompiledReference(library)
    return c.run(estimates_n), python_reference(estimates_n, reference)


def hand_observations(design: Any, obj: ObjectSpec, recording: Recording, fitted: Any, *,
                      hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N, duration_s: float,
                      seed: int = 0, hand: HandSettings = DEFAULT_HAND,
                      ) -> tuple[list[Observation], np.ndarray]:
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
    observations : list of Observation
    commands : ndarray, shape (n_run,)
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
    loop.run()
    rec = loop.recorder
    return list(rec.observations), np.asarray(rec.computed)


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
