"""Motor-unit pool sEMG generator (Fuglevand, Winter and Patla 1993).

Each muscle is a pool of ``n_units`` motor units (120 by default):

* recruitment thresholds ``RTE_i = exp(ln(RR) i / n)``, RR = 30;
* rate coding: ``rate = min(g (E - RTE_i) + 8 Hz, PFR_i)`` above threshold,
  gain g = 1 Hz per unit excitation, peak rate falling linearly with
  threshold from 35 Hz (first unit) to 25 Hz (last unit); the excitation at
  full drive, ``E_max``, brings the last unit to its peak rate;
* discharge times from a time-varying rate with Gaussian ISI jitter
  (coefficient of variation 0.15): a unit fires whenever its integrated rate
  crosses the next of a sequence of thresholds with jittered unit spacing;
* twitches ``f(t) = P (t/T) exp(1 - t/T)``, peak forces ``P`` exponential over
  a range of 100, contraction times ``T = 90 ms * P^(-ln 3 / ln 100)`` (90 down
  to 30 ms, quantized to ``n_twitch_levels`` geometric levels so that the
  twitch sum is computed exactly by second-order recursions at the ADC rate);
* saturating gain: when ``x = T / ISI > 0.4`` the twitch is scaled by
  ``S(x) / x / (S(0.4) / 0.4)``, ``S(x) = 1 - exp(-2 x^3)``;
* MUAP trains: each unit has its own MUAP (a mix of Gaussian first and
  second derivatives, :mod:`sim.user.muap`) whose amplitude grows as
  ``P ** muap_exponent`` with a random depth factor and whose width is spread
  log-normally around the muscle's width. Widths are interpolated between a
  few basis widths, so the whole pool needs only a few FFT convolutions.

The sEMG is synthesized at ``internal_fs_hz`` (2 kHz), passed through the
armband's front end and decimated without anti-aliasing to ``fs_hz``; the
muscle force is the sum of the same units' twitches, delayed by the EMD.
Pool anatomy (MUAP shapes, depth) comes from ``MuscleParams.anatomy_seed``,
discharge jitter from the session's ``rng``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from sim.errors import GriploopError
from sim.user.armband import FrontEnd
from sim.user.emg import MuscleSignals
from sim.user.emg_noise import fatigue_profile
from sim.user.muap import gaussian_derivative
from sim.user.muscles import MuscleParams, fractional_delay

_SATURATION_KNEE = 0.4
_N_BASIS_WIDTHS = 4
_MIN_ISI_FRACTION = 0.3  # shortest jittered interval, as a fraction of the mean


class MotorUnitError(GriploopError, ValueError):
    """Motor-unit pool settings are out of range."""


def _saturation(x: np.ndarray) -> np.ndarray:
    return 1.0 - np.exp(-2.0 * x**3)


def saturating_gain(t_over_isi: np.ndarray) -> np.ndarray:
    """Fuglevand's twitch gain for the normalized rate ``x = T / ISI`` (1 for x <= 0.4)."""
    x = np.asarray(t_over_isi, dtype=float)
    ref = _saturation(np.float64(_SATURATION_KNEE)) / _SATURATION_KNEE
    safe = np.maximum(x, _SATURATION_KNEE)
    return np.where(x > _SATURATION_KNEE, _saturation(safe) / safe / ref, 1.0)


@dataclass(frozen=True)
class MotorUnitEmgGenerator:
    """Motor-unit pool model of sEMG and force; satisfies :class:`sim.user.emg.EmgGenerator`.

    Parameters
    ----------
    n_units : int
        Motor units per muscle (Fuglevand: 120).
    recruitment_range : float
        Ratio of the last to the first recruitment threshold (RR).
    min_rate_hz : float
        Firing rate at recruitment.
    peak_rate_first_hz, peak_rate_last_hz : float
        Peak firing rate of the first and of the last recruited unit.
    rate_gain_hz : float
        Firing-rate gain, Hz per unit excitation.
    isi_cv : float
        Coefficient of variation of the inter-spike intervals.
    twitch_force_range : float
        Ratio of the largest to the smallest twitch peak force.
    contraction_time_max_s, contraction_time_min_s : float
        Contraction time of the smallest and of the largest unit, seconds.
    n_twitch_levels : int
        Number of distinct (geometrically spaced) contraction times.
    internal_fs_hz : float
        Synthesis rate of the sEMG, hertz; must be an integer multiple of the
        ADC rate.
    muap_width_spread : float
        Log-normal std of per-unit MUAP widths around the muscle's width.
    muap_depth_spread : float
        Log-normal std of the per-unit amplitude factor (fibre depth).
    """

    n_units: int = 120
    recruitment_range: float = 30.0
    min_rate_hz: float = 8.0
    peak_rate_first_hz: float = 35.0
    peak_rate_last_hz: float = 25.0
    rate_gain_hz: float = 1.0
    isi_cv: float = 0.15
    twitch_force_range: float = 100.0
    contraction_time_max_s: float = 0.090
    contraction_time_min_s: float = 0.030
    n_twitch_levels: int = 16
    internal_fs_hz: float = 2000.0
    muap_width_spread: float = 0.2
    muap_depth_spread: float = 0.3
    name: str = "motor_units"

    def __post_init__(self) -> None:
        if self.n_units < 2 or self.recruitment_range <= 1 or self.twitch_force_range <= 1:
            raise MotorUnitError(
                "MotorUnitEmgGenerator: expected n_units >= 2, recruitment_range > 1 and "
                f"twitch_force_range > 1, found {self.n_units}, {self.recruitment_range}, "
                f"{self.twitch_force_range}"
            )
        if not 0 <= self.isi_cv < 0.5:
            raise MotorUnitError(f"isi_cv must be in [0, 0.5), found {self.isi_cv}")
        if not 0 < self.min_rate_hz <= min(self.peak_rate_first_hz, self.peak_rate_last_hz):
            raise MotorUnitError(
                "expected 0 < min_rate_hz <= peak rates, found "
                f"{self.min_rate_hz}, {self.peak_rate_first_hz}, {self.peak_rate_last_hz}"
            )

    # ------------------------------------------------------------- the pool
    def thresholds(self) -> np.ndarray:
        """Recruitment thresholds (excitation units), shape (n_units,)."""
        i = np.arange(1, self.n_units + 1)
        return np.exp(np.log(self.recruitment_range) * i / self.n_units)

    def peak_rates_hz(self) -> np.ndarray:
        """Peak firing rate of each unit in hertz, shape (n_units,)."""
        rte = self.thresholds()
        frac = (rte - rte[0]) / (rte[-1] - rte[0])
        return self.peak_rate_first_hz - (self.peak_rate_first_hz - self.peak_rate_last_hz) * frac

    @property
    def max_excitation(self) -> float:
        """Excitation at full drive: the last unit reaches its peak rate."""
        return float(
            self.thresholds()[-1]
            + (self.peak_rate_last_hz - self.min_rate_hz) / self.rate_gain_hz
        )

    def twitch_forces(self) -> np.ndarray:
        """Twitch peak forces (arbitrary units, 1..range), shape (n_units,)."""
        i = np.arange(1, self.n_units + 1)
        return np.exp(np.log(self.twitch_force_range) * i / self.n_units)

    def contraction_times_s(self) -> np.ndarray:
        """Contraction time of each unit in seconds, quantized, shape (n_units,)."""
        p = self.twitch_forces()
        ratio = self.contraction_time_max_s / self.contraction_time_min_s
        t = self.contraction_time_max_s * p ** (-np.log(ratio) / np.log(self.twitch_force_range))
        levels = self.twitch_levels_s()
        idx = np.argmin(np.abs(np.log(t)[:, None] - np.log(levels)[None, :]), axis=1)
        return levels[idx]

    def twitch_levels_s(self) -> np.ndarray:
        """The distinct contraction times in seconds, shape (n_twitch_levels,)."""
        return np.geomspace(
            self.contraction_time_max_s, self.contraction_time_min_s, self.n_twitch_levels
        )

    def rates_hz(self, excitation: np.ndarray) -> np.ndarray:
        """Firing rates for excitations, shape ``(*excitation.shape, n_units)``; 0 if not
        recruited."""
        e = np.asarray(excitation, dtype=float)[..., None]
        rte = self.thresholds()
        rate = np.minimum(self.rate_gain_hz * (e - rte) + self.min_rate_hz, self.peak_rates_hz())
        return np.where(e >= rte, rate, 0.0)

    def _pool_force(self, excitation: np.ndarray) -> np.ndarray:
        rate = self.rates_hz(excitation)
        t = self.contraction_times_s()
        gain = saturating_gain(t * rate)
        return np.sum(self.twitch_forces() * gain * rate * t * np.e, axis=-1)

    def steady_force(self, drive: np.ndarray, muscles: MuscleParams) -> np.ndarray:
        """Mean pool force at constant drive, normalized to full drive, shape (n_muscles,).

        Uses the mean of a steady discharge: ``sum_i P_i gain_i rate_i T_i e``
        (the integral of one twitch is ``P T e``).
        """
        d = np.clip(np.asarray(drive, dtype=float), 0.0, 1.0)
        return self._pool_force(d * self.max_excitation) / self._pool_force(
            np.float64(self.max_excitation)
        )

    def params(self) -> dict[str, Any]:
        """Generator settings for metadata."""
        return asdict(self)

    # ------------------------------------------------------------ generation
    def generate(
        self,
        drive: np.ndarray,
        muscles: MuscleParams,
        front_end: FrontEnd,
        *,
        fs_hz: float,
        rng: np.random.Generator,
    ) -> MuscleSignals:
        """Muscle sEMG and force from motor-unit discharges.

        Parameters
        ----------
        drive : ndarray, shape (n_samples, n_muscles)
            Neural drive per muscle, 0..1, at ``fs_hz`` (excitation = drive * E_max).
        muscles : MuscleParams
        front_end : FrontEnd
        fs_hz : float
            ADC rate in hertz; ``internal_fs_hz / fs_hz`` must be an integer.
        rng : numpy.random.Generator
            Discharge jitter and initial phases.

        Returns
        -------
        MuscleSignals
            sEMG normalized to RMS about 1 at full drive (Campbell's theorem on
            the front-end-filtered MUAPs), force normalized to the steady
            force at full drive; ``info`` holds spike counts per muscle.
        """
        import scipy.signal
        q = self.internal_fs_hz / fs_hz
        if abs(q - round(q)) > 1e-9 or round(q) < 1:
            raise MotorUnitError(
                f"internal_fs_hz / fs_hz must be a positive integer, found "
                f"{self.internal_fs_hz} / {fs_hz}"
            )
        q = int(round(q))
        e = np.clip(np.asarray(drive, dtype=float), 0.0, 1.0)
        n, n_muscles = e.shape
        n_int = n * q
        anatomy = np.random.default_rng(muscles.anatomy_seed)
        sos = front_end.sos(self.internal_fs_hz)
        freq_factor, amp_factor = fatigue_profile(n, fs_hz, muscles.fatigue_per_min)
        slowest = freq_factor.min()
        widths = muscles.array("muap_width_ms") * 1e-3
        gamma = muscles.array("muap_exponent")
        f_max = self._pool_force(np.float64(self.max_excitation))
        raw = np.zeros((n_int, n_muscles))
        force = np.zeros((n, n_muscles))
        spikes = []
        for m in range(n_muscles):
            unit, t_spk, isi = self._discharges(e[:, m] * self.max_excitation, fs_hz, rng)
            spikes.append(int(t_spk.size))
            force[:, m] = self._twitch_sum(unit, t_spk, isi, n, fs_hz) / f_max
            pool = self._pool_muaps(widths[m], gamma[m], sos, anatomy, slowest)
            raw[:, m] = self._muap_train(pool, unit, t_spk, n_int, fs_hz, freq_factor,
                                         amp_factor)
        emg = scipy.signal.sosfilt(sos, raw, axis=0)[::q]
        force = fractional_delay(force, muscles.array("emd_s"), fs_hz)
        return MuscleSignals(emg=emg, force=force, info={"spikes_per_muscle": spikes})

    def _discharges(
        self, excitation: np.ndarray, fs_hz: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Spike trains of one pool: (unit index, time s, preceding ISI s), sorted by unit."""
        n = excitation.size
        dt = 1.0 / fs_hz
        active = np.flatnonzero(self.thresholds() <= excitation.max())
        if active.size == 0:
            empty = np.zeros(0)
            return empty.astype(int), empty, empty
        rate = self.rates_hz(excitation)[:, active]  # (n, n_active)
        phase = np.zeros_like(rate)
        np.cumsum(0.5 * (rate[1:] + rate[:-1]) * dt, axis=0, out=phase[1:])
        total = phase[-1]
        k = int(np.ceil(total.max())) + 2
        steps = 1.0 + self.isi_cv * rng.standard_normal((k, active.size))
        np.maximum(steps, _MIN_ISI_FRACTION, out=steps)
        steps[0] = rng.random(active.size)  # phase of the first discharge
        theta = np.cumsum(steps, axis=0)
        # One global search: offset each unit's monotone phase into its own band.
        band = max(float(total.max()), float(theta.max())) + 1.0
        offset = band * np.arange(active.size)
        flat = (phase + offset).T.ravel()
        targets = (theta + offset).T  # (n_active, k)
        pos = np.searchsorted(flat, targets.ravel(), side="left").reshape(targets.shape)
        j = pos - (np.arange(active.size) * n)[:, None]
        valid = (j >= 1) & (j < n) & (theta.T <= total[:, None])
        u_idx, s_idx = np.nonzero(valid)
        jj = j[u_idx, s_idx]
        lo = phase[jj - 1, u_idx]
        hi = phase[jj, u_idx]
        th = theta[s_idx, u_idx]
        t = (jj - 1 + (th - lo) / np.maximum(hi - lo, 1e-300)) * dt
        isi = np.empty_like(t)
        isi[0] = np.inf
        isi[1:] = np.diff(t)
        first = np.ones(t.size, dtype=bool)
        first[1:] = u_idx[1:] != u_idx[:-1]
        isi[first] = np.inf
        return active[u_idx], t, isi

    def _twitch_sum(
        self, unit: np.ndarray, t_spk: np.ndarray, isi: np.ndarray, n: int, fs_hz: float
    ) -> np.ndarray:
        """Exact samples at ``k / fs_hz`` of the sum of the spikes' twitches, shape (n,)."""
        import scipy.signal
        t_c = self.contraction_times_s()
        levels = self.twitch_levels_s()
        level_of_unit = np.argmin(np.abs(t_c[:, None] - levels[None, :]), axis=1)
        dt = 1.0 / fs_hz
        big_t = t_c[unit]
        weight = self.twitch_forces()[unit] * saturating_gain(big_t / isi) * np.e / big_t
        k0 = np.floor(t_spk / dt).astype(int) + 1  # first sample after the spike
        keep = k0 < n
        lag = k0[keep] * dt - t_spk[keep]  # time from spike to that sample, [0, dt)
        lvl = level_of_unit[unit[keep]]
        decay = np.exp(-lag / big_t[keep])
        # f(tau + lag) = w e^{-lag/T} [tau e^{-tau/T} + lag e^{-tau/T}], tau = (k - k0) dt
        idx = lvl * n + k0[keep]
        size = levels.size * n
        a = np.bincount(idx, weight[keep] * decay, minlength=size).reshape(levels.size, n)
        b = np.bincount(idx, weight[keep] * decay * lag, minlength=size).reshape(levels.size, n)
        out = np.zeros(n)
        for i, tl in enumerate(levels):
            r = np.exp(-dt / tl)
            # sum_j a_j (k-j) dt r^(k-j)  and  sum_j b_j r^(k-j)
            out += scipy.signal.lfilter([0.0, dt * r], [1.0, -2.0 * r, r * r], a[i])
            out += scipy.signal.lfilter([1.0], [1.0, -r], b[i])
        return out

    def _pool_muaps(self, width_s: float, gamma: float, sos: np.ndarray,
                    anatomy: np.random.Generator, slowest_factor: float) -> _PoolMuaps:
        """One pool's MUAPs (its anatomy) on the basis widths, normalized.

        Parameters
        ----------
        width_s : float
            The muscle's MUAP width, s.
        gamma : float
            Exponent of MUAP amplitude on twitch force.
        sos : ndarray, shape (n_sections, 6)
            The front end's filter at ``internal_fs_hz``.
        anatomy : numpy.random.Generator
            Draws the units' widths, shapes, polarities and depths.
        slowest_factor : float
            Smallest MUAP frequency factor of the session (fatigue widens MUAPs by its
            inverse): the basis reaches the widest unit at that factor.
        """
        import scipy.signal
        nu = self.n_units
        fs = self.internal_fs_hz
        unit_width = width_s * np.exp(self.muap_width_spread * anatomy.standard_normal(nu))
        mix = anatomy.uniform(0.0, 0.5 * np.pi, nu)
        polarity = anatomy.choice([-1.0, 1.0], nu)
        amp = self.twitch_forces() ** gamma * np.exp(
            self.muap_depth_spread * anatomy.standard_normal(nu)
        )
        coef = np.stack([np.cos(mix), np.sin(mix)], axis=1) * (polarity * amp)[:, None]
        lo_w = unit_width.min()
        hi_w = unit_width.max() / slowest_factor
        basis_w = np.geomspace(lo_w, hi_w * (1 + 1e-9), _N_BASIS_WIDTHS)
        half = int(np.ceil(6.0 * basis_w[-1] * fs))
        tk = np.arange(-half, half + 1) / fs
        # Unit-energy kernels (continuous-time norm), shape (2 orders, n_widths, len).
        energy = np.array([np.sqrt(np.pi) / 2.0, 3.0 * np.sqrt(np.pi) / 4.0])
        kernels = np.stack(
            [
                np.stack([gaussian_derivative(tk, w, o) / np.sqrt(energy[o - 1] * w * fs)
                          for w in basis_w])
                for o in (1, 2)
            ]
        )
        # Normalization: Campbell's theorem on the filtered kernels at full drive.
        padded = np.zeros((2 * _N_BASIS_WIDTHS, kernels.shape[-1] + int(0.5 * fs)))
        padded[:, : kernels.shape[-1]] = kernels.reshape(2 * _N_BASIS_WIDTHS, -1)
        filt = scipy.signal.sosfilt(sos, padded, axis=1)
        gram = filt @ filt.T
        w_lo, w_hi, i_lo = _width_weights(unit_width, basis_w)
        unit_vec = np.zeros((nu, 2, _N_BASIS_WIDTHS))
        for o in range(2):
            np.add.at(unit_vec[:, o, :], (np.arange(nu), i_lo), coef[:, o] * w_lo)
            np.add.at(unit_vec[:, o, :], (np.arange(nu), i_lo + 1), coef[:, o] * w_hi)
        unit_vec = unit_vec.reshape(nu, -1)
        unit_energy = np.einsum("ij,jk,ik->i", unit_vec, gram, unit_vec)
        full_rate = self.rates_hz(np.float64(self.max_excitation))
        scale = 1.0 / np.sqrt(np.sum(full_rate / fs * unit_energy))
        return _PoolMuaps(unit_width, coef, basis_w, kernels, scale)

    def _muap_train(
        self,
        pool: _PoolMuaps,
        unit: np.ndarray,
        t_spk: np.ndarray,
        n_int: int,
        fs_hz: float,
        freq_factor: np.ndarray,
        amp_factor: np.ndarray,
    ) -> np.ndarray:
        """Raw (pre-front-end) sEMG of one pool at the internal rate, shape (n_int,)."""
        import scipy.signal
        fs = self.internal_fs_hz
        basis_w, kernels = pool.basis_width_s, pool.kernels
        # Per-spike coefficients (fatigue widens MUAPs and raises amplitude).
        k_adc = np.minimum((t_spk * fs_hz).astype(int), freq_factor.size - 1)
        spk_w = pool.unit_width_s[unit] / freq_factor[k_adc]
        s_lo, s_hi, s_i = _width_weights(spk_w, basis_w)
        spk_c = pool.coef[unit] * (amp_factor[k_adc] * pool.scale)[:, None]
        n_idx = np.minimum((t_spk * fs).astype(int), n_int - 1)
        trains = np.zeros(2 * _N_BASIS_WIDTHS * n_int)
        for o in range(2):
            base = o * _N_BASIS_WIDTHS
            trains += np.bincount((base + s_i) * n_int + n_idx, spk_c[:, o] * s_lo,
                                  minlength=trains.size)
            trains += np.bincount((base + s_i + 1) * n_int + n_idx, spk_c[:, o] * s_hi,
                                  minlength=trains.size)
        trains = trains.reshape(2 * _N_BASIS_WIDTHS, n_int)
        conv = scipy.signal.fftconvolve(trains, kernels.reshape(2 * _N_BASIS_WIDTHS, -1),
                                  mode="same", axes=1)
        return conv.sum(axis=0)


@dataclass(frozen=True)
class _PoolMuaps:
    """One pool's MUAPs, as :meth:`MotorUnitEmgGenerator._muap_train` sums them.

    Attributes
    ----------
    unit_width_s : ndarray, shape (n_units,)
        Each unit's MUAP width, s.
    coef : ndarray, shape (n_units, 2)
        Each unit's weights of the first and second Gaussian derivative.
    basis_width_s : ndarray, shape (n_basis,)
        Basis widths the units' widths are interpolated between, s.
    kernels : ndarray, shape (2, n_basis, n_taps)
        Unit-energy kernels of both orders at the basis widths.
    scale : float
        Normalization to RMS about 1 at full drive.
    """

    unit_width_s: np.ndarray
    coef: np.ndarray
    basis_width_s: np.ndarray
    kernels: np.ndarray
    scale: float


def _width_weights(
    width_s: np.ndarray, basis_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear weights on log-width between adjacent basis widths: (w_lo, w_hi, index_lo)."""
    lw = np.log(np.clip(width_s, basis_s[0], basis_s[-1]))
    lb = np.log(basis_s)
    i = np.clip(np.searchsorted(lb, lw, side="right") - 1, 0, basis_s.size - 2)
    frac = (lw - lb[i]) / (lb[i + 1] - lb[i])
    return 1.0 - frac, frac, i
