"""The MYO-like armband: electrode ring, crosstalk, analog front end, noise, int8 ADC.

Eight electrodes sit on a ring around the forearm, one spacing apart, so
channel 8 neighbours channel 1. Muscle ``m`` (0-based) lies under electrode
``m`` when the band is in its reference position; rotating the band by
``electrode_shift`` spacings moves every electrode to ``c + shift``. Each
electrode sees each muscle with weight ``exp(-d / crosstalk_length)``, ``d``
the ring distance in spacings (crosstalk falls with distance).

The front end band-limits the signal (default Butterworth 15 Hz high-pass,
200 Hz low-pass, 2nd order each) and the ADC samples at 200 Hz *without* an
anti-aliasing filter below Nyquist, so sEMG power above 100 Hz folds back:
with 1.5 ms MUAPs this gives the real MYO's spectrum (median about 64 Hz;
CALIBRATION.md). Values are rounded to int8 counts and clipped at -128..127.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from sim.errors import GriploopError
from sim.user.muscles import slow_fluctuation

N_CHANNELS = 8
INT8_MIN, INT8_MAX = -128, 127
_DRIFT_SHARED = 0.7  # share of the noise-floor drift common to every electrode
_ARTIFACT_S = (0.02, 0.12)  # burst duration, s
_ARTIFACT_LSB = (40.0, 160.0)  # burst amplitude, counts
_ARTIFACT_SPREAD = 0.3  # weight of a burst on the neighbouring electrodes


class ArmbandError(GriploopError, ValueError):
    """Armband settings or inputs out of range."""


@dataclass(frozen=True)
class FrontEnd:
    """Analog band-limiting before the ADC (Butterworth high-pass and low-pass).

    Parameters
    ----------
    highpass_hz, lowpass_hz : float
        Corner frequencies in hertz.
    order : int
        Order of each of the two Butterworth sections.
    """

    highpass_hz: float = 15.0
    lowpass_hz: float = 200.0
    order: int = 2

    def __post_init__(self) -> None:
        if not (0 < self.highpass_hz < self.lowpass_hz) or self.order < 1:
            raise ArmbandError(
                "FrontEnd: expected 0 < highpass_hz < lowpass_hz and order >= 1, found "
                f"{self.highpass_hz}, {self.lowpass_hz}, {self.order}"
            )

    def power_response(self, f_hz: np.ndarray) -> np.ndarray:
        """Squared magnitude of the analog response at ``f_hz`` (shape kept)."""
        f = np.abs(np.asarray(f_hz, dtype=float))
        n2 = 2 * self.order
        hp = (f / self.highpass_hz) ** n2
        return hp / (1.0 + hp) / (1.0 + (f / self.lowpass_hz) ** n2)

    def sos(self, fs_hz: float) -> np.ndarray:
        """Digital second-order sections of the front end at rate ``fs_hz``.

        Raises
        ------
        ArmbandError
            If ``fs_hz`` is not above twice the low-pass corner.
        """
        import scipy.signal
        if fs_hz <= 2.0 * self.lowpass_hz:
            raise ArmbandError(
                f"internal rate must exceed 2 x lowpass_hz = {2 * self.lowpass_hz} Hz, "
                f"found {fs_hz} Hz"
            )
        hp = scipy.signal.butter(self.order, self.highpass_hz, "highpass", fs=fs_hz, output="sos")
        lp = scipy.signal.butter(self.order, self.lowpass_hz, "lowpass", fs=fs_hz, output="sos")
        return np.vstack([hp, lp])

    def folded_psd(
        self,
        source_psd: Callable[[np.ndarray], np.ndarray],
        f_hz: np.ndarray,
        fs_hz: float,
        n_images: int = 5,
    ) -> np.ndarray:
        """PSD after the front end and sampling at ``fs_hz`` (aliasing included).

        Parameters
        ----------
        source_psd : callable
            Two-sided source PSD ``S(f)`` of the muscle signal (any scale),
            vectorized over ``f``.
        f_hz : ndarray, shape (n_freq,)
            Frequencies in ``[0, fs_hz / 2]``.
        fs_hz : float
            Sampling rate of the ADC in hertz.
        n_images : int
            Number of spectral images folded in on each side (sEMG power above
            ``n_images * fs_hz`` is negligible: 1 kHz at 200 Hz).

        Returns
        -------
        ndarray, shape (n_freq,)
            ``sum_k S(f + k fs) |H(f + k fs)|^2`` over all integer ``k``.
        """
        f = np.asarray(f_hz, dtype=float)
        k = np.arange(-n_images, n_images + 1)[:, None] * fs_hz
        g = f[None, :] + k
        return np.sum(source_psd(g) * self.power_response(g), axis=0)


@lru_cache(maxsize=64)
def _mixing_matrix(shift: float, length: float, channel_gain: tuple[float, ...],
                   n_muscles: int) -> np.ndarray:
    """:meth:`Armband.mixing_matrix`, computed once per band (read-only: digitize is hot)."""
    pos = np.arange(N_CHANNELS) + shift
    d = ring_distance(pos[:, None], np.arange(n_muscles)[None, :])
    gain = np.asarray(channel_gain, dtype=float)[:, None]
    out = gain * np.exp(-d / length)
    out.setflags(write=False)
    return out


def ring_distance(a: np.ndarray | float, b: np.ndarray | float, n: int = N_CHANNELS) -> np.ndarray:
    """Shortest distance around a ring of ``n`` equally spaced positions (in spacings)."""
    d = np.mod(np.asarray(a, dtype=float) - np.asarray(b, dtype=float), n)
    return np.minimum(d, n - d)


@dataclass(frozen=True)
class Armband:
    """Electrode ring, crosstalk and digitization of one subject's MYO.

    Parameters
    ----------
    crosstalk_length : float
        Decay length of crosstalk in electrode spacings; weight of a muscle
        one spacing away is ``exp(-1 / crosstalk_length)`` (0.55 gives 16 %).
    electrode_shift : float
        Rotation of the band in electrode spacings (positive: towards higher
        channel numbers); 0 is the reference placement of the paper.
    noise_lsb : float
        Skin/electrode/amplifier noise std in counts (rest std about 1.9 LSB).
    extra_noise_lsb : float
        Scenario knob: additional noise std in counts, added in quadrature.
    channel_gain : tuple of float
        Electrode-skin contact gain per channel (multiplies that channel).
    front_end : FrontEnd
        Analog band-limiting before the ADC.
    noise_drift_std : float
        Log-SD of a slow drift of the noise floor (dry electrode-skin impedance changing
        with sweat and pressure): the noise std is multiplied by ``exp(z(t))``, ``z`` an
        Ornstein-Uhlenbeck process, 70 % shared by all channels. 0 = stationary noise.
    noise_drift_time_s : float
        Correlation time of that drift, seconds.
    artifact_rate_hz : float
        Rate of contact artifacts: bursts of 20-120 ms, 40-160 counts, on one electrode
        (30 % on its neighbours) when a dry electrode briefly loses contact. 0 = none.
    """

    crosstalk_length: float = 0.55
    electrode_shift: float = 0.0
    noise_lsb: float = 1.9
    extra_noise_lsb: float = 0.0
    channel_gain: tuple[float, ...] = (1.0,) * N_CHANNELS
    front_end: FrontEnd = field(default_factory=FrontEnd)
    noise_drift_std: float = 0.0
    noise_drift_time_s: float = 10.0
    artifact_rate_hz: float = 0.0

    def __post_init__(self) -> None:
        if self.crosstalk_length <= 0 or self.noise_lsb < 0 or self.extra_noise_lsb < 0:
            raise ArmbandError(
                "Armband: expected crosstalk_length > 0 and noise levels >= 0, found "
                f"{self.crosstalk_length}, {self.noise_lsb}, {self.extra_noise_lsb}"
            )
        if self.noise_drift_std < 0 or self.noise_drift_time_s <= 0 or self.artifact_rate_hz < 0:
            raise ArmbandError(
                "Armband: expected noise_drift_std >= 0, noise_drift_time_s > 0 and "
                f"artifact_rate_hz >= 0, found {self.noise_drift_std}, "
                f"{self.noise_drift_time_s}, {self.artifact_rate_hz}"
            )
        if len(self.channel_gain) != N_CHANNELS:
            raise ArmbandError(
                f"Armband.channel_gain: expected {N_CHANNELS} values, found "
                f"{len(self.channel_gain)}"
            )

    @property
    def total_noise_lsb(self) -> float:
        """Additive noise std in counts (base and extra in quadrature)."""
        return float(np.hypot(self.noise_lsb, self.extra_noise_lsb))

    def mixing_matrix(self, n_muscles: int = N_CHANNELS) -> np.ndarray:
        """Crosstalk weights, shape (n_channels, n_muscles); 1 on the diagonal at zero shift."""
        return _mixing_matrix(self.electrode_shift, self.crosstalk_length,
                              tuple(self.channel_gain), int(n_muscles)).copy()

    def nearest_muscles(self) -> list[int]:
        """0-based index of the muscle closest to each electrode."""
        pos = np.arange(N_CHANNELS) + self.electrode_shift
        return [int(np.mod(np.rint(p), N_CHANNELS)) for p in pos]

    def noise_std_lsb(self, n_samples: int, fs_hz: float,
                      rng: np.random.Generator) -> np.ndarray | float:
        """Additive noise std in counts: a constant, or shape (n_samples, n_channels) with drift."""
        if self.noise_drift_std == 0:
            return self.total_noise_lsb
        common = slow_fluctuation(n_samples, fs_hz, np.array([1.0]), self.noise_drift_time_s, rng)
        own = slow_fluctuation(n_samples, fs_hz, np.ones(N_CHANNELS), self.noise_drift_time_s,
                               rng)
        z = self.noise_drift_std * (np.sqrt(_DRIFT_SHARED) * common
                                    + np.sqrt(1.0 - _DRIFT_SHARED) * own)
        return self.total_noise_lsb * np.exp(z - 0.5 * self.noise_drift_std ** 2)

    def artifacts_lsb(self, n_samples: int, fs_hz: float,
                      rng: np.random.Generator) -> np.ndarray | None:
        """Contact-artifact bursts in counts, shape (n_samples, n_channels), or None."""
        if self.artifact_rate_hz == 0:
            return None
        out = np.zeros((n_samples, N_CHANNELS))
        for _ in range(int(rng.poisson(self.artifact_rate_hz * n_samples / fs_hz))):
            start = int(rng.integers(0, n_samples))
            length = max(2, int(rng.uniform(*_ARTIFACT_S) * fs_hz))
            burst = rng.uniform(*_ARTIFACT_LSB) * rng.standard_normal(length) * np.hanning(length)
            burst = burst[: n_samples - start]
            ch = int(rng.integers(0, N_CHANNELS))
            for c, weight in ((ch, 1.0), ((ch + 1) % N_CHANNELS, _ARTIFACT_SPREAD),
                              ((ch - 1) % N_CHANNELS, _ARTIFACT_SPREAD)):
                out[start:start + burst.size, c] += weight * burst
        return out

    def digitize(
        self, muscle_emg_lsb: np.ndarray, rng: np.random.Generator, *, fs_hz: float = 200.0
    ) -> tuple[np.ndarray, int]:
        """Mix muscle signals onto the electrodes, add noise and quantize to int8.

        Parameters
        ----------
        muscle_emg_lsb : ndarray, shape (n_samples, n_muscles)
            Each muscle's sEMG after the front end, at the ADC rate, in counts
            as an electrode directly above it would see it.
        rng : numpy.random.Generator
        fs_hz : float
            ADC rate in hertz (time scale of the noise drift and the artifacts).

        Returns
        -------
        emg : ndarray of int8, shape (n_samples, n_channels)
        n_saturated : int
            Number of samples (over all channels) clipped at -128 or 127.
        """
        s = np.asarray(muscle_emg_lsb, dtype=float)
        x = s @ self.mixing_matrix_view(s.shape[1]).T
        q = self.quantize(x, self.electrode_noise_lsb(x.shape[0], fs_hz, rng))
        n_sat = int(np.count_nonzero((q < INT8_MIN) | (q > INT8_MAX)))
        return np.clip(q, INT8_MIN, INT8_MAX).astype(np.int8), n_sat

    def mixing_matrix_view(self, n_muscles: int = N_CHANNELS) -> np.ndarray:
        """:meth:`mixing_matrix`, read-only and computed once per band (no copy)."""
        return _mixing_matrix(self.electrode_shift, self.crosstalk_length,
                              tuple(self.channel_gain), int(n_muscles))

    def electrode_noise_lsb(self, n_samples: int, fs_hz: float,
                            rng: np.random.Generator) -> np.ndarray:
        """Everything the electrodes add to the muscles' signals, counts, (n_samples, n_channels).

        The (drifting) noise floor times standard normal draws, plus the contact bursts;
        drawn in this order from ``rng``. It does not depend on the muscles, so a causal
        session (:mod:`sim.user.causal`) draws it up front with the same numbers.
        """
        noise = self.noise_std_lsb(n_samples, fs_hz, rng) * rng.standard_normal(
            (n_samples, N_CHANNELS))
        bursts = self.artifacts_lsb(n_samples, fs_hz, rng)
        if bursts is not None:
            noise += bursts
        return noise

    def quantize(self, electrode_lsb: np.ndarray, noise_lsb: np.ndarray) -> np.ndarray:
        """Add the electrodes' noise to mixed signals and round to counts (not clipped).

        Parameters
        ----------
        electrode_lsb : ndarray, shape (n_samples, n_channels)
            Mixed signals in counts; modified in place.
        noise_lsb : ndarray, same shape
            What :meth:`electrode_noise_lsb` drew for these samples, counts.
        """
        electrode_lsb += noise_lsb
        return np.rint(electrode_lsb, out=electrode_lsb)
