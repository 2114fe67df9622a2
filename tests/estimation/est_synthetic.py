"""Synthetic data with known answers for the estimation tests (no virtual subjects needed)."""

from __future__ import annotations

import numpy as np

from estimation.rls import difference_transform
from sim.recording import Recording


def simulate_arx(a: np.ndarray, b: np.ndarray, n_samples: int, *, noise_std: float,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``y(k) = sum_j a_j y(k-j) + b . u(k-1) + e(k)`` with uniform inputs.

    Returns ``U`` (n_samples, len(b)) and ``y`` (n_samples,).
    """
    n = len(a)
    U = rng.uniform(0.0, 1.0, size=(n_samples, len(b)))
    e = noise_std * rng.standard_normal(n_samples)
    y = np.zeros(n_samples)
    for k in range(n, n_samples):
        y[k] = np.dot(a, y[k - n:k][::-1]) + np.dot(b, U[k - 1]) + e[k]
    return U, y


def arx_state_space(a: np.ndarray, b: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form ``A, B`` of an ARX model in the paper's difference states (eq. 6).

    With ``x(k) = T [y(k) .. y(k-n+1)]`` the lag form is the companion matrix
    ``Ac`` (first row ``a``) and ``Bc = e1 b^T``; so ``A = T Ac T^-1``, ``B = T Bc``.
    """
    n = len(a)
    Ac = np.zeros((n, n))
    Ac[0] = a
    Ac[1:, :-1] = np.eye(n - 1)
    Bc = np.zeros((n, len(b)))
    Bc[0] = b
    T = difference_transform(n, dt_s)
    return T @ Ac @ np.linalg.inv(T), T @ Bc


def squeeze_intent(fs_hz: float, duration_s: float, levels=(0.3, 0.55, 0.9)) -> np.ndarray:
    """Three smooth squeezes of increasing level, shape (n_samples,), 0..1."""
    t = np.arange(int(duration_s * fs_hz)) / fs_hz
    intent = np.zeros_like(t)
    period = duration_s / len(levels)
    for i, level in enumerate(levels):
        start = i * period + 0.25 * period
        stop = start + 0.45 * period
        rise = np.clip((t - start) / 0.8, 0, 1) * np.clip((stop - t) / 0.8 + 1, 0, 1)
        intent = np.maximum(intent, level * (0.5 - 0.5 * np.cos(np.pi * np.clip(rise, 0, 1))))
    return intent


def toy_recording(*, fs_hz: float = 200.0, duration_s: float = 30.0, seed: int = 0,
                  with_force: bool = True) -> Recording:
    """MYO-like int8 sEMG whose amplitude follows a squeeze profile, plus FSR-like force.

    Channel ``c`` has amplitude ``1.5 + g_c * intent`` LSB; the force is
    ``40 N * intent`` through a first-order lag (tau 80 ms) with 0.2 N noise.
    """
    rng = np.random.default_rng(seed)
    intent = squeeze_intent(fs_hz, duration_s)
    gains = np.array([3, 4, 5, 6, 8, 25, 20, 22], dtype=float)
    amp = 1.5 + intent[:, None] * gains[None, :]
    emg = np.clip(np.round(amp * rng.standard_normal((intent.size, 8))), -128, 127)
    alpha = 1.0 - np.exp(-1.0 / (0.08 * fs_hz))
    lagged = np.zeros_like(intent)
    for k in range(1, intent.size):
        lagged[k] = lagged[k - 1] + alpha * (intent[k] - lagged[k - 1])
    force = 40.0 * lagged + 0.2 * rng.standard_normal(intent.size)
    return Recording(emg=emg.astype(np.int8), fs_hz=fs_hz,
                     force_n=force if with_force else None, intent=intent,
                     metadata={"toy": True, "seed": seed}, source=f"toy{seed}")


def synthetic_corpus(*, n_inputs: int, n_subjects: int, seed: int, population: str = "default",
                     n_windows: int = 160) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """A pretraining corpus for any number of inputs (``estimation.transfer`` tests).

    Per subject: a force of repeated raised-sine squeezes and features that follow its
    square root with subject gains and noise, min-max scaled on the first half.
    """
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n_subjects):
        t = np.arange(n_windows)
        y = np.clip(np.sin(2 * np.pi * t / 40.0), 0, None) * rng.uniform(0.5, 1.0)
        U = rng.uniform(0.5, 1.5, n_inputs) * np.sqrt(y)[:, None] \
            + 0.03 * rng.standard_normal((n_windows, n_inputs))
        n_id = n_windows // 2
        span = np.ptp(U[:n_id], axis=0)
        span[span == 0] = 1.0
        out.append(((U - U[:n_id].min(axis=0)) / span,
                    (y - y[:n_id].min()) / np.ptp(y[:n_id]), n_id))
    return out


#: Small pretraining settings on :func:`synthetic_corpus` (registered as "synthetic-test").
SMALL_TRANSFER = {"corpus": "synthetic-test", "pretrain_subjects": 4, "pretrain_epochs": 5,
                  "hidden": (8,), "n_networks": 2, "validation_subjects": 2}


def register_synthetic_corpus() -> None:
    """Register :func:`synthetic_corpus` as ``"synthetic-test"`` (idempotent)."""
    from estimation.corpora import register_corpus

    register_corpus("synthetic-test", synthetic_corpus, replace=True)
