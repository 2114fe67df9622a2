"""Calibration: an estimator fitted on a subject's squeeze session and scored on its rest.

:func:`calibrate` records the scenario subject's calibration session
(:mod:`scenarios.runners.subject`) and fits the estimator on it;
:func:`fit_on_features` fits it on a session's features, simulated or recorded
(:mod:`scenarios.live.recorded`); :func:`run_calibration_scenario` is the runner of
scenario kind ``calibration``. Fitting and scoring is
:func:`estimation.evaluation.fit_and_score`, the same as the reproduction's
(:mod:`scenarios.runners.reproduction`) and ``griploop evaluate``'s: the first part of
the windows identifies, the estimator runs over the whole session and the rest scores.
:func:`fit_one` adds what a run needs of one estimator in one mode: the mode exists and
the model does not diverge in it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.features import FeatureSet
from estimation.paper import PAPER_ORDER
from estimation.rest_gate import RestGate, rest_thresholds
from estimation.threads import one_blas_thread
from scenarios.rows import CalibrationRow
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.subject import calibration_session, subject_for
from scenarios.schema import NO_ESTIMATOR, Scenario
from sim.recording import Recording
from sim.user.subjects import VirtualSubject


@dataclass
class Calibration:
    """An estimator fitted on a subject's calibration session.

    Attributes
    ----------
    name : str
        Estimator name (or ``"oracle"``, ``"intact"``, ``"ideal_interface"``).
    mode : {"one_step", "free_run"}
    pipeline : object or None
        Fitted :class:`estimation.pipeline.ForcePipeline` (``None`` for the oracle, the intact
        hand and the ideal interface).
    mvc_cal_n : float
        Largest FSR force of the calibration session, N.
    r2 : float or None
        Validation R^2 in ``mode`` on the session's last part (None for the oracle).
    fit_s : float
        Time to fit, s.
    rest_on_n, rest_off_n : float
        The hand's rest threshold on the estimate (:mod:`estimation.rest_gate`), N:
        closed above ``rest_on_n``, open again below ``rest_off_n``; set from the
        estimate at sustained rest in the session (0: none, the oracle's).
    decoder : object or None
        The open/close decoder fitted on the squeeze session and a session of open
        contractions (:mod:`estimation.decoding`); ``None``: none fitted.
    """

    name: str
    mode: str
    pipeline: Any
    mvc_cal_n: float
    r2: float | None
    fit_s: float
    rest_on_n: float = 0.0
    rest_off_n: float = 0.0
    decoder: Any = None

    def rest_gate(self) -> RestGate:
        """A new (open) :class:`~estimation.rest_gate.RestGate` at the calibration's thresholds."""
        return RestGate(self.rest_on_n, self.rest_off_n)


def fit_one(features: FeatureSet, estimator: str, mode: str, *, rng: np.random.Generator,
            order: int, fraction: float, time_steps: bool = False,
            options: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Fit and score one estimator (:func:`~estimation.evaluation.fit_and_score`) for one mode.

    Parameters
    ----------
    features : FeatureSet
        The session's features, ``X`` shape (n_windows, n_inputs), ``y`` in N.
    estimator : str
        Registry name.
    mode : {"one_step", "free_run"}
        The mode the run will use.
    rng : numpy.random.Generator
        Seeds the estimator.
    order, fraction, time_steps
        As :func:`estimation.evaluation.fit_and_score`.
    options : mapping, optional
        The estimator's own hyperparameters a user chose (``estimator.options``).

    Returns
    -------
    dict
        :func:`estimation.evaluation.evaluate_subject`'s entry of the estimator, with
        its fitted ``"_pipeline"``; its ``modes[mode]["status"]`` is ``"ok"``.

    Raises
    ------
    UnsupportedScenarioError
        The estimator has no such mode.
    DivergedError
        The identified model is unstable in ``mode``, or its Kalman design failed.
    """
    # the estimators (scikit-learn's models) load here: an oracle reference fits nothing
    from estimation.evaluation import fit_and_score

    result = fit_and_score(features, [estimator], rng=rng, order=order, fraction=fraction,
                           time_steps=time_steps,
                           options={estimator: dict(options)} if options else None)[0][estimator]
    if mode not in result["modes"]:
        raise UnsupportedScenarioError(
            f"estimator {estimator} has modes {tuple(result['modes'])} (found mode {mode})"
        )
    reason = result["_pipeline"].divergence(mode) if "_pipeline" in result else None
    if reason is not None:
        raise DivergedError(f"estimator {estimator}: {reason}")
    scores = result["modes"][mode]
    if scores["status"] != "ok":
        raise DivergedError(f"{estimator} {mode}: {scores.get('message', scores['status'])}")
    return result


def fit_on_features(features: FeatureSet, estimator: str, mode: str, *,
                    rng: np.random.Generator, order: int, identification_fraction: float,
                    mvc_cal_n: float, options: Mapping[str, Any] | None = None) -> Calibration:
    """Fit ``estimator`` on the identification part of a calibration's features and score it.

    The fit of a calibration, for a simulated session (:func:`calibrate`) and a
    recording (:mod:`scenarios.live.recorded`), through :func:`fit_one`; the hand's
    rest threshold comes from the fitted estimate over the whole session
    (:func:`estimation.rest_gate.rest_thresholds`).

    Raises
    ------
    UnsupportedScenarioError
        ``mode`` is not one of the estimator's modes.
    DivergedError
        The identified model is unstable and ``mode`` would run it open loop.
    """
    result = fit_one(features, estimator, mode, rng=rng, order=order,
                     fraction=identification_fraction, options=options)
    pipeline = result["_pipeline"]
    estimate = pipeline.predict(features.X, features.y if mode == "one_step" else None,
                                mode=mode)
    on_n, off_n = rest_thresholds(estimate, features.y, features.dt_s)
    return Calibration(estimator, mode, pipeline, mvc_cal_n, result["modes"][mode]["r2"],
                       result["train_ms"] / 1e3, on_n, off_n)


@dataclass(frozen=True)
class CalibrationSettings:
    """How a calibration is recorded and fitted: everything but the subject and the seed.

    Attributes
    ----------
    estimator, mode : str
        The estimator (or ``"oracle"``, ``"intact"``, ``"ideal_interface"``) and its mode.
    order : int
        State-space order of the estimators that take one.
    generator : str
        The sEMG generator.
    identification_fraction : float
        Share of the session that identifies.
    calibration_s : float or None
        Least session length, s (``None``: the paper's one session).
    options : mapping or None
        The estimator's own hyperparameters.
    window_ms, step_ms : float
        The feature window and its increment, ms.
    decoder : str or None
        An open/close decoder to fit too (:mod:`estimation.decoding`): the session then
        adds open contractions (:meth:`sim.user.subjects.VirtualSubject.open_session`).
        ``None``: the paper's squeezes only.
    """

    estimator: str
    mode: str
    order: int = PAPER_ORDER
    generator: str = "noise"
    identification_fraction: float = 0.5
    calibration_s: float | None = None
    options: Mapping[str, Any] | None = None
    window_ms: float = 400.0
    step_ms: float = 125.0
    decoder: str | None = None

    def fit(self, subject: VirtualSubject, seed_seq: np.random.SeedSequence) -> Calibration:
        """:func:`shared_calibration` of ``subject`` with these settings."""
        return shared_calibration(subject, self, seed_seq=seed_seq)

    def key(self, seed_seq: np.random.SeedSequence) -> dict[str, Any]:
        """JSON-ready identity of the calibration these settings fit with ``seed_seq``."""
        return {"seed": [int(x) for x in seed_seq.generate_state(4)],
                "estimator": self.estimator, "mode": self.mode, "order": int(self.order),
                "generator": self.generator,
                "identification_fraction": float(self.identification_fraction),
                "calibration_s": self.calibration_s, "options": dict(self.options or {}),
                "window_ms": float(self.window_ms), "step_ms": float(self.step_ms),
                **({} if self.decoder is None else {"decoder": self.decoder})}


def calibrate(subject: VirtualSubject, settings: CalibrationSettings, *,
              rng: np.random.Generator) -> Calibration:
    """Record a calibration session and fit the estimator on its first part.

    Parameters
    ----------
    subject : VirtualSubject
        The user whose session is recorded.
    settings : CalibrationSettings
        The estimator, its mode and options, the session's sEMG generator and least
        length, the identifying share and the feature window (``window_ms`` windows
        every ``step_ms``).
    rng : numpy.random.Generator
        Split in two: the session (protocol timing, levels, noise) and the estimator's
        seeds.

    Returns
    -------
    Calibration
        The fitted estimator (none for the oracle and the references the user's own force
        drives) and its scores.

    Raises
    ------
    UnsupportedScenarioError, DivergedError
        As :func:`fit_on_features`.
    """
    s = settings
    session_rng, estimator_rng = rng.spawn(2)
    recording, features = calibration_session(subject, session_rng, generator=s.generator,
                                              min_duration_s=s.calibration_s,
                                              window_ms=s.window_ms, step_ms=s.step_ms)
    mvc_cal_n = float(np.max(recording.force_n))
    if s.estimator in NO_ESTIMATOR:  # the oracle, intact, ideal_interface: nothing to fit
        cal = Calibration(s.estimator, s.mode, None, mvc_cal_n, None, 0.0)
    else:
        cal = fit_on_features(features, s.estimator, s.mode, rng=estimator_rng, order=s.order,
                              identification_fraction=s.identification_fraction,
                              mvc_cal_n=mvc_cal_n, options=s.options)
    if s.decoder is not None:
        # a third stream of the calibration's seed: the squeezes and the estimator keep theirs
        open_session = subject.open_session(rng.spawn(1)[0], generator=s.generator,
                                            fs_hz=recording.fs_hz)
        cal.decoder = fit_decoder(s.decoder, [recording, open_session],
                                  window_ms=s.window_ms, step_ms=s.step_ms)
    return cal


def fit_decoder(name: str, recordings: Sequence[Recording], *, window_ms: float = 400.0,
                step_ms: float = 125.0) -> Any:
    """The decoder ``name`` fitted on the labelled windows of ``recordings``.

    Parameters
    ----------
    name : str
        A registered decoder (:func:`estimation.decoding.decoder_names`).
    recordings : sequence of Recording
        Sessions with their close intent (``intent``) and, for some, their open intent
        (``open_intent``): the paper's squeezes and the open contractions.
    window_ms, step_ms : float
        The feature window and its increment, ms.

    Raises
    ------
    estimation.decoding.DecoderCalibrationError
        No open contractions in any recording, or a site that never rises above its
        rest level (the message names its channels).
    """
    from estimation.decoding import decoder_windows, make_decoder

    xs, ys = [], []
    for rec in recordings:
        intent = rec.intent if rec.intent is not None else np.zeros(rec.n_samples)
        x, y = decoder_windows(rec.emg, intent, rec.open_intent,
                               fs_hz=rec.fs_hz, window_ms=window_ms, step_ms=step_ms)[:2]
        xs.append(x)
        ys.append(y)
    return make_decoder(name).fit(np.concatenate(xs), np.concatenate(ys))


_CALIBRATIONS: dict[tuple, Calibration] = {}
_MAX_CALIBRATIONS = 8


def shared_calibration(subject: VirtualSubject, settings: CalibrationSettings, *,
                       seed_seq: np.random.SeedSequence) -> Calibration:
    """:func:`calibrate`, memoized in this process on everything it depends on.

    A sweep's scenarios that differ only in what happens after the calibration (the
    object, the controller, the feedback) calibrate the same subject with the same seed
    (``seed_by: [subject]``): a worker process fits the estimator once and the next
    scenarios reuse it, as the trials of one feedback task do. The fit is deterministic
    given its seeds (``seed_seq`` seeds :func:`calibrate`'s ``rng``), so the figures are
    those of a fresh calibration; ``fit_s`` is the time the one fit took. The last
    :data:`_MAX_CALIBRATIONS` are kept.
    """
    s = settings
    key = (subject, s.estimator, s.mode, s.order, s.generator, s.identification_fraction,
           s.calibration_s, tuple(seed_seq.generate_state(4)),
           tuple(sorted((s.options or {}).items())), float(s.window_ms), float(s.step_ms),
           s.decoder)
    if key not in _CALIBRATIONS:
        if len(_CALIBRATIONS) >= _MAX_CALIBRATIONS:
            _CALIBRATIONS.pop(next(iter(_CALIBRATIONS)))
        _CALIBRATIONS[key] = calibrate(subject, settings, rng=np.random.default_rng(seed_seq))
    return _CALIBRATIONS[key]


def run_calibration_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``calibration``: fit on a session, score the rest, no grasp."""
    e, p = scenario.estimator, scenario.protocol
    subject = subject_for(scenario)
    with one_blas_thread():
        # the paper's 400 ms windows every 125 ms (the kind ignores estimator.window_ms)
        settings = CalibrationSettings(
            e.name, e.mode, PAPER_ORDER if e.order is None else e.order,
            scenario.subject.generator, p.identification_fraction, p.calibration_s, e.options)
        cal = calibrate(subject, settings,
                        rng=np.random.default_rng(np.random.SeedSequence(scenario.seed or 0)))
    return CalibrationRow.build(subject_id=subject.subject_id, estimator=e.name, mode=e.mode,
                                r2=cal.r2, mvc_cal_n=cal.mvc_cal_n, fit_s=cal.fit_s).as_dict()
