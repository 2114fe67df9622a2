"""A person's calibration recording fitted: the estimator, and an open/close decoder.

:func:`fit_calibration` fits the estimator on a calibration recording (a virtual
subject's paper session, a file from ``griploop calibrate --lsl`` or a lab's recording)
exactly as :func:`scenarios.runners.calibration.calibrate` fits it on a simulated
session: features of the chosen channels, the first 50 % of the windows identify, the
rest scores, ``mvc_cal_n`` is the largest measured force.

A recording with open contractions (``griploop calibrate --open``, or
:func:`with_open_contractions` of a virtual subject's two sessions) holds them after the
squeezes, from ``metadata["open_from_s"]``: the estimator sees the squeezes only
(:func:`squeeze_part`), and an open/close decoder, when one is asked for, is fitted on the
whole recording with all its channels (:func:`scenarios.runners.calibration.fit_decoder`;
close label: the recording's ``intent``, else its force over the squeezes' largest; open
label: ``open_intent``). A calibration without open contractions (a real recording of
squeezes only, any lab's CSV) cannot fit one: :func:`calibration_decoder` refuses it in
one line, before any stream is opened or trial run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from controllers.paradigms import needs_decoder
from estimation.decoding import DecoderCalibrationError, NoOpenContractionsError
from estimation.features import PAPER_CHANNELS, extract_features
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.live.errors import SessionError
from scenarios.runners.calibration import Calibration, fit_decoder, fit_on_features
from scenarios.runners.episode import HAND_FORCE_AT_MVC_N
from scenarios.runners.trial_loop import HandSettings
from scenarios.schema import ORACLE
from sim.recording import Recording, RecordingError

OPEN_ON = 0.1
"""Open intent from which a sample is an opening contraction (the decoder's label edge:
:func:`estimation.decoding.decoder_windows`' ``on``)."""


@dataclass
class RecordedCalibration:
    """An estimator fitted on a calibration recording, with the layout a stream must match.

    Attributes
    ----------
    calibration : scenarios.runners.calibration.Calibration
        Estimator name, mode, fitted pipeline, ``mvc_cal_n`` (N), validation R^2, fit time.
    recording : Recording
        The calibration recording.
    channels : list or None
        The channels used, as given (``None``: all).
    channel_index : list of int
        Their zero-based columns.
    """

    calibration: Calibration
    recording: Recording
    channels: list[int | str] | None
    channel_index: list[int] = field(default_factory=list)

    @property
    def fs_hz(self) -> float:
        """Sampling rate a stream must have, Hz."""
        return self.recording.fs_hz

    @property
    def n_channels(self) -> int:
        """Channel count a stream must have."""
        return self.recording.n_channels

    @property
    def integer(self) -> bool:
        """Whether samples are int8 counts (MYO): features are then exact integer sums."""
        return self.recording.emg.dtype == np.int8

    @property
    def decoder(self) -> Any:
        """The fitted open/close decoder (on all the recording's channels), or ``None``."""
        return getattr(self.calibration, "decoder", None)

    def to_hand(self, hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N) -> float:
        """The force mapping: hand newtons per estimated user newton."""
        return hand_force_at_mvc_n / self.calibration.mvc_cal_n

    def summary(self) -> dict[str, Any]:
        """JSON-ready description (``decoder``: its name, only when one was fitted)."""
        c = self.calibration
        out = {"file": self.recording.source, "estimator": c.name, "mode": c.mode,
               "channels": "all" if self.channels is None else [str(ch) for ch in self.channels],
               "r2": c.r2, "mvc_cal_n": c.mvc_cal_n, "fit_s": c.fit_s,
               "n_channels": self.n_channels, "fs_hz": self.fs_hz}
        if self.decoder is not None:
            out["decoder"] = getattr(self.decoder, "name", type(self.decoder).__name__)
        return out


def has_open_contractions(recording: Recording) -> bool:
    """Whether ``recording`` has an open-intent label reaching :data:`OPEN_ON` somewhere."""
    opening = recording.open_intent
    return opening is not None and bool(np.any(np.asarray(opening) >= OPEN_ON))


def require_open_contractions(recording: Recording, needed_by: str) -> None:
    """Refuse a calibration without open contractions, in one line.

    Parameters
    ----------
    recording : Recording
        The calibration recording.
    needed_by : str
        What needs them, for the message (``"paradigm velocity"``, ``"decoder pattern"``).

    Raises
    ------
    estimation.decoding.NoOpenContractionsError
        No ``open_intent``, or none reaching :data:`OPEN_ON`: a recording of squeezes only
        (a real one, a lab's CSV, ``griploop calibrate`` without ``--open``).
    """
    if not has_open_contractions(recording):
        raise NoOpenContractionsError(
            f"{recording.source}: {needed_by} needs open contractions, and this calibration "
            "has none (record one with griploop calibrate --open)")


def calibration_decoder(recording: Recording, hand: HandSettings) -> str | None:
    """The open/close decoder a session with ``hand`` fits on ``recording``, checked first.

    The decoder asked for, or the default where the paradigm needs one
    (:attr:`~scenarios.runners.trial_loop.HandSettings.effective_decoder`); ``None``: none.

    Raises
    ------
    estimation.decoding.NoOpenContractionsError
        A decoder is needed and ``recording`` has no open contractions (the message names
        the paradigm that needs them, else the decoder).
    """
    decoder = hand.effective_decoder
    if decoder is not None:
        needed_by = (f"paradigm {hand.paradigm}" if needs_decoder(hand.paradigm)
                     else f"decoder {decoder}")
        require_open_contractions(recording, needed_by)
    return decoder


def squeeze_part(recording: Recording) -> Recording:
    """The squeezes of a calibration recording: before ``metadata["open_from_s"]`` when it
    has open contractions after them, else the whole recording."""
    at = recording.metadata.get("open_from_s")
    if at is None:
        return recording
    n = int(round(float(at) * recording.fs_hz))
    return recording.slice(0, n) if 0 < n < recording.n_samples else recording


def with_open_contractions(squeezes: Recording, opens: Recording) -> Recording:
    """One calibration recording: ``squeezes`` (the paper's session) then ``opens``.

    The layout of ``griploop calibrate --open``'s file, for a virtual subject's two
    sessions (:meth:`~sim.user.subjects.VirtualSubject.paper_session` and
    ``open_session``): series that one of them lacks are 0 there (the pitch is kept only
    when both have one), ``open_intent`` is 0 during the squeezes, and
    ``metadata["open_from_s"]`` is where ``opens`` begins; the metadata is the squeezes',
    with ``opens``' under ``open_session``.

    Raises
    ------
    RecordingError
        Another channel count, rate or sEMG unit.
    """
    a, b = squeezes, opens
    if (a.n_channels, a.fs_hz, a.emg_unit) != (b.n_channels, b.fs_hz, b.emg_unit):
        raise RecordingError(
            f"{b.source} has {b.n_channels} channels at {b.fs_hz:g} Hz in {b.emg_unit} but "
            f"{a.source} has {a.n_channels} at {a.fs_hz:g} Hz in {a.emg_unit}; expected the "
            "same layout for the squeezes and the open contractions")

    def join(name: str, fill_missing: bool = True) -> np.ndarray | None:
        x, y = getattr(a, name, None), getattr(b, name, None)
        if (x is None and y is None) or (not fill_missing and (x is None or y is None)):
            return None
        return np.concatenate([np.zeros(a.n_samples) if x is None else x,
                               np.zeros(b.n_samples) if y is None else y])

    return Recording(emg=np.concatenate([a.emg, b.emg]), fs_hz=a.fs_hz,
                     force_n=join("force_n"), channel_names=list(a.channel_names),
                     emg_unit=a.emg_unit, intent=join("intent"),
                     intent_force_n=join("intent_force_n"),
                     pitch_rad=join("pitch_rad", fill_missing=False),
                     open_intent=join("open_intent"),
                     metadata={**a.metadata, "open_from_s": a.n_samples / a.fs_hz,
                               "open_session": dict(b.metadata)},
                     source=a.source)


def _decoder_labelled(recording: Recording, mvc_cal_n: float) -> Recording:
    """``recording`` with a close intent for the decoder's labels: its own (a virtual
    subject's), else its force over the squeezes' largest (a person's: the force stream's
    reading, or the cue levels)."""
    if recording.intent is not None:
        return recording
    return replace(recording, intent=np.clip(recording.force_n / mvc_cal_n, 0.0, 1.0))


def fit_calibration(recording: Recording, estimator: str = "ridge", *, mode: str = "free_run",
                    channels: Sequence[int | str] | None = PAPER_CHANNELS,
                    order: int = PAPER_ORDER, identification_fraction: float = 0.5,
                    seed: int = 0, decoder: str | None = None) -> RecordedCalibration:
    """Fit ``estimator`` on a calibration recording's first part and score it on the rest.

    With open contractions after the squeezes (``metadata["open_from_s"]``), the estimator
    sees the squeezes only (:func:`squeeze_part`); ``decoder`` is fitted on the whole
    recording, with all its channels.

    Parameters
    ----------
    recording : Recording
        sEMG with the measured force (N); ``open_intent`` for a decoder.
    estimator : str
        A registered estimator (not the oracle: a person's recording has no true force).
    mode : {"free_run", "one_step"}
        The mode it will stream in (a live session runs ``free_run``: sEMG only).
    channels : sequence of int or str, or None
        Channels (1-based numbers or names); ``None``: all. Default: the paper's 6, 7, 8.
    order : int
        State-space order of the estimators that take one.
    identification_fraction : float
        Share of the windows that identify (paper: 0.5).
    seed : int
        Seeds the estimators that draw random numbers (networks, trees).
    decoder : str, optional
        An open/close decoder to fit too (:func:`estimation.decoding.decoder_names`),
        stored as the calibration's ``decoder``; ``None``: none.

    Raises
    ------
    RecordingError
        No force, or no positive force.
    SessionError
        ``estimator`` is the oracle.
    UnsupportedScenarioError, DivergedError
        As :func:`scenarios.runners.calibration.calibrate`.
    estimation.decoding.DecoderCalibrationError
        ``decoder`` on a recording without open contractions
        (:class:`~estimation.decoding.NoOpenContractionsError`), or one whose site never
        rises above its rest level; the message starts with the recording's source.
    """
    if estimator == ORACLE:
        raise SessionError("estimator: the oracle needs the user's true force, which a "
                           "recording of a person does not have; expected a fitted estimator")
    if recording.force_n is None:
        raise RecordingError(
            f"{recording.source}: no force; a calibration recording needs the measured force "
            "(record one with griploop calibrate --lsl)"
        )
    if decoder is not None:
        require_open_contractions(recording, f"decoder {decoder}")
    squeezes = squeeze_part(recording)
    mvc_cal_n = float(np.max(squeezes.force_n))
    if not mvc_cal_n > 0:
        raise RecordingError(f"{recording.source}: force never rises above 0 N; expected the "
                             "calibration squeezes")
    channel_list = None if channels is None else list(channels)
    index = (list(range(recording.n_channels)) if channel_list is None
             else [recording.channel_index(ch) for ch in channel_list])
    features = extract_features(squeezes, channels=channel_list)
    with one_blas_thread():
        cal = fit_on_features(features, estimator, mode, rng=np.random.default_rng(seed),
                              order=order, identification_fraction=identification_fraction,
                              mvc_cal_n=mvc_cal_n)
        if decoder is not None:
            try:
                cal.decoder = fit_decoder(decoder, [_decoder_labelled(recording, mvc_cal_n)])
            except DecoderCalibrationError as exc:
                raise type(exc)(f"{recording.source}: {exc}") from None
    return RecordedCalibration(cal, recording, channel_list, index)
