"""Fast sEMG generator: amplitude-modulated shaped noise (Hogan and Mann 1980).

Each muscle's sEMG is ``sigma(t) n(t)``: ``n`` is unit-variance Gaussian noise
whose spectrum is the MUAP spectrum (:func:`sim.user.muap.muap_psd`) after the
armband's front end and *folded* by sampling at ``fs_hz`` (exactly what
generating at a high rate, band-limiting and decimating without an
anti-aliasing filter gives, in distribution), and
``sigma = drive ** amplitude_exponent`` is the amplitude. Shaping is done
directly at ``fs_hz`` by filtering white noise in the frequency domain, which
makes the generator tens of thousands of times faster than real time.

Force follows the drive through the electromechanical delay and the
critically damped activation dynamics (:mod:`sim.user.muscles`). Fatigue
compresses the spectrum (crossfade towards a spectrum slowed by the end-of-
recording factor) and raises the amplitude.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import scipy.fft

from sim.user.armband import FrontEnd
from sim.user.emg import MuscleSignals
from sim.user.muap import muap_psd
from sim.user.muscles import CausalActivation, CausalDelay, MuscleParams, muscle_force

# Lowest median-frequency factor fatigue may reach (spectrum compression limit).
_MIN_FREQUENCY_FACTOR = 0.5
# Frequency grid on which folded spectra are computed (then interpolated).
_N_GRID = 513


@lru_cache(maxsize=256)
def _folded_grid(width_s: float, front_end: FrontEnd, fs_hz: float) -> np.ndarray:
    """Folded MUAP power on ``_N_GRID`` points over 0..fs/2 (read-only, cached)."""
    f = np.linspace(0.0, fs_hz / 2.0, _N_GRID)
    power = front_end.folded_psd(lambda g: muap_psd(g, width_s), f, fs_hz)
    power.setflags(write=False)
    return power


def fatigue_profile(
    n_samples: int, fs_hz: float, fatigue_per_min: float
) -> tuple[np.ndarray, np.ndarray]:
    """Median-frequency and amplitude factors over a recording.

    Parameters
    ----------
    n_samples : int
    fs_hz : float
        Sampling rate in hertz.
    fatigue_per_min : float
        Fractional fall of the median frequency per minute.

    Returns
    -------
    frequency_factor, amplitude_factor : ndarray, shape (n_samples,)
        ``max(1 - r t, 0.5)`` and ``1 + 2 r t`` with ``t`` in minutes.
    """
    t_min = np.arange(n_samples) / fs_hz / 60.0
    freq = np.maximum(1.0 - fatigue_per_min * t_min, _MIN_FREQUENCY_FACTOR)
    return freq, 1.0 + 2.0 * fatigue_per_min * t_min


def shaped_noise(
    n_samples: int,
    fs_hz: float,
    width_s: np.ndarray,
    front_end: FrontEnd,
    rng: np.random.Generator,
) -> np.ndarray:
    """Unit-variance Gaussian noise with the folded MUAP spectrum, one column per width.

    Parameters
    ----------
    n_samples : int
    fs_hz : float
        Sampling rate in hertz (the ADC rate; aliasing is folded in).
    width_s : ndarray, shape (n_columns,)
        MUAP Gaussian width of each column, seconds.
    front_end : FrontEnd
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n_samples, n_columns)
        Stationary Gaussian noise, variance 1 per column: the spectrum of
        white noise is drawn directly over a fast FFT length >= n_samples,
        shaped, transformed back and truncated.
    """
    width_s = np.asarray(width_s, dtype=float)
    n_fft = scipy.fft.next_fast_len(n_samples, real=True)
    f = np.fft.rfftfreq(n_fft, 1.0 / fs_hz)
    grid = np.linspace(0.0, fs_hz / 2.0, _N_GRID)
    power = np.stack(
        [np.interp(f, grid, _folded_grid(float(w), front_end, float(fs_hz))) for w in width_s],
        axis=1,
    )
    bin_weight = np.full(f.size, 2.0)
    bin_weight[0] = 1.0
    if n_fft % 2 == 0:
        bin_weight[-1] = 1.0
    power *= n_fft / (bin_weight @ power)[None, :]
    # The spectrum of unit white noise, drawn directly: independent complex
    # Gaussians of variance n_fft (real at DC and Nyquist).
    spectrum = rng.standard_normal((f.size, width_s.size, 2)).view(np.complex128)[..., 0]
    spectrum *= np.sqrt(power * (n_fft / bin_weight)[:, None])
    spectrum[0].imag = 0.0
    if n_fft % 2 == 0:
        spectrum[-1].imag = 0.0
    return scipy.fft.irfft(spectrum, n=n_fft, axis=0)[:n_samples]


def laplace_mixture(shape: tuple[int, ...], mix: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-power scale factors that turn unit Gaussian noise towards a Laplacian.

    ``sqrt((1 - mix) + mix w) / c`` with ``w`` exponential of mean 1, independent per
    sample: a Gaussian times it is a Gaussian scale mixture whose marginal is Gaussian at
    ``mix = 0`` and Laplacian at ``mix = 1`` (variance kept at 1, ``c = 1``). Independent
    factors leave the autocorrelation at lags > 0 scaled by ``E[s]^2`` and add a white
    part, which flattens the folded sEMG spectrum slightly.

    Parameters
    ----------
    shape : tuple of int
        Shape of the noise to scale.
    mix : float
        0..1.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray
        Factors of mean square 1, shape ``shape``.
    """
    return np.sqrt((1.0 - mix) + mix * rng.exponential(1.0, shape))


def _carrier(n: int, muscles: MuscleParams, front_end: FrontEnd, fs_hz: float,
             rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray | None]:
    """Unit carrier noise of ``n`` samples (fatigue crossfade and the Laplace mixture
    included) and the fatigue amplitude factor (``None`` without fatigue): everything the
    drive does not change."""
    width_s = muscles.array("muap_width_ms") * 1e-3
    if muscles.fatigue_per_min > 0:
        freq, amp = fatigue_profile(n, fs_hz, muscles.fatigue_per_min)
        both = shaped_noise(n, fs_hz, np.concatenate([width_s, width_s / freq[-1]]),
                            front_end, rng)
        span = max(1.0 - freq[-1], 1e-12)
        beta = ((1.0 - freq) / span)[:, None]
        m = width_s.size
        noise = np.sqrt(1.0 - beta) * both[:, :m] + np.sqrt(beta) * both[:, m:]
    else:
        noise, amp = shaped_noise(n, fs_hz, width_s, front_end, rng), None
    if muscles.carrier_laplace > 0:
        noise *= laplace_mixture(noise.shape, muscles.carrier_laplace, rng)
    return noise, amp


class CausalNoiseMuscles:
    """:class:`NoiseEmgGenerator` running chunk by chunk (see :meth:`NoiseEmgGenerator.causal`).

    Parameters
    ----------
    noise : ndarray, shape (n_samples, n_muscles)
        The unit carrier noise of the whole recording.
    amplitude_factor : ndarray, shape (n_samples,) or None
        Fatigue's amplitude rise, or ``None``.
    muscles : MuscleParams
    fs_hz : float
        Sampling rate in hertz.
    """

    def __init__(self, noise: np.ndarray, amplitude_factor: np.ndarray | None,
                 muscles: MuscleParams, fs_hz: float) -> None:
        self._noise = noise
        self._amp = amplitude_factor
        self._exponent = muscles.array("amplitude_exponent")[None, :]
        self._delay = CausalDelay(muscles.array("emd_s"), fs_hz)
        self._activation = CausalActivation(muscles.array("activation_cutoff_hz"), fs_hz)
        self._n_emg = 0

    def emg(self, drive: np.ndarray) -> np.ndarray:
        """sEMG of the next chunk of drive, shape (n_chunk, n_muscles).

        Raises
        ------
        ValueError
            More samples than the recording was drawn for.
        """
        e = np.maximum(np.asarray(drive, dtype=float), 0.0)  # np.clip's values, less overhead
        i0, i1 = self._n_emg, self._n_emg + e.shape[0]
        if i1 > self._noise.shape[0]:
            raise ValueError(f"causal sEMG drawn for {self._noise.shape[0]} samples, "
                             f"asked for sample {i1}")
        sigma = e ** self._exponent
        if self._amp is not None:
            sigma = sigma * self._amp[i0:i1, None]
        self._n_emg = i1
        return self._noise[i0:i1] * sigma

    def force(self, drive: np.ndarray) -> np.ndarray:
        """Muscle force of the next chunk of drive (delay, activation), (n_chunk, n_muscles)."""
        e = np.maximum(np.asarray(drive, dtype=float), 0.0)
        return self._activation.step(self._delay.step(e))


@dataclass(frozen=True)
class NoiseEmgGenerator:
    """Amplitude-modulated noise sEMG with activation-dynamics force.

    Satisfies :class:`sim.user.emg.CausalEmgGenerator` (so a reacting user can
    drive it chunk by chunk); it has no settings of its own
    (everything comes from the subject's :class:`~sim.user.muscles.MuscleParams`).
    """

    name: str = "noise"

    def generate(
        self,
        drive: np.ndarray,
        muscles: MuscleParams,
        front_end: FrontEnd,
        *,
        fs_hz: float,
        rng: np.random.Generator,
    ) -> MuscleSignals:
        """Muscle sEMG and force.

        Parameters
        ----------
        drive : ndarray, shape (n_samples, n_muscles)
            Neural drive per muscle, 0..1, at ``fs_hz``.
        muscles : MuscleParams
        front_end : FrontEnd
        fs_hz : float
            ADC sampling rate in hertz.
        rng : numpy.random.Generator

        Returns
        -------
        MuscleSignals
            sEMG with RMS ``drive ** amplitude_exponent`` (1 at full drive) and
            force ``actdyn(drive(t - emd))``.
        """
        e = np.clip(np.asarray(drive, dtype=float), 0.0, None)
        n = e.shape[0]
        sigma = e ** muscles.array("amplitude_exponent")[None, :]
        noise, amp = _carrier(n, muscles, front_end, fs_hz, rng)
        if amp is not None:
            sigma = sigma * amp[:, None]
        force = muscle_force(e, fs_hz, muscles.array("activation_cutoff_hz"),
                             muscles.array("emd_s"))
        noise *= sigma
        return MuscleSignals(emg=noise, force=force, info={})

    def causal(
        self,
        n_samples: int,
        muscles: MuscleParams,
        front_end: FrontEnd,
        *,
        fs_hz: float,
        rng: np.random.Generator,
    ) -> CausalNoiseMuscles:
        """The same generator run chunk by chunk (:class:`sim.user.emg.CausalEmgGenerator`).

        The shaped carrier noise of all ``n_samples`` is drawn here, as
        :meth:`generate` draws it for a drive of ``n_samples``; chunks fed the
        same drive give :meth:`generate`'s output to the last bits (numpy's vector loops
        may round an element differently with its place in a chunk on some CPUs).
        """
        noise, amp = _carrier(int(n_samples), muscles, front_end, fs_hz, rng)
        return CausalNoiseMuscles(noise, amp, muscles, fs_hz)

    def steady_force(self, drive: np.ndarray, muscles: MuscleParams) -> np.ndarray:
        """Steady force equals the drive (unit DC gain), shape (n_muscles,)."""
        return np.clip(np.asarray(drive, dtype=float), 0.0, None)

    def params(self) -> dict[str, Any]:
        """Generator settings for metadata."""
        return {"name": self.name}
