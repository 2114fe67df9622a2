"""Forearm muscles under the MYO band and their drive-to-force physiology.

The eight MYO channels sit over the muscles of the paper's electrode table
(Table 1): 1 pronator teres ... 8 flexor carpi radialis. This module holds
that table, the per-subject muscle parameters (:class:`MuscleParams`) and the
signal-level building blocks shared by both sEMG generators:

* activation dynamics: a critically damped second-order low-pass (about
  3 Hz, tau about 50 ms) from neural drive to muscle force;
* electromechanical delay (EMD, 40-140 ms): force lags the sEMG;
* slow drive fluctuations (Ornstein-Uhlenbeck), the per-muscle
  non-stationarity that keeps sEMG and force from being a fixed map.

Two intents drive the muscles: closing (grip force, the paper's only one, through
``MuscleParams.synergy``) and opening (finger extension, through
``MuscleParams.open_synergy``, :data:`OPEN_PATTERN`). The opening pattern follows the
published one qualitatively: the extensor digitorum communis (channel 4) is the prime mover
of finger extension, the wrist extensors (carpi radialis and ulnaris, channels 3 and 5)
stabilize the wrist, and the flexors stay co-active at a low level. Extrinsic finger
muscles work in a reciprocal agonist/antagonist pattern in which no muscle is ever silent,
and truly co-contract only in resisted grasp (an electromyographic study of the extrinsic
finger muscles in resisted grasp, finger extension and grasp-release: "Activity analysis:
electromyographic and electrogoniometric verification", Am J Occup Ther). Hand opening is
one of the movements NinaPro DB5 records with two MYO armbands on the forearm (Pizzolato et
al. 2017, PLoS ONE 12:e0186132). **The numeric ranges of** :data:`OPEN_PATTERN` **are
griploop's choice within that pattern, not measured values**: no source we hold gives
per-muscle amplitudes of an opening contraction under a MYO band.

Both patterns model the paper's able-bodied forearms. A residual limb (transradial
amputation) differs: its extrinsic muscles are shortened, scarred and partly reattached
(myodesis, myoplasty); contractions are efforts of a phantom hand without proprioceptive
feedback; amplitudes are lower, open and close patterns less separable, and the sites
shift with the socket's loading (docs/SUBJECTS.md, "Opening").
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from sim.errors import GriploopError

MUSCLES = (
    "pronator_teres",
    "brachioradialis",
    "extensor_carpi_radialis",
    "extensor_digitorum_communis",
    "extensor_carpi_ulnaris",
    "flexor_carpi_ulnaris",
    "palmaris_longus",
    "flexor_carpi_radialis",
)
"""Muscle under each MYO channel 1..8 (paper Table 1)."""

MUSCLE_ABBREVIATIONS = ("PT", "BR", "ECR", "EDC", "ECU", "FCU", "PL", "FCR")
MUSCLE_ROLES = ("other", "other", "extensor", "extensor", "extensor", "flexor", "flexor", "flexor")
"""Role in the grip synergy: flexors drive grip, extensors co-contract, others weakly."""

N_MUSCLES = len(MUSCLES)

OPEN_PATTERN = {
    "extensor_digitorum_communis": (0.85, 1.00),
    "extensor_carpi_radialis": (0.45, 0.80),
    "extensor_carpi_ulnaris": (0.45, 0.80),
    "flexor_carpi_ulnaris": (0.08, 0.30),
    "palmaris_longus": (0.08, 0.30),
    "flexor_carpi_radialis": (0.08, 0.30),
    "pronator_teres": (0.05, 0.25),
    "brachioradialis": (0.05, 0.25),
}
"""Drive of each muscle per unit open intent: the uniform range each subject's
``open_synergy`` is drawn from (:meth:`sim.user.subjects.VirtualSubject.sample`).

Extensor digitorum communis, the prime mover of finger extension, 0.85-1.0; the wrist
extensors that stabilize the wrist 0.45-0.80; the flexors, antagonists co-active at a low
level (never silent), 0.08-0.30; pronator teres and brachioradialis 0.05-0.25. The pattern
is the published one (module docstring); the numbers are griploop's choice within it, not
measured values.
"""


class MuscleParamsError(GriploopError, ValueError):
    """Per-muscle parameters have the wrong length or an out-of-range value."""


@dataclass(frozen=True)
class MuscleParams:
    """Per-muscle physiology of one subject; every tuple has one entry per muscle.

    Parameters
    ----------
    synergy : tuple of float
        Neural drive of each muscle per unit grip intent (0..1): the grip
        synergy. Flexors about 0.8-1, co-contracting extensors 0.35-0.65,
        other muscles 0.1-0.3.
    grip_share : tuple of float
        Relative contribution of each muscle's force to grip force (flexors
        only in the default population).
    amplitude_exponent : tuple of float
        EMG amplitude = drive ** exponent while force follows drive linearly
        (noise generator): 1 is linear, > 1 curvilinear.
    amplitude_lsb : tuple of float
        sEMG RMS in MYO counts (LSB) that the muscle produces on an electrode
        directly above it at full drive (after the front end).
    emd_s : tuple of float
        Electromechanical delay in seconds (40-140 ms).
    activation_cutoff_hz : tuple of float
        Corner frequency of the critically damped activation dynamics (Hz).
    muap_width_ms : tuple of float
        Characteristic MUAP width (Gaussian sigma, ms); sets the sEMG spectrum.
    muap_exponent : tuple of float
        Motor-unit generator: MUAP amplitude grows as twitch force ** exponent
        (sets that generator's EMG-force curvature).
    fluctuation_std : tuple of float
        Relative std of the slow multiplicative drive fluctuation.
    fluctuation_time_s : float
        Correlation time of that fluctuation, seconds.
    emg_gain_std : tuple of float
        Relative std of a multiplicative sEMG amplitude fluctuation that
        leaves force unchanged (muscle moving under the electrode, skin
        impedance): with the FSR contact fluctuation, the main source of
        estimation error.
    emg_gain_time_s : float
        Correlation time of that fluctuation, seconds.
    fatigue_per_min : float
        Fatigue rate: per minute of recording the median frequency falls by
        this fraction and the sEMG amplitude rises by twice it (0 = none).
    carrier_laplace : float
        Noise generator: shape of the sEMG's amplitude distribution, from Gaussian (0)
        to Laplacian (1), as a Gaussian scale mixture. Surface EMG lies between the two,
        nearer the Laplacian at low and moderate contraction (Clancy & Hogan 1999, IEEE
        TBME 46:730; Nazarpour et al. 2013, IEEE TBME 60:1418); it makes RMS features
        noisier than MAV features.
    cocontraction_drift_std : float
        Relative std of a slow fluctuation of the drive of the muscles that do not
        contribute to grip (antagonists and stabilizers): co-contraction varies from one
        squeeze to the next while the grip does not. 0 = a fixed synergy.
    cocontraction_drift_time_s : float
        Correlation time of that fluctuation, seconds.
    cocontraction_power : float
        How steeply the muscles that do not grip join in with grip force: their mean drive
        target is ``synergy_m u ** cocontraction_power`` (1, the default population's: in
        proportion to the intent ``u``; above 1 they stay quiet in light squeezes and
        stiffen the wrist in strong ones). The ``wide`` population
        (``sim.user.populations``) draws it.
    anatomy_seed : int
        Seed of the subject's fixed motor-unit anatomy (MUAP shapes, sizes),
        so that every session of a subject uses the same motor units.
    open_synergy : tuple of float
        Neural drive of each muscle per unit *open* intent (0..1): the pattern of an
        opening contraction (finger extension), :data:`OPEN_PATTERN`. All zero: a
        subject who never opens (the default of a hand-made parameter set).
    """

    synergy: tuple[float, ...]
    grip_share: tuple[float, ...]
    amplitude_exponent: tuple[float, ...]
    amplitude_lsb: tuple[float, ...]
    emd_s: tuple[float, ...]
    activation_cutoff_hz: tuple[float, ...]
    muap_width_ms: tuple[float, ...]
    muap_exponent: tuple[float, ...]
    fluctuation_std: tuple[float, ...]
    emg_gain_std: tuple[float, ...] = (0.0,) * N_MUSCLES
    fluctuation_time_s: float = 1.0
    emg_gain_time_s: float = 0.5
    fatigue_per_min: float = 0.0
    carrier_laplace: float = 0.0
    cocontraction_drift_std: float = 0.0
    cocontraction_drift_time_s: float = 8.0
    cocontraction_power: float = 1.0
    anatomy_seed: int = 0
    open_synergy: tuple[float, ...] = (0.0,) * N_MUSCLES

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, tuple):
                if len(value) != N_MUSCLES:
                    raise MuscleParamsError(
                        f"MuscleParams.{f.name}: expected {N_MUSCLES} values, found {len(value)}"
                    )
                if not all(np.isfinite(v) and v >= 0 for v in value):
                    raise MuscleParamsError(
                        f"MuscleParams.{f.name}: expected finite non-negative values, "
                        f"found {value}"
                    )
        if sum(self.grip_share) <= 0:
            raise MuscleParamsError("MuscleParams.grip_share: expected a positive sum, found 0")
        if self.fatigue_per_min < 0 or min(self.fluctuation_time_s, self.emg_gain_time_s,
                                           self.cocontraction_drift_time_s) <= 0:
            raise MuscleParamsError(
                "MuscleParams: expected fatigue_per_min >= 0 and positive correlation times, "
                f"found {self.fatigue_per_min}, {self.fluctuation_time_s}, "
                f"{self.emg_gain_time_s}, {self.cocontraction_drift_time_s}"
            )
        if not 0.0 <= self.carrier_laplace <= 1.0 or self.cocontraction_drift_std < 0 \
                or not 1.0 <= self.cocontraction_power <= 5.0:
            raise MuscleParamsError(
                "MuscleParams: expected carrier_laplace in 0..1, cocontraction_drift_std "
                f">= 0 and cocontraction_power in 1..5, found {self.carrier_laplace}, "
                f"{self.cocontraction_drift_std}, {self.cocontraction_power}"
            )

    def array(self, name: str) -> np.ndarray:
        """One per-muscle parameter as a float array of shape (n_muscles,)."""
        return np.asarray(getattr(self, name), dtype=float)

    def to_dict(self) -> dict[str, list[float] | float]:
        """JSON-ready parameters (tuples become lists)."""
        return {
            f.name: list(getattr(self, f.name))
            if isinstance(getattr(self, f.name), tuple)
            else getattr(self, f.name)
            for f in fields(self)
        }


def activation_dynamics(
    drive: np.ndarray, fs_hz: float, cutoff_hz: np.ndarray | float
) -> np.ndarray:
    """Critically damped second-order low-pass from neural drive to force.

    Two identical first-order lags with time constant ``1 / (2 pi cutoff_hz)``
    in cascade, each discretized exactly for a zero-order-held input; unit DC
    gain, no overshoot. Columns sharing a cutoff are filtered in one call.

    Parameters
    ----------
    drive : ndarray, shape (n_samples, n_muscles)
        Neural drive (0..1).
    fs_hz : float
        Sampling rate in hertz.
    cutoff_hz : float or ndarray, shape (n_muscles,)
        Corner frequency per muscle in hertz (about 3 Hz).

    Returns
    -------
    ndarray, shape (n_samples, n_muscles)
        Normalized muscle force, starting from rest at the first drive value.
    """
    import scipy.signal
    x = np.asarray(drive, dtype=float)
    cut = np.broadcast_to(np.asarray(cutoff_hz, dtype=float), (x.shape[1],))
    levels = np.unique(cut)
    out = None if levels.size == 1 else np.empty_like(x)
    for fc in levels:
        cols = slice(None) if out is None else np.flatnonzero(cut == fc)
        r = float(np.exp(-2.0 * np.pi * fc / fs_hz))
        b, a = [(1.0 - r) ** 2], [1.0, -2.0 * r, r * r]
        # direct-form-II-transposed state of a filter resting at the first value x0
        x0 = x[0, cols]
        zi = np.stack([x0 * (2.0 * r - r * r), -r * r * x0], axis=0)
        y = scipy.signal.lfilter(b, a, x[:, cols], axis=0, zi=zi)[0]
        if out is None:
            return y
        out[:, cols] = y
    return out


def muscle_force(
    drive: np.ndarray, fs_hz: float, cutoff_hz: np.ndarray | float, emd_s: np.ndarray | float
) -> np.ndarray:
    """Neural drive to normalized force: electromechanical delay, then activation dynamics.

    Parameters
    ----------
    drive : ndarray, shape (n_samples, n_muscles)
        Neural drive (0..1).
    fs_hz : float
        Sampling rate in hertz.
    cutoff_hz : float or ndarray, shape (n_muscles,)
        Activation corner frequency in hertz (about 3 Hz).
    emd_s : float or ndarray, shape (n_muscles,)
        Electromechanical delay in seconds (40-140 ms).

    Returns
    -------
    ndarray, shape (n_samples, n_muscles)
    """
    return activation_dynamics(fractional_delay(drive, emd_s, fs_hz), fs_hz, cutoff_hz)


def fractional_delay(x: np.ndarray, delay_s: np.ndarray | float, fs_hz: float) -> np.ndarray:
    """Delay every column by its own (fractional) time, holding the first value.

    Parameters
    ----------
    x : ndarray, shape (n_samples, n_columns)
    delay_s : float or ndarray, shape (n_columns,)
        Non-negative delays in seconds; linear interpolation between samples.
    fs_hz : float
        Sampling rate in hertz.

    Returns
    -------
    ndarray, shape (n_samples, n_columns)
        ``y[k, j] = x(t_k - delay_s[j])``.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    d = np.broadcast_to(np.asarray(delay_s, dtype=float), (x.shape[1],)) * fs_hz
    out = np.empty_like(x)
    for j, dj in enumerate(d):
        w = int(np.floor(dj))
        f = float(dj - w)
        out[: min(w, n), j] = x[0, j]
        if w >= n:
            continue
        # y[k] = (1 - f) x[k - w] + f x[k - w - 1], with x[i < 0] = x[0]
        out[w:, j] = (1.0 - f) * x[: n - w, j]
        if f > 0:
            out[w + 1:, j] += f * x[: n - w - 1, j]
            out[w, j] += f * x[0, j]
    return out


def drive_targets(muscles: MuscleParams, u: np.ndarray, one_eta: np.ndarray,
                  drift: np.ndarray | None = None, open_u: np.ndarray | None = None
                  ) -> np.ndarray:
    """Each muscle's force target for the intent, 0..1.

    The muscles that grip aim at ``synergy_m u (1 + eta_m)``; the others (antagonists and
    stabilizers) at ``synergy_m u (1 + eta_m) max(u ** (p - 1) + c_m, 0.2 u ** (p - 1))``,
    ``p`` the subject's ``cocontraction_power`` (their mean grows as ``u ** p``) and ``c_m``
    the slow co-contraction drift, in proportion to the grip. With ``p = 1`` (the default
    population) this is ``u (1 + eta) max(1 + c, 0.2)``, computed in the order it always
    was. The batch recording and the causal session both call this, so their targets are
    the same numbers.

    Parameters
    ----------
    muscles : MuscleParams
    u : ndarray, shape (n_samples,)
        Intent, 0..1.
    one_eta : ndarray, shape (n_samples, n_muscles)
        ``1 + eta``: the force-steadiness fluctuation.
    drift : ndarray, shape (n_samples, n_others), optional
        The co-contraction drift ``c`` of the muscles that do not grip (None: none).
    open_u : ndarray, shape (n_samples,), optional
        The open intent ``v``, 0..1: each muscle's close target (the one computed without
        it) gains ``open_synergy_m v (1 + eta_m)`` and the sum is clipped to 0..1, so
        ``v = 0`` gives the close targets exactly. ``None``: no opening, and the targets
        are computed exactly as before the open intent existed (no seed moves).

    Returns
    -------
    ndarray, shape (n_samples, n_muscles)
    """
    if open_u is not None:
        return with_opening(muscles, drive_targets(muscles, u, one_eta, drift), open_u, one_eta)
    target = muscles.array("synergy")[None, :] * u[:, None] * one_eta
    power = muscles.cocontraction_power
    if power == 1.0:
        target = np.minimum(np.maximum(target, 0.0), 1.0)
        if drift is not None:
            others = muscles.array("grip_share") == 0
            target[:, others] = np.clip(target[:, others] * np.clip(1.0 + drift, 0.2, None),
                                        0, 1)
        return target
    others = muscles.array("grip_share") == 0
    mean = u[:, None] ** (power - 1.0)
    target[:, others] *= mean if drift is None else np.maximum(mean + drift, 0.2 * mean)
    return np.minimum(np.maximum(target, 0.0), 1.0)


def with_opening(muscles: MuscleParams, close: np.ndarray, open_u: np.ndarray,
                 one_eta: np.ndarray) -> np.ndarray:
    """Close targets plus the opening's: ``clip(close_m + open_synergy_m v (1 + eta_m), 0, 1)``.

    Parameters
    ----------
    muscles : MuscleParams
    close : ndarray, shape (n_samples, n_muscles)
        The targets of the close intent alone (:func:`drive_targets` without ``open_u``).
    open_u : ndarray, shape (n_samples,)
        The open intent ``v``, 0..1.
    one_eta : ndarray, shape (n_samples, n_muscles)
        ``1 + eta``, the fluctuation the close targets were made with.

    Returns
    -------
    ndarray, shape (n_samples, n_muscles)
        Each muscle's target, 0..1 (``close`` itself where ``v = 0``).
    """
    opening = muscles.array("open_synergy")[None, :] * np.asarray(open_u)[:, None] * one_eta
    return np.minimum(np.maximum(close + opening, 0.0), 1.0)


def slow_fluctuation(
    n_samples: int, fs_hz: float, std: np.ndarray, time_s: float, rng: np.random.Generator
) -> np.ndarray:
    """Stationary Ornstein-Uhlenbeck noise, one independent column per muscle.

    Parameters
    ----------
    n_samples : int
    fs_hz : float
        Sampling rate in hertz.
    std : ndarray, shape (n_columns,)
        Stationary standard deviation of each column.
    time_s : float
        Correlation time in seconds.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n_samples, n_columns)
        Zero-mean; starts in the stationary distribution.
    """
    import scipy.signal
    std = np.asarray(std, dtype=float)
    a = np.exp(-1.0 / (time_s * fs_hz))
    w = rng.standard_normal((n_samples, std.size))
    w[0] /= np.sqrt(1.0 - a * a)  # stationary start
    z = scipy.signal.lfilter([np.sqrt(1.0 - a * a)], [1.0, -a], w, axis=0)
    return z * std[None, :]


class CausalDelay:
    """:func:`fractional_delay` applied chunk by chunk, to the last bits.

    Holds the last samples of the input between calls, so that feeding a
    signal in consecutive chunks gives exactly the samples
    :func:`fractional_delay` gives on the whole signal (the value before the
    first sample is the first sample, as there).

    Parameters
    ----------
    delay_s : ndarray, shape (n_columns,)
        Non-negative delays in seconds.
    fs_hz : float
        Sampling rate in hertz.
    """

    def __init__(self, delay_s: np.ndarray, fs_hz: float) -> None:
        d = np.asarray(delay_s, dtype=float) * fs_hz
        w = np.floor(d).astype(int)
        f = d - w
        self._keep = int(w.max()) + 1
        self._w = w[None, :]
        self._f = f[None, :]
        self._one_minus_f = (1.0 - f)[None, :]
        self._base = self._keep - self._w  # row of input n + i - w in [history, chunk]
        self._cols = np.arange(d.size)[None, :]
        self._history: np.ndarray | None = None  # the last `_keep` inputs
        self._x0: np.ndarray | None = None
        self._n = 0  # samples consumed so far

    def step(self, x: np.ndarray) -> np.ndarray:
        """Delay the next chunk, shape (n_chunk, n_columns); returns the same shape."""
        x = np.asarray(x, dtype=float)
        k = x.shape[0]
        if self._history is None:
            self._x0 = x[0].copy()
            self._history = np.repeat(self._x0[None, :], self._keep, axis=0)
        ext = np.concatenate([self._history, x], axis=0)  # row keep + i is input n + i
        rows = self._base + np.arange(k)[:, None]
        # (1 - f) x[i - w] + f x[i - w - 1], in the batch's order of operations; the
        # history starts filled with x[0], the batch's x[i < 0]; f = 0 adds an exact 0.
        out = self._one_minus_f * ext[rows, self._cols]
        out += self._f * ext[rows - 1, self._cols]
        g = self._n + np.arange(k)[:, None]
        out = np.where(g < self._w, self._x0[None, :], out)
        self._history = ext[-self._keep:]
        self._n += k
        return out


class CausalActivation:
    """:func:`activation_dynamics` applied chunk by chunk, to the last bits.

    The filter state is carried between chunks (``scipy.signal.lfilter`` with
    ``zi``); it starts at rest at the first chunk's first value, as the batch
    filter does.

    Parameters
    ----------
    cutoff_hz : ndarray, shape (n_columns,)
        Corner frequency per column in hertz.
    fs_hz : float
        Sampling rate in hertz.
    """

    def __init__(self, cutoff_hz: np.ndarray, fs_hz: float) -> None:
        self._cut = np.asarray(cutoff_hz, dtype=float)
        self._fs = float(fs_hz)
        self._levels = np.unique(self._cut)
        self._state: list[np.ndarray] | None = None

    def step(self, x: np.ndarray) -> np.ndarray:
        """Filter the next chunk, shape (n_chunk, n_columns); returns the same shape."""
        import scipy.signal
        x = np.asarray(x, dtype=float)
        single = self._levels.size == 1
        out = None if single else np.empty_like(x)
        first = self._state is None
        if first:
            self._state = []
        for i, fc in enumerate(self._levels):
            cols = slice(None) if single else np.flatnonzero(self._cut == fc)
            r = float(np.exp(-2.0 * np.pi * fc / self._fs))
            b, a = [(1.0 - r) ** 2], [1.0, -2.0 * r, r * r]
            if first:
                x0 = x[0, cols]
                self._state.append(np.stack([x0 * (2.0 * r - r * r), -r * r * x0], axis=0))
            y, self._state[i] = scipy.signal.lfilter(b, a, x[:, cols], axis=0, zi=self._state[i])
            if single:
                return y
            out[:, cols] = y
        return out
