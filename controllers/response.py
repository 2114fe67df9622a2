"""Frequency response and poles of a SISO state-space loop from its matrices, numpy only.

:func:`controllers.plant.frequency_response` evaluates state-space systems here; the report
(:mod:`scenarios.report`) draws stored loops with it without importing python-control.
"""

from __future__ import annotations

import numpy as np


def state_space_response(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray,
                         dt_s: float | None, omega_rad_s: np.ndarray) -> np.ndarray:
    """Complex response ``C (pI - A)^-1 B + D`` of a SISO system, shape (n_freqs,).

    One batched linear solve over all frequencies.

    Parameters
    ----------
    a, b, c, d : ndarray
        State-space matrices, shapes (n, n), (n, 1), (1, n), (1, 1); only the first input
        and output are used.
    dt_s : float or None
        Sampling period, s (``p = exp(j w dt)``); ``None`` for a continuous system
        (``p = j w``).
    omega_rad_s : ndarray
        Frequencies, rad/s.

    Raises
    ------
    numpy.linalg.LinAlgError
        A frequency lies on a pole.
    """
    omega = np.asarray(omega_rad_s, dtype=float).reshape(-1)
    point = np.exp(1j * omega * dt_s) if dt_s else 1j * omega
    a = np.atleast_2d(np.asarray(a, dtype=float))
    d0 = float(np.asarray(d, dtype=float).reshape(-1)[0])
    if a.size == 0:
        return np.full(omega.shape, d0, dtype=complex)
    b = np.asarray(b, dtype=float).reshape(a.shape[0], -1)[:, :1]
    c = np.asarray(c, dtype=float).reshape(-1, a.shape[0])[:1]
    m = point[:, None, None] * np.eye(a.shape[0]) - a
    with np.errstate(all="ignore"):
        x = np.linalg.solve(m, np.broadcast_to(b.astype(complex), (point.size, *b.shape)))
    return np.einsum("j,ijk->i", c[0], x) + d0


def closed_loop_poles(a: np.ndarray, b: np.ndarray, c: np.ndarray,
                      d: np.ndarray) -> np.ndarray:
    """Poles of ``L / (1 + L)`` (negative unit feedback) of the SISO open loop ``(A, B, C, D)``:
    the eigenvalues of ``A - B C / (1 + D)``."""
    a = np.atleast_2d(np.asarray(a, dtype=float))
    if a.size == 0:
        return np.zeros(0, dtype=complex)
    b = np.asarray(b, dtype=float).reshape(a.shape[0], -1)[:, :1]
    c = np.asarray(c, dtype=float).reshape(-1, a.shape[0])[:1]
    d0 = float(np.asarray(d, dtype=float).reshape(-1)[0])
    return np.linalg.eigvals(a - b @ c / (1.0 + d0)).astype(complex)
