"""The scenario's virtual user and their calibration session.

Every runner that fits an estimator starts here: the subject of the scenario
(with its electrode shift, extra noise and fatigue) performs the paper's squeeze
protocol with the FSR, and the session's features on the paper's channels are
what the estimator is fitted and scored on.
"""

from __future__ import annotations

import numpy as np

from estimation.features import PAPER_CHANNELS, FeatureSet, extract_features
from scenarios.schema import Scenario
from sim.recording import Recording
from sim.user.intent import IntentProfile, paper_protocol
from sim.user.subjects import VirtualSubject

CALIBRATION_FS_HZ = 200.0


def subject_for(scenario: Scenario) -> VirtualSubject:
    """The scenario's virtual subject, with its electrode shift, noise and fatigue."""
    s = scenario.subject
    return VirtualSubject.sample(s.population_seed, s.subject_id).with_scenario(
        electrode_shift=s.electrode_shift, extra_noise_lsb=s.extra_noise_lsb,
        fatigue_per_min=s.fatigue_per_min)


def calibration_profile(rng: np.random.Generator, *, fs_hz: float,
                        min_duration_s: float | None) -> IntentProfile:
    """The paper's squeeze session, repeated until it lasts at least ``min_duration_s``."""
    parts = [paper_protocol(rng, fs_hz=fs_hz)]
    while min_duration_s is not None and sum(p.duration_s for p in parts) < min_duration_s:
        parts.append(paper_protocol(rng, fs_hz=fs_hz))
    if len(parts) == 1:
        return parts[0]
    cues, offset = [], 0.0
    for p in parts:
        cues += [(kind, t + offset) for kind, t in p.cues]
        offset += p.duration_s
    return IntentProfile(intent=np.concatenate([p.intent for p in parts]), fs_hz=fs_hz,
                         cues=tuple(cues), levels=tuple(v for p in parts for v in p.levels),
                         name=f"paper_protocol x{len(parts)}")


def calibration_session(subject: VirtualSubject, rng: np.random.Generator, *,
                        generator: str = "noise", min_duration_s: float | None = None,
                        window_ms: float = 400.0, step_ms: float = 125.0
                        ) -> tuple[Recording, FeatureSet]:
    """Record the subject's calibration session and extract its features.

    Parameters
    ----------
    subject : VirtualSubject
        The user.
    rng : numpy.random.Generator
        Draws the protocol's timing and levels, then the session's noise.
    generator : {"noise", "motor_units"}
        The sEMG model.
    min_duration_s : float, optional
        Repeat the paper's session until it lasts at least this long, s
        (``None``: one session, about 25-36 s, as
        :meth:`sim.user.subjects.VirtualSubject.paper_session` records it).
    window_ms, step_ms : float
        The feature window and its increment, ms (the paper's 400 and 125).

    Returns
    -------
    recording : Recording
        sEMG at 200 Hz, shape (n_samples, 8), with the FSR force.
    features : FeatureSet
        MAV, RMS and WL of the paper's channels, ``X`` shape (n_windows, 9), ``y`` in N,
        one window every ``step_ms``.
    """
    profile = calibration_profile(rng, fs_hz=CALIBRATION_FS_HZ, min_duration_s=min_duration_s)
    recording = subject.record(profile, generator=generator, fs_hz=CALIBRATION_FS_HZ, rng=rng,
                               rig=True)
    return recording, extract_features(recording, channels=PAPER_CHANNELS, window_ms=window_ms,
                                       step_ms=step_ms)
