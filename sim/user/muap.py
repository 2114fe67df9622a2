"""Motor-unit action potential (MUAP) waveforms and their power spectra.

A MUAP is modelled as a mix of the first and second derivative of a Gaussian
of width ``sigma`` (normalized so that the peak of the envelope is 1)::

    psi_1(t) = -(t / sigma) exp(-t^2 / (2 sigma^2))         (biphasic)
    psi_2(t) = (1 - t^2 / sigma^2) exp(-t^2 / (2 sigma^2))  (triphasic)

Their Fourier transforms are in quadrature, so the power spectrum of
``c1 psi_1 + c2 psi_2`` is the sum of the two::

    |X(f)|^2 = 2 pi sigma^4 w^2 e^{-w^2 sigma^2} (c1^2 + c2^2 sigma^2 w^2),  w = 2 pi f.

With ``sigma`` about 1.5 ms the spectrum peaks near 100 Hz, as surface EMG does.
"""

from __future__ import annotations

import numpy as np


def gaussian_derivative(t_s: np.ndarray, width_s: float, order: int) -> np.ndarray:
    """Normalized Gaussian derivative waveform (order 1 or 2) sampled at ``t_s``.

    Parameters
    ----------
    t_s : ndarray
        Times in seconds (any shape), centred on the MUAP.
    width_s : float
        Gaussian sigma in seconds.
    order : {1, 2}
        Derivative order: 1 biphasic, 2 triphasic.

    Returns
    -------
    ndarray
        Dimensionless waveform, same shape as ``t_s``.
    """
    u = np.asarray(t_s, dtype=float) / width_s
    g = np.exp(-0.5 * u * u)
    if order == 1:
        return -u * g
    if order == 2:
        return (1.0 - u * u) * g
    raise ValueError(f"order must be 1 or 2, found {order!r}")


def muap_psd(f_hz: np.ndarray, width_s: float, second_order_weight: float = 0.5) -> np.ndarray:
    """Power spectrum of a random MUAP mix (expected over unit shapes).

    Parameters
    ----------
    f_hz : ndarray
        Frequencies in hertz (any shape; negative allowed).
    width_s : float
        Gaussian sigma in seconds.
    second_order_weight : float
        Expected ``c2^2`` with ``c1^2 + c2^2 = 1`` (0.5 for a uniform mix angle).

    Returns
    -------
    ndarray
        PSD up to a constant factor, same shape as ``f_hz``.
    """
    w = 2.0 * np.pi * np.asarray(f_hz, dtype=float)
    ws2 = (w * width_s) ** 2
    return ws2 * np.exp(-ws2) * ((1.0 - second_order_weight) + second_order_weight * ws2)
