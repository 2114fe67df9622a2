"""Real-time streams and batch responses of affine LTI estimators.

A stream serves one estimator sample by sample (the closed loop, a prosthesis)::

    stream = fitted.streaming(mode="free_run")   # or "one_step"
    stream.reset()
    for u in windows:                           # u: features of the newest window
        force_n = stream.step(u, y_prev=None)   # y_prev: measured force at k-1 (one_step)

``step`` at tick ``k`` receives ``u(k)`` and, in ``one_step`` mode, the measured
force ``y(k-1)``, and returns ``yhat(k)``; so the ``k``-th return value equals
``predict(U, y, mode)[k]`` of the same estimator. ``y_prev`` is ignored at the
first call (there is no ``k - 1``) and never needed in ``free_run`` mode.

Two timings cover every linear estimator here:

- :class:`DelayedLTIStream`: ``s(k) = F s(k-1) + Gu u(k-1) + Gy y(k-1)``,
  ``yhat(k) = h s(k)``, ``s(0) = 0`` -- the paper's state-space model and its
  Kalman predictor (eq. 16), whose estimate uses inputs up to ``k - 1``.
- :class:`DirectLTIStream`: ``s(k) = F s(k-1) + G u(k)``,
  ``yhat(k) = h s(k) + d u(k)`` -- latent-state Kalman decoders and static
  linear fits, which use the current window.

Min-max input/output scaling is folded into one matrix ``M`` so that a step is a
slice write and one ``M.dot(z, out=w)`` on preallocated buffers (no array
allocation). Batch responses use ``scipy.signal.lfilter`` on the transfer
functions (one numerator per input, shared denominator ``det(zI - F)``);
:func:`delayed_response_affine` folds the scaling into the numerator weights
so that raw features stream through one matrix product.
"""

from __future__ import annotations

import numpy as np
import scipy.signal
from scipy.linalg.blas import daxpy

from estimation.errors import EstimationInputError, ModeError
from estimation.normalize import MinMaxScaling


def _fold_scaling(
    G: np.ndarray, offset: np.ndarray, span: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Express ``G (v - offset) / span`` as ``G' v + g'``; returns ``(G', g')``."""
    Gs = G / span
    return Gs, -Gs @ offset


def _transfer(F: np.ndarray, G: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Transfer functions ``h (zI - F)^-1 G_j = nums[j] / den`` (shared denominator).

    Returns
    -------
    den : ndarray, shape (n_states + 1,)
        ``det(zI - F)``, leading coefficient 1.
    nums : ndarray, shape (n_inputs, n_states + 1)
        ``det(zI - F + G_j h) - det(zI - F)``; column 0 is zero (strictly proper).
    """
    den = np.real(np.poly(F))
    nums = np.empty((G.shape[1], F.shape[0] + 1))
    for j in range(G.shape[1]):
        nums[j] = np.real(np.poly(F - np.outer(G[:, j], h))) - den
    return den, nums


def _delayed_sum(Z: np.ndarray) -> np.ndarray:
    """``fir[k] = sum_{lag=1..n_lags} Z[k - lag, lag - 1]`` (terms with ``k < lag`` are 0).

    Parameters
    ----------
    Z : ndarray, shape (n_samples, n_lags)
        Per-lag weighted inputs (one matrix product ``V @ nums[:, 1:]``).

    Returns
    -------
    ndarray, shape (n_samples,)
    """
    n_samples, n_lags = Z.shape
    fir = np.zeros(n_samples)
    for lag in range(1, min(n_lags, n_samples - 1) + 1):
        fir[lag:] += Z[: n_samples - lag, lag - 1]
    return fir


def delayed_response(F: np.ndarray, G: np.ndarray, h: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Output of ``s(k) = F s(k-1) + G v(k-1)``, ``yhat(k) = h s(k)``, ``s(0) = 0``.

    Parameters
    ----------
    F : ndarray, shape (n_states, n_states)
    G : ndarray, shape (n_states, n_inputs)
    h : ndarray, shape (n_states,)
    V : ndarray, shape (n_samples, n_inputs)

    Returns
    -------
    ndarray, shape (n_samples,)
        Computed with ``lfilter`` on ``h (zI - F)^-1 G``: one matrix product of
        ``V`` with the numerators (all lags at once), the lagged sum, and a
        single IIR pass with the shared denominator.
    """
    F = np.atleast_2d(F)
    n_samples = V.shape[0]
    if F.shape[0] == 0:
        return np.zeros(n_samples)
    den, nums = _transfer(F, G, h)
    return scipy.signal.lfilter([1.0], den, _delayed_sum(V @ nums[:, 1:]))


def delayed_response_affine(
    F: np.ndarray,
    Gu: np.ndarray,
    Gy: np.ndarray | None,
    h: np.ndarray,
    U: np.ndarray,
    y: np.ndarray | None = None,
    *,
    scaling: MinMaxScaling | None = None,
) -> np.ndarray:
    """Batch output of :class:`DelayedLTIStream` with the scaling folded into the weights.

    ``yhat(k) = h s(k)``, ``s(k) = F s(k-1) + Gu u_n(k-1) + Gy y_n(k-1)``, ``s(0) = 0``,
    with ``u_n = (u - u_min) / u_span`` and ``y_n = (y - y_min) / y_span``; the
    result is ``y_span yhat + y_min`` (newtons). Instead of normalizing the
    inputs (two passes over ``U`` and a stacked copy) the per-lag numerator
    weights absorb the scaling: for lag ``l`` and feature ``j``::

        w_u[j, l] = y_span nums_u[j, l] / u_span[j],   w_y[l] = nums_y[l]
        c[l]      = -(sum_j w_u[j, l] u_min[j] + w_y[l] y_min)

    so ``fir(k) = sum_l (w_u[:, l] . u(k - l) + w_y[l] y(k - l) + c[l])`` over the
    lags ``l <= k`` and ``yhat_N = lfilter(1, den, fir) + y_min``. Equal to the
    normalized path and to the stream to rounding (1e-12 relative, tested).

    Parameters
    ----------
    F, Gu, Gy, h : the stream's matrices (``Gy`` None: the force is not used)
    U : ndarray, shape (n_samples, n_inputs)
        Raw features (normalized when ``scaling`` is None).
    y : ndarray, shape (n_samples,), optional
        Measured force in N; required when ``Gy`` is given.
    scaling : MinMaxScaling, optional

    Returns
    -------
    ndarray, shape (n_samples,)
        Estimate in N (normalized units without ``scaling``).
    """
    F = np.atleast_2d(np.asarray(F, dtype=np.float64))
    n_samples, m = U.shape
    if scaling is None:
        u_min, u_span, y_min, y_span = np.zeros(m), np.ones(m), 0.0, 1.0
    else:
        u_min, u_span = scaling.u_min, scaling.u_span
        y_min, y_span = float(scaling.y_min_n), float(scaling.y_span_n)
    ns = F.shape[0]
    if ns == 0 or n_samples == 0:
        return np.full(n_samples, y_min)
    G = Gu if Gy is None else np.column_stack([Gu, np.asarray(Gy, dtype=np.float64)])
    den, nums = _transfer(F, G, h)
    w_u = nums[:m, 1:] * (y_span / u_span)[:, None]  # (m, ns)
    offset = -(u_min @ w_u)  # (ns,)
    Z = U @ w_u  # (n_samples, ns), one pass over U
    if Gy is not None:
        w_y = nums[m, 1:]
        offset -= w_y * y_min
        Zf = Z.reshape(-1)
        for lag in range(ns):  # Z[:, lag] += w_y[lag] * y, in place (BLAS daxpy)
            daxpy(y, Zf, n_samples, w_y[lag], 0, 1, lag, ns)
    fir = _delayed_sum(Z)
    # the constant of lag l enters from sample l on
    partial = np.cumsum(offset)
    head = min(ns, n_samples - 1)
    fir[1:head + 1] += partial[:head]
    fir[ns + 1:] += partial[-1]
    out = scipy.signal.lfilter([1.0], den, fir)
    out += y_min
    return out


class _AffineStream:
    """Shared buffers and scaling for the LTI streams."""

    mode: str

    def __init__(self, n_states: int, n_inputs: int, scaling: MinMaxScaling | None) -> None:
        self.n_states = n_states
        self.n_inputs = n_inputs
        if scaling is None:
            self._u_min, self._u_span = np.zeros(n_inputs), np.ones(n_inputs)
            self._y_min, self._y_span = 0.0, 1.0
        else:
            if scaling.u_min.shape != (n_inputs,):
                raise EstimationInputError(
                    f"scaling has {scaling.u_min.size} inputs, the estimator {n_inputs}"
                )
            self._u_min, self._u_span = scaling.u_min, scaling.u_span
            self._y_min, self._y_span = scaling.y_min_n, scaling.y_span_n

    def _output_row(self, h: np.ndarray, M_state: np.ndarray, extra: np.ndarray) -> np.ndarray:
        """Output row in output units: ``y_span * (h M_state + extra)`` plus ``y_min`` on 1."""
        row = self._y_span * (h @ M_state + extra)
        row[-1] += self._y_min
        return row


class DelayedLTIStream(_AffineStream):
    """Stream of ``s(k) = F s(k-1) + Gu u(k-1) + Gy y(k-1)``, ``yhat(k) = h s(k)``.

    Parameters
    ----------
    F : ndarray, shape (n_states, n_states)
    Gu : ndarray, shape (n_states, n_inputs)
        Gain on the (normalized) features.
    Gy : ndarray, shape (n_states,) or None
        Gain on the measured (normalized) force; ``None`` for a stream that
        never uses the force (``free_run``).
    h : ndarray, shape (n_states,)
    mode : str
        Label carried by the stream (``"one_step"`` or ``"free_run"``).
    scaling : MinMaxScaling, optional
        If given, ``step`` takes raw features and force in newtons and returns
        newtons; otherwise everything is in normalized units.
    """

    def __init__(
        self,
        F: np.ndarray,
        Gu: np.ndarray,
        Gy: np.ndarray | None,
        h: np.ndarray,
        *,
        mode: str,
        scaling: MinMaxScaling | None = None,
    ) -> None:
        ns, m = Gu.shape
        super().__init__(ns, m, scaling)
        self.mode = mode
        self.uses_force = Gy is not None
        Gu_r, g0 = _fold_scaling(Gu, self._u_min, self._u_span)
        blocks = [F, Gu_r]
        if Gy is not None:
            Gy_r = np.asarray(Gy, dtype=np.float64).reshape(ns, 1) / self._y_span
            g0 = g0 - Gy_r[:, 0] * self._y_min
            blocks.append(Gy_r)
        state_rows = np.hstack(blocks + [g0[:, None]])
        out_row = self._output_row(np.asarray(h, dtype=np.float64), state_rows,
                                   np.zeros(state_rows.shape[1]))
        self._M = np.ascontiguousarray(np.vstack([state_rows, out_row]))
        self._z = np.zeros(self._M.shape[1])
        self._w = np.zeros(ns + 1)
        self._z_state, self._w_state = self._z[:ns], self._w[:ns]
        self._z_u = self._z[ns:ns + m]
        self._mdot = self._M.dot  # bound ndarray.dot(z, out): the fastest small gemv
        self._iy = ns + m
        self._y_first = float(self._y_min)  # h s(0) = 0 in normalized units
        self._first = True
        self.reset()

    def reset(self) -> None:
        """Zero the state and forget the stored input (start of a new episode)."""
        self._z[:] = 0.0
        self._z[-1] = 1.0
        self._first = True

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Consume ``u(k)`` (and ``y(k-1)``); return ``yhat(k)`` (N if scaled).

        Raises
        ------
        ModeError
            ``y_prev`` missing after the first call of a stream that uses the force.
        """
        if self._first:
            self._z_u[...] = u
            self._first = False
            return self._y_first
        if self.uses_force:
            if y_prev is None:
                raise ModeError(f"{self.mode} stream needs y_prev (the force at k-1), got None")
            self._z[self._iy] = y_prev
        self._mdot(self._z, self._w)
        self._z_state[...] = self._w_state
        self._z_u[...] = u
        return self._w.item(-1)


class DirectLTIStream(_AffineStream):
    """Stream of ``s(k) = F s(k-1) + G u(k) + g``, ``yhat(k) = h s(k) + d u(k) + d0``.

    Parameters
    ----------
    F : ndarray, shape (n_states, n_states)
        May be empty (0, 0) for a static map.
    G : ndarray, shape (n_states, n_inputs)
    h : ndarray, shape (n_states,)
    d : ndarray, shape (n_inputs,)
    g : ndarray, shape (n_states,), optional
    d0 : float
        Offsets in normalized units.
    mode : str
    scaling : MinMaxScaling, optional
        As for :class:`DelayedLTIStream`.
    """

    uses_force = False

    def __init__(
        self,
        F: np.ndarray,
        G: np.ndarray,
        h: np.ndarray,
        d: np.ndarray,
        *,
        g: np.ndarray | None = None,
        d0: float = 0.0,
        mode: str = "free_run",
        scaling: MinMaxScaling | None = None,
    ) -> None:
        G = np.atleast_2d(np.asarray(G, dtype=np.float64))
        ns = np.asarray(F).shape[0]
        m = np.asarray(d).size
        G = G.reshape(ns, m)
        super().__init__(ns, m, scaling)
        self.mode = mode
        G_r, g0 = _fold_scaling(G, self._u_min, self._u_span)
        if g is not None:
            g0 = g0 + g
        state_rows = np.hstack([np.asarray(F, dtype=np.float64).reshape(ns, ns), G_r,
                                g0[:, None]])
        d_r, d00 = _fold_scaling(np.asarray(d, dtype=np.float64)[None, :], self._u_min,
                                 self._u_span)
        extra = np.concatenate([np.zeros(ns), d_r[0], [d00[0] + d0]])
        out_row = self._output_row(np.asarray(h, dtype=np.float64).reshape(ns), state_rows,
                                   extra)
        self._M = np.ascontiguousarray(np.vstack([state_rows, out_row]))
        self._z = np.zeros(ns + m + 1)
        self._w = np.zeros(ns + 1)
        self._z_state, self._w_state = self._z[:ns], self._w[:ns]
        self._z_u = self._z[ns:ns + m]
        self._mdot = self._M.dot
        self.reset()

    def reset(self) -> None:
        """Zero the state."""
        self._z[:] = 0.0
        self._z[-1] = 1.0

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Consume ``u(k)``; return ``yhat(k)``. ``y_prev`` is ignored."""
        self._z_u[...] = u
        self._mdot(self._z, self._w)
        self._z_state[...] = self._w_state
        return self._w.item(-1)


def direct_response(
    F: np.ndarray, G: np.ndarray, h: np.ndarray, d: np.ndarray, U: np.ndarray,
    *, g: np.ndarray | None = None, d0: float = 0.0,
) -> np.ndarray:
    """Batch output of :class:`DirectLTIStream`'s system with ``s(-1) = 0``, shape (n_samples,).

    With ``r(k) = s(k-1)`` the system is delayed: ``r(k+1) = F r(k) + G u(k) + g`` and
    ``yhat(k) = h F r(k) + (h G + d) u(k) + h g + d0``.
    """
    U = np.asarray(U, dtype=np.float64)
    F = np.atleast_2d(np.asarray(F, dtype=np.float64))
    ns = np.asarray(h).size
    direct = U @ (h @ G.reshape(ns, -1) + d) + d0 if ns else U @ d + d0
    if ns == 0:
        return direct
    g = np.zeros(ns) if g is None else np.asarray(g, dtype=np.float64)
    V = np.hstack([U, np.ones((U.shape[0], 1))])
    Gv = np.hstack([G.reshape(ns, -1), g[:, None]])
    return delayed_response(F, Gv, h @ F, V) + direct + float(h @ g)


class ScaledStream:
    """Wrap a stream in normalized units so that it takes raw features and newtons.

    Used for nonlinear estimators (MLP, NARX, LDA + QPF) whose scaling cannot be
    folded into a matrix. ``step`` normalizes ``u`` into a preallocated buffer.
    """

    def __init__(self, inner: object, scaling: MinMaxScaling) -> None:
        self._inner = inner
        self.mode = inner.mode
        self.uses_force = inner.uses_force
        self._u_min = scaling.u_min.copy()
        self._u_inv = 1.0 / scaling.u_span
        self._y_min = scaling.y_min_n
        self._y_span = scaling.y_span_n
        self._buf = np.empty_like(self._u_min)

    def reset(self) -> None:
        """Reset the wrapped stream."""
        self._inner.reset()

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Raw ``u(k)`` and ``y(k-1)`` in N in; ``yhat(k)`` in N out."""
        np.subtract(u, self._u_min, out=self._buf)
        np.multiply(self._buf, self._u_inv, out=self._buf)
        y_n = None if y_prev is None else (y_prev - self._y_min) / self._y_span
        return self._inner.step(self._buf, y_n) * self._y_span + self._y_min


def scaled(stream: object, scaling: MinMaxScaling | None) -> object:
    """``stream`` itself, or wrapped in :class:`ScaledStream` when ``scaling`` is given."""
    return stream if scaling is None else ScaledStream(stream, scaling)
