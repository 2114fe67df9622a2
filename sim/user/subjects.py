"""Virtual subjects: a seeded population that produces MYO sEMG and FSR force.

A :class:`VirtualSubject` is a frozen set of parameters (anatomy, physiology,
armband fit, FSR device) plus the methods that turn an intent profile into a
:class:`~sim.recording.Recording`:

    intent u(t) (0..1), optionally open intent v(t) (0..1)
      -> target force_m(t) = synergy_m u(t) (1 + eta_m(t))  (grip synergy, slow fluctuation)
      -> + open_synergy_m v(t) (1 + eta_m(t)) for the sEMG's drive (the force's is u's alone)
      -> drive_m(t): inverse of the generator's steady force-drive curve
      -> generator: muscle sEMG s_m(t) and force F_m(t)    ("noise" or "motor_units")
      -> sEMG gain (1 + xi_m(t)): amplitude changes that force does not share
      -> armband: sum_m M[c, m] amplitude_lsb_m s_m + noise -> int8     (crosstalk ring)
      -> grip force = mvc_n sum_m share_m F_m / sum_m share_m synergy_m
      -> contact fraction (1 + zeta(t)) -> FSR 402 -> measured force (N)

``eta``, ``xi`` and ``zeta`` are Ornstein-Uhlenbeck fluctuations.

See docs/SUBJECTS.md for the parameter ranges and which ones set the
estimation difficulty.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim.errors import GriploopError
from sim.recording import Recording
from sim.user.armband import Armband
from sim.user.emg import EmgGenerator, MuscleSignals
from sim.user.fsr import FSR402
from sim.user.generators import (  # noqa: F401  (UnknownGeneratorError re-exported)
    UnknownGeneratorError,
    generator_names,
    make_generator,
)
from sim.user.intent import (
    PROTOCOL_ROUNDS,
    IntentProfile,
    as_rng,
    open_protocol,
    paper_protocol,
)
from sim.user.muscles import (
    MUSCLE_ABBREVIATIONS,
    MUSCLE_ROLES,
    MUSCLES,
    N_MUSCLES,
    OPEN_PATTERN,
    MuscleParams,
    drive_targets,
    muscle_force,
    slow_fluctuation,
    with_opening,
)
from sim.user.populations import apply_variant

# Per-role uniform ranges of the sampled muscle parameters: (low, high).
_SYNERGY = {"flexor": (0.80, 1.00), "extensor": (0.50, 0.78), "other": (0.10, 0.30)}
# sEMG amplitude = drive ** p. Below 1 for the flexors: amplitude cancellation makes
# surface EMG grow less than linearly with drive at high contraction (Keenan et al. 2005,
# J Appl Physiol 98:120); with it a linear fit of force on sEMG is as good as a compressed
# one, as on the real recordings (shared/REAL_RECORDINGS.md: RIDGE's square root gains
# 0.003 over a linear MAV fit there).
_EXPONENT = {"flexor": (0.68, 1.08), "extensor": (0.78, 1.38), "other": (0.78, 1.58)}
_AMPLITUDE_LSB = {"flexor": (22.0, 34.0), "extensor": (20.0, 35.0), "other": (15.0, 30.0)}
# Subject-level log-uniform factors: overall sEMG size (all muscles) and extensor
# co-contraction (extensor amplitudes on top of size). Real recordings (docs/SUBJECTS.md):
# active RMS varies about 5x across subjects, flexor/extensor RMS ratio about 1.
_AMPLITUDE_SCALE = (0.40, 2.5)
_EXTENSOR_SCALE = (1.8, 3.6)
_CROSSTALK_LENGTH = (0.45, 0.75)  # electrode spacings
_NOISE_LSB = (1.05, 4.6)  # log-uniform; real rest std 1.0-4.7 LSB
_MUAP_WIDTH_MS = (1.4, 1.7)
# What the real recordings of the protocol show beyond the sEMG statistics (docs/SUBJECTS.md,
# "Against the real recordings' estimation verdicts"):
_CONTACT_STD = (0.08, 0.12)  # FSR contact fluctuation: real persistence R^2 0.969 at 125 ms
_CONTACT_TIME_S = (0.2, 0.4)
_CARRIER_LAPLACE = (0.6, 1.0)  # sEMG amplitude distribution between Gaussian and Laplacian
_COCONTRACTION_DRIFT = (0.15, 0.35)  # squeeze-to-squeeze variation of co-contraction
_NOISE_DRIFT = (0.3, 0.6)  # log-SD of the electrode noise-floor drift
_ARTIFACT_PROBABILITY = 0.3  # share of sessions with a loose electrode
_ARTIFACT_RATE_HZ = (0.1, 0.6)  # log-uniform, when there is one
_RIG_LAG_S = (0.0, 0.15)  # sEMG stream behind the FSR stream in the recording rig
# Motor-unit MUAP-size exponent gamma that gives, with the default pool, about
# the same log-log sEMG-force slope over 3-100 % MVC as ``amplitude_exponent``
# p in the noise generator (measured: p = 0.16 + 0.77 gamma for gamma in 0.3..1.6).
_MUAP_EXPONENT_FIT = (0.16, 0.77)
# Second word of a subject's SeedSequence spawn keys: 0 its parameters, 1 its sessions
# (session_rng), 2 the population variants (sim.user.populations), 3 its opening pattern,
# 4 its open session.
_OPEN_SYNERGY_STREAM = 3
_OPEN_SESSION_STREAM = 4


class SubjectParamsError(GriploopError, ValueError):
    """A virtual subject's own parameters (rig lag, FSR contact) are out of range."""


class OpenIntentError(GriploopError, ValueError):
    """An open intent that cannot be recorded (shape, or a generator without it)."""


@dataclass(frozen=True)
class VirtualSubject:
    """One virtual subject: parameters and the methods that record from them.

    Parameters
    ----------
    subject_id : int
        1-based number within the population.
    seed : int
        Population seed; with ``subject_id`` it determines every parameter
        and the default session noise.
    mvc_n : float
        Maximum voluntary grip force in newtons (30-50 N, inside the FSR range).
    muscles : MuscleParams
        Per-muscle physiology (synergy, nonlinearity, EMD, dynamics, MUAPs).
    armband : Armband
        Electrode ring fit: crosstalk, shift, noise, contact gains.
    fsr : FSR402
        The subject's force sensor (device spread).
    contact_std : float
        Relative std of the fluctuating fraction of grip force that loads the
        FSR inside the soft ball (finger and ball contact shifting under the
        sensor); seen by the FSR only, not by the sEMG.
    contact_time_s : float
        Correlation time of that fraction, seconds.
    rig_lag_s : float
        Latency of the sEMG stream behind the FSR stream in the calibration rig (MYO over
        Bluetooth and the FSR over the Arduino's serial line, logged by one PC), seconds.
        Applied to calibration sessions (:meth:`paper_session`, ``record(rig=True)``), not
        to the prosthesis' own sEMG path.
    protocol_rounds : int
        Rounds of three squeezes this subject's calibration sessions hold
        (:meth:`paper_session`; the real recordings hold two, 6-9 squeezes).
    """

    subject_id: int
    seed: int
    mvc_n: float
    muscles: MuscleParams
    armband: Armband = field(default_factory=Armband)
    fsr: FSR402 = field(default_factory=FSR402)
    contact_std: float = 0.23
    contact_time_s: float = 0.15
    rig_lag_s: float = 0.0
    protocol_rounds: int = PROTOCOL_ROUNDS

    def __post_init__(self) -> None:
        if not 0.0 <= self.rig_lag_s <= 2.0 or self.contact_std < 0 or self.contact_time_s <= 0 \
                or int(self.protocol_rounds) != self.protocol_rounds or self.protocol_rounds < 1:
            raise SubjectParamsError(
                f"VirtualSubject: expected rig_lag_s in 0..2 s, contact_std >= 0, "
                f"contact_time_s > 0 and protocol_rounds >= 1, found {self.rig_lag_s}, "
                f"{self.contact_std}, {self.contact_time_s}, {self.protocol_rounds}")

    # -------------------------------------------------------------- creation
    @classmethod
    def sample(cls, seed: int, subject_id: int) -> VirtualSubject:
        """Draw a subject's parameters from ``SeedSequence(seed, spawn_key=(subject_id, 0))``.

        The opening pattern (``MuscleParams.open_synergy``,
        :data:`~sim.user.muscles.OPEN_PATTERN`) comes from a stream of its own,
        ``spawn_key=(subject_id, 3)``, so every other parameter keeps
        the value it had before the open intent existed.
        """
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(subject_id, 0)))
        # the opening pattern from a stream of its own: every draw below keeps its value
        open_rng = np.random.default_rng(np.random.SeedSequence(
            seed, spawn_key=(subject_id, _OPEN_SYNERGY_STREAM)))
        open_synergy = tuple(float(open_rng.uniform(*OPEN_PATTERN[m])) for m in MUSCLES)

        def per_role(table: dict[str, tuple[float, float]]) -> tuple[float, ...]:
            return tuple(float(rng.uniform(*table[role])) for role in MUSCLE_ROLES)

        flexor = np.array([role == "flexor" for role in MUSCLE_ROLES])
        extensor = np.array([role == "extensor" for role in MUSCLE_ROLES])
        share = np.where(flexor, rng.uniform(0.7, 1.3, N_MUSCLES), 0.0)
        synergy = per_role(_SYNERGY)
        exponent = per_role(_EXPONENT)
        # Subject-level factors that make people differ (real recordings, docs/SUBJECTS.md):
        # overall sEMG size (skin, fat, forearm girth) and extensor co-contraction.
        size = float(np.exp(rng.uniform(*np.log(_AMPLITUDE_SCALE))))
        cocontraction = float(np.exp(rng.uniform(*np.log(_EXTENSOR_SCALE))))
        amplitude = np.array(per_role(_AMPLITUDE_LSB)) * size
        amplitude[extensor] *= cocontraction
        muscles = MuscleParams(
            synergy=synergy,
            grip_share=tuple(float(v) for v in share),
            amplitude_exponent=exponent,
            amplitude_lsb=tuple(float(v) for v in amplitude),
            emd_s=tuple(float(v) for v in rng.uniform(0.04, 0.14, N_MUSCLES)),
            activation_cutoff_hz=(float(rng.uniform(2.5, 3.5)),) * N_MUSCLES,
            muap_width_ms=tuple(float(v) for v in rng.uniform(*_MUAP_WIDTH_MS, N_MUSCLES)),
            muap_exponent=tuple((p - _MUAP_EXPONENT_FIT[0]) / _MUAP_EXPONENT_FIT[1]
                                for p in exponent),
            fluctuation_std=tuple(float(v) for v in rng.uniform(0.05, 0.12, N_MUSCLES)),
            fluctuation_time_s=float(rng.uniform(0.3, 1.0)),
            emg_gain_std=tuple(float(v) for v in rng.uniform(0.45, 0.60, N_MUSCLES)),
            emg_gain_time_s=float(rng.uniform(0.1, 0.3)),
            anatomy_seed=int(rng.integers(2**31)),
        )
        armband = Armband(
            crosstalk_length=float(rng.uniform(*_CROSSTALK_LENGTH)),
            noise_lsb=float(np.exp(rng.uniform(*np.log(_NOISE_LSB)))),
            channel_gain=tuple(float(v) for v in np.exp(0.1 * rng.standard_normal(N_MUSCLES))),
        )
        mvc_n = float(rng.uniform(30.0, 50.0))
        fsr = FSR402.sample(rng)
        contact_std = float(rng.uniform(*_CONTACT_STD))
        contact_time_s = float(rng.uniform(*_CONTACT_TIME_S))
        # drawn last, so that the parameters above keep their draws
        muscles = dataclasses.replace(
            muscles, carrier_laplace=float(rng.uniform(*_CARRIER_LAPLACE)),
            cocontraction_drift_std=float(rng.uniform(*_COCONTRACTION_DRIFT)),
            open_synergy=open_synergy)
        loose = rng.random() < _ARTIFACT_PROBABILITY
        rate = float(np.exp(rng.uniform(*np.log(_ARTIFACT_RATE_HZ))))
        armband = dataclasses.replace(
            armband, noise_drift_std=float(rng.uniform(*_NOISE_DRIFT)),
            artifact_rate_hz=rate if loose else 0.0)
        return cls(
            subject_id=int(subject_id),
            seed=int(seed),
            mvc_n=mvc_n,
            muscles=muscles,
            armband=armband,
            fsr=fsr,
            contact_std=contact_std,
            contact_time_s=contact_time_s,
            rig_lag_s=float(rng.uniform(*_RIG_LAG_S)),
        )

    def with_scenario(
        self,
        *,
        electrode_shift: float | None = None,
        extra_noise_lsb: float | None = None,
        fatigue_per_min: float | None = None,
    ) -> VirtualSubject:
        """The same subject under a scenario: band rotated, extra noise, fatigue.

        Parameters
        ----------
        electrode_shift : float, optional
            Band rotation in electrode spacings (e.g. 0.5 = half a spacing).
        extra_noise_lsb : float, optional
            Additional sEMG noise std in counts.
        fatigue_per_min : float, optional
            Fractional median-frequency fall per minute (amplitude rises 2x that).
        """
        armband = self.armband
        muscles = self.muscles
        if electrode_shift is not None:
            armband = dataclasses.replace(armband, electrode_shift=float(electrode_shift))
        if extra_noise_lsb is not None:
            armband = dataclasses.replace(armband, extra_noise_lsb=float(extra_noise_lsb))
        if fatigue_per_min is not None:
            muscles = dataclasses.replace(muscles, fatigue_per_min=float(fatigue_per_min))
        return dataclasses.replace(self, armband=armband, muscles=muscles)

    # -------------------------------------------------------------- metadata
    def session_rng(self, session: int = 1) -> np.random.Generator:
        """The subject's reproducible stream for session number ``session``:
        ``SeedSequence(seed, spawn_key=(subject_id, session))``. Session 1 is the default
        of :meth:`record` and :meth:`paper_session`; keys 2-4 are other streams of the
        subject (population variants, opening pattern, :meth:`open_session`)."""
        return np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(self.subject_id, int(session)))
        )

    def channel_muscles(self) -> list[str]:
        """Name of the muscle nearest each electrode (changes with electrode shift)."""
        return [MUSCLES[m] for m in self.armband.nearest_muscles()]

    def params(self) -> dict[str, Any]:
        """Every parameter, JSON-ready."""
        armband = dataclasses.asdict(self.armband)
        armband["channel_gain"] = list(self.armband.channel_gain)
        return {
            "subject_id": self.subject_id,
            "seed": self.seed,
            "mvc_n": self.mvc_n,
            "muscles": self.muscles.to_dict(),
            "armband": armband,
            "fsr": self.fsr.to_dict(),
            "contact_std": self.contact_std,
            "contact_time_s": self.contact_time_s,
            "rig_lag_s": self.rig_lag_s,
            "protocol_rounds": self.protocol_rounds,
        }

    # -------------------------------------------------------------- recording
    def drive(
        self,
        intent: np.ndarray,
        fs_hz: float,
        rng: np.random.Generator,
        generator: str | EmgGenerator = "noise",
        open_intent: np.ndarray | None = None,
    ) -> np.ndarray:
        """Neural drive per muscle, shape (n_samples, n_muscles), 0..1.

        Each muscle aims at the force ``target_m = synergy_m u (1 + eta_m)``
        (``eta_m`` an independent Ornstein-Uhlenbeck fluctuation; the muscles that do not
        grip also vary their co-contraction slowly, ``cocontraction_drift_std``, and follow
        ``u ** cocontraction_power``, 1 in the default population:
        :func:`sim.user.muscles.drive_targets`); the drive
        is the inverse of the generator's steady force-drive curve at that
        target (identity for the noise generator, the convex recruitment and
        rate-coding curve for motor units), clipped to 0..1. With an ``open_intent``
        ``v`` (shape (n_samples,), 0..1) every target gains ``open_synergy_m v (1 + eta_m)``
        (:func:`sim.user.muscles.with_opening`); ``None`` draws and computes exactly what
        it did before the open intent existed.
        """
        return self._drives(intent, fs_hz, rng, generator, open_intent)[0]

    def _drives(self, intent: np.ndarray, fs_hz: float, rng: np.random.Generator,
                generator: str | EmgGenerator, open_intent: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray]:
        """The drive of both intents and that of the close intent alone (the same array
        without an open intent), each (n_samples, n_muscles)."""
        gen = make_generator(generator)
        u = np.clip(np.asarray(intent, dtype=float), 0.0, 1.0)
        eta = slow_fluctuation(u.size, fs_hz, self.muscles.array("fluctuation_std"),
                               self.muscles.fluctuation_time_s, rng)
        drift = None
        if self.muscles.cocontraction_drift_std > 0:
            # co-contraction of the muscles that do not grip varies from squeeze to squeeze
            others = self.muscles.array("grip_share") == 0
            std = np.full(int(others.sum()), self.muscles.cocontraction_drift_std)
            drift = slow_fluctuation(u.size, fs_hz, std, self.muscles.cocontraction_drift_time_s,
                                     rng)
        one_eta = 1.0 + eta
        close = drive_targets(self.muscles, u, one_eta, drift)
        grid = np.repeat(np.linspace(0.0, 1.0, 257)[:, None], N_MUSCLES, axis=1)
        curve = np.maximum.accumulate(gen.steady_force(grid, self.muscles), axis=0)

        def inverse(target: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(target[:, m], curve[:, m], grid[:, m])
                             for m in range(N_MUSCLES)], axis=1)

        close_drive = inverse(close)
        if open_intent is None:
            return close_drive, close_drive
        v = np.clip(np.asarray(open_intent, dtype=float), 0.0, 1.0)
        if v.shape != u.shape:
            raise OpenIntentError(f"open intent: expected shape {u.shape} like the intent, "
                                  f"found {v.shape}")
        return inverse(with_opening(self.muscles, close, v, one_eta)), close_drive

    def record(
        self,
        profile: IntentProfile,
        *,
        generator: str | EmgGenerator = "noise",
        fs_hz: float = 200.0,
        rng: np.random.Generator | int | None = None,
        rig: bool = False,
    ) -> Recording:
        """Record sEMG and FSR force while the subject follows ``profile``.

        With the profile's ``open_intent`` the sEMG comes from the drive of both intents
        and the muscle force that loads the grip (and the FSR) from the drive of the close
        intent alone: an opening contraction extends the digits and presses nothing. The
        noise generator's force is a function of the drive alone
        (:func:`sim.user.muscles.muscle_force`), so it is computed for that drive without
        a draw; the motor-unit pool's is not, and an open intent is refused for it.

        Parameters
        ----------
        profile : IntentProfile
            Intended grip force (0..1 of MVC) and, optionally, intended opening; resampled
            to ``fs_hz`` if needed.
        generator : {"noise", "motor_units"} or EmgGenerator
            The sEMG model.
        fs_hz : float
            MYO sampling rate in hertz.
        rng : numpy.random.Generator, int or None
            Session noise; ``None`` uses :meth:`session_rng` (reproducible).
        rig : bool
            Recorded by the calibration rig: the sEMG stream lags the FSR stream by
            ``rig_lag_s`` (its first sample held before).

        Returns
        -------
        Recording
            ``emg`` int8 (n_samples, 8); ``force_n`` FSR reading (N);
            ``intent`` (0..1); ``intent_force_n`` true grip force (N); ``open_intent``
            (0..1) when the profile has one; metadata with subject id, seed, generator,
            muscles per channel, mvc_n, cues, saturation count and every parameter.

        Raises
        ------
        OpenIntentError
            An open intent with a generator other than the noise generator.
        """
        gen = make_generator(generator)
        g = self.session_rng() if rng is None else as_rng(rng)
        prof = profile.resampled(fs_hz)
        opening = prof.open_intent
        drive, out = self._muscle_signals(prof, gen, fs_hz, g)
        xi = slow_fluctuation(drive.shape[0], fs_hz, self.muscles.array("emg_gain_std"),
                              self.muscles.emg_gain_time_s, g)
        gain = np.clip(1.0 + xi, 0.0, None)
        muscle_lsb = out.emg * gain * self.muscles.array("amplitude_lsb")
        emg, n_sat = self.armband.digitize(muscle_lsb, g, fs_hz=fs_hz)
        lag = int(round(self.rig_lag_s * fs_hz)) if rig else 0
        if 0 < lag < emg.shape[0]:
            emg = np.concatenate([np.repeat(emg[:1], lag, axis=0), emg[:-lag]])
        share = self.muscles.array("grip_share")
        grip_n = self.mvc_n * (out.force @ share) / float(self.muscles.array("synergy") @ share)
        contact = 1.0 + slow_fluctuation(grip_n.size, fs_hz, np.array([self.contact_std]),
                                         self.contact_time_s, g)[:, 0]
        force_n = self.fsr.measure(grip_n * np.clip(contact, 0.0, None), g)
        metadata = {**self._provenance(gen, prof), "n_saturated": n_sat,
                    "rig_lag_s": lag / fs_hz, "generator_info": out.info,
                    "params": self.params()}
        return Recording(
            emg=emg,
            fs_hz=fs_hz,
            force_n=force_n,
            channel_names=[f"emg{i + 1}" for i in range(emg.shape[1])],
            emg_unit="int8",
            intent=prof.intent,
            intent_force_n=grip_n,
            open_intent=None if opening is None else np.clip(opening, 0.0, 1.0),
            metadata=metadata,
            source=f"subject{self.subject_id:02d}",
        )

    def _provenance(self, gen: EmgGenerator, prof: IntentProfile) -> dict[str, Any]:
        """:meth:`record`'s metadata about who recorded what, in its order."""
        return {"subject_id": self.subject_id, "seed": self.seed, "generator": gen.name,
                "generator_params": gen.params(), "muscles_per_channel": self.channel_muscles(),
                "muscle_abbreviations": list(MUSCLE_ABBREVIATIONS), "mvc_n": self.mvc_n,
                "profile": prof.to_metadata(), "cues": [[k, float(t)] for k, t in prof.cues]}

    def _muscle_signals(self, prof: IntentProfile, gen: EmgGenerator, fs_hz: float,
                        g: np.random.Generator) -> tuple[np.ndarray, MuscleSignals]:
        """:meth:`record`'s drive (both intents) and the generator's muscle signals, whose
        force is the close intent's alone when the profile has an open intent."""
        opening = prof.open_intent
        if opening is not None:
            from sim.user.emg_noise import NoiseEmgGenerator
            if not isinstance(gen, NoiseEmgGenerator):
                raise OpenIntentError(
                    f"sEMG generator {gen.name} cannot record open contractions (its force is "
                    "not a function of the drive alone); expected the noise generator")
        drive, close_drive = self._drives(prof.intent, fs_hz, g, gen, opening)
        out = gen.generate(drive, self.muscles, self.armband.front_end, fs_hz=fs_hz, rng=g)
        if opening is not None:
            # an opening presses nothing: the grip's muscle force is the close drive's
            out = dataclasses.replace(out, force=muscle_force(
                np.clip(close_drive, 0.0, None), fs_hz,
                self.muscles.array("activation_cutoff_hz"), self.muscles.array("emd_s")))
        return drive, out

    def paper_session(
        self,
        rng: np.random.Generator | int | None = None,
        *,
        generator: str | EmgGenerator = "noise",
        fs_hz: float = 200.0,
        rounds: int | None = None,
    ) -> Recording:
        """A whole paper-protocol calibration session (two rounds, about 45-75 s), by the rig.

        The protocol's timing and levels and the session noise both come from
        ``rng`` (``None``: the subject's reproducible :meth:`session_rng`); ``rounds``
        defaults to the subject's :attr:`protocol_rounds`.
        """
        g = self.session_rng() if rng is None else as_rng(rng)
        rounds = self.protocol_rounds if rounds is None else rounds
        profile = paper_protocol(g, fs_hz=fs_hz, rounds=rounds)
        return self.record(profile, generator=generator, fs_hz=fs_hz, rng=g, rig=True)

    def open_session(
        self,
        rng: np.random.Generator | int | None = None,
        *,
        generator: str | EmgGenerator = "noise",
        fs_hz: float = 200.0,
    ) -> Recording:
        """A session of opening contractions (:func:`sim.user.intent.open_protocol`), by
        the rig: the calibration a hand that opens on a second signal adds to the paper's.

        ``rng`` draws the protocol's timing, then the session's noise; ``None`` uses the
        subject's own stream for it (:meth:`open_session_rng`), apart from
        :meth:`session_rng`'s, so :meth:`paper_session` keeps its numbers. The recording's
        ``open_intent`` labels the contractions; its ``intent`` is 0 and its grip force
        the rest level.
        """
        g = self.open_session_rng() if rng is None else as_rng(rng)
        profile = open_protocol(g, fs_hz=fs_hz)
        return self.record(profile, generator=generator, fs_hz=fs_hz, rng=g, rig=True)

    def open_session_rng(self) -> np.random.Generator:
        """The subject's reproducible stream for :meth:`open_session`:
        ``SeedSequence(seed, spawn_key=(subject_id, 4))``."""
        return np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(self.subject_id, _OPEN_SESSION_STREAM)))


def make_population(n: int = 10, seed: int = 0, *,
                    variant: str = "default") -> list[VirtualSubject]:
    """``n`` distinct virtual subjects, numbered 1..n, reproducible from ``seed``.

    ``variant`` names another population (:mod:`sim.user.populations`: ``"wide"`` draws
    the band's placement, co-contraction and the protocol's rounds from wider ranges, to
    judge an estimator that learned from the default one out of population).

    Raises
    ------
    ValueError
        If ``n < 1``.
    sim.user.populations.UnknownPopulationError
        An unregistered ``variant``.
    """
    if int(n) < 1:
        raise ValueError(f"population size must be at least 1, found {n}")
    subjects = [VirtualSubject.sample(int(seed), i) for i in range(1, int(n) + 1)]
    return subjects if variant == "default" else apply_variant(subjects, int(seed), variant)


def __getattr__(attr: str) -> Any:
    if attr == "GENERATORS":  # the generator names registered so far (sim.user.generators)
        return generator_names()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")
