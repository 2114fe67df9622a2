"""Interlink FSR 402 read through a voltage divider by a 10-bit ADC (the paper's rig).

Chain (per sample):

1. mechanical saturation of the sensing area:
   ``F_eff = F / (1 + (F / saturation_n)^8)^(1/8)``;
2. resistance ``R = r_ref_ohm * (F_eff / 10 N)^(-alpha)`` (conductance
   nearly proportional to force, as in the datasheet's log-log curve); below
   the turn-on force the sensor is open (``r_open_ohm``);
3. divider ``V / Vcc = r_meas / (r_meas + R)``;
4. ADC: ``code = round(1023 V / Vcc + noise)`` clipped to 0..1023;
5. conversion back to newtons with the *nominal* calibration
   (``alpha = 1``, ``r_ref_ohm = 1 kOhm``), clipped to the 0..50 N range.

The device's own ``alpha`` and ``r_ref_ohm`` differ from nominal (part-to-part
spread), so the measured force carries a realistic nonlinearity error, ADC
quantization (about 1 N per count near 50 N) and saturation.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from sim.errors import GriploopError

NOMINAL_R_REF_OHM = 1e3
REFERENCE_FORCE_N = 10.0
NOMINAL_ALPHA = 1.0


class FSRError(GriploopError, ValueError):
    """FSR settings or force input out of range."""


@dataclass(frozen=True)
class FSR402:
    """One FSR 402 sensor with its divider and ADC.

    Parameters
    ----------
    r_ref_ohm : float
        Sensor resistance at the 10 N reference force (device value).
    alpha : float
        Exponent of the resistance-force law (device value).
    r_meas_ohm : float
        Divider resistor.
    r_open_ohm : float
        Resistance below the turn-on force.
    turn_on_n : float
        Force below which the sensor is open.
    saturation_n : float
        Mechanical saturation force of the sensing area.
    adc_bits : int
        ADC resolution (10 on the paper's Arduino).
    adc_noise_lsb : float
        Gaussian noise std at the ADC input, in counts.
    range_n : float
        Upper end of the calibrated range; readings are clipped to 0..range_n.
    """

    r_ref_ohm: float = NOMINAL_R_REF_OHM
    alpha: float = NOMINAL_ALPHA
    r_meas_ohm: float = 3.3e3
    r_open_ohm: float = 10e6
    turn_on_n: float = 0.2
    saturation_n: float = 60.0
    adc_bits: int = 10
    adc_noise_lsb: float = 0.5
    range_n: float = 50.0

    def __post_init__(self) -> None:
        if min(self.r_ref_ohm, self.alpha, self.r_meas_ohm, self.saturation_n, self.range_n) <= 0:
            raise FSRError(f"FSR402: expected positive resistances and forces, found {self}")
        if not 1 <= self.adc_bits <= 16:
            raise FSRError(f"FSR402.adc_bits: expected 1..16, found {self.adc_bits}")

    @classmethod
    def sample(cls, rng: np.random.Generator) -> FSR402:
        """A device with part-to-part spread: ``r_ref`` 8 % (log-normal), alpha 0.93..1.07."""
        return cls(
            r_ref_ohm=NOMINAL_R_REF_OHM * float(np.exp(0.08 * rng.standard_normal())),
            alpha=float(rng.uniform(0.93, 1.07)),
        )

    @property
    def full_scale(self) -> int:
        """Largest ADC code."""
        return 2**self.adc_bits - 1

    def resistance_ohm(self, force_n: np.ndarray) -> np.ndarray:
        """Sensor resistance for true forces in newtons (same shape)."""
        f = np.clip(np.asarray(force_n, dtype=float), 0.0, None)
        f_eff = f / (1.0 + (f / self.saturation_n) ** 8) ** 0.125
        r = self.r_ref_ohm * (np.maximum(f_eff, 1e-12) / REFERENCE_FORCE_N) ** (-self.alpha)
        return np.where(f_eff >= self.turn_on_n, np.minimum(r, self.r_open_ohm), self.r_open_ohm)

    def adc_codes(self, force_n: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """ADC codes (int, 0..full_scale) for true forces in newtons, same shape."""
        f = np.asarray(force_n, dtype=float)
        if not np.all(np.isfinite(f)):
            raise FSRError("FSR402: force_n contains NaN or inf; expected finite newtons")
        r = self.resistance_ohm(f)
        v = self.r_meas_ohm / (self.r_meas_ohm + r)
        code = np.rint(self.full_scale * v + self.adc_noise_lsb * rng.standard_normal(f.shape))
        return np.clip(code, 0, self.full_scale).astype(int)

    def codes_to_force_n(self, codes: np.ndarray) -> np.ndarray:
        """The rig's nominal calibration: ADC codes back to newtons, clipped to 0..range_n."""
        v = np.clip(np.asarray(codes, dtype=float) / self.full_scale, 0.0, 1.0)
        with np.errstate(divide="ignore"):
            r = np.where(v > 0, self.r_meas_ohm * (1.0 - v) / np.maximum(v, 1e-12), np.inf)
            f = REFERENCE_FORCE_N * (NOMINAL_R_REF_OHM / r) ** (1.0 / NOMINAL_ALPHA)
        return np.clip(np.where(np.isfinite(f), f, self.range_n), 0.0, self.range_n)

    def measure(self, force_n: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measured force in newtons for true forces in newtons (same shape)."""
        return self.codes_to_force_n(self.adc_codes(force_n, rng))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready parameters."""
        return asdict(self)
