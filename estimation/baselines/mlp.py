"""Multi-layer perceptron baseline (paper section 3.4.1) on scikit-learn.

Three layers, logistic hidden units (as many as the SS order, 4), linear output,
MSE loss, mini-batch 1, at most 1000 epochs. scikit-learn has no RMSprop; Adam
with ``beta_1 = 0`` is RMSprop (decay ``beta_2``) with bias correction, so that
is used. Training stops early when the score on a validation split held out of
the identification data (``validation_fraction``, scikit-learn's
``early_stopping``) has not improved by ``tol`` for ``n_iter_no_change``
epochs, and the weights of the best validation epoch are kept; never on the
training loss. ``n_epochs_`` records the real count.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from scipy.special import expit
from sklearn.exceptions import ConvergenceWarning
from sklearn.neural_network import MLPRegressor

from estimation.base import ForceEstimator
from estimation.deployable import check_period
from estimation.errors import check_features, check_mode, check_target
from estimation.normalize import MinMaxScaling
from estimation.streaming import scaled


def seed_from(rng: np.random.Generator | int | None) -> int:
    """An ``int`` seed for scikit-learn's ``random_state`` drawn from ``rng``."""
    return int(np.random.default_rng(rng).integers(0, 2**31 - 1))


def fit_quietly(net: MLPRegressor, X: np.ndarray, y: np.ndarray) -> bool:
    """Fit ``net``; return True if it stopped on the loss criterion before ``max_iter``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        net.fit(X, y)
    return net.n_iter_ < net.max_iter


class MLPForward:
    """Allocation-free forward pass of a logistic multilayer perceptron with a linear output.

    The one forward pass of every network griploop streams: the baselines' regressors
    (``mlp``, ``narx``) and the pretrained ensembles (``transfer_mlp``, ``adaptive_mlp``).

    Parameters
    ----------
    net : MLPRegressor or estimation.pretrained_store.Network
        A fitted scikit-learn regressor (``coefs_``, ``intercepts_``) or stored weights
        (``coefs``, ``intercepts``): per layer, weights (n_in, n_out) and biases (n_out,);
        logistic hidden layers, one linear output.
    """

    def __init__(self, net: Any) -> None:
        coefs = getattr(net, "coefs_", None)
        coefs, intercepts = (net.coefs, net.intercepts) if coefs is None else (
            coefs, net.intercepts_)
        # per hidden layer: W^T (n_out, n_in), bias, output buffer
        self._hidden = [(np.ascontiguousarray(W.T), np.array(b, dtype=float), np.empty(len(b)))
                        for W, b in zip(coefs[:-1], intercepts[:-1], strict=True)]
        self._w_out = np.array(coefs[-1][:, 0], dtype=float)
        self._b_out = float(intercepts[-1][0])
        self._odot = self._w_out.dot

    def __call__(self, x: np.ndarray) -> float:
        """Network output for one input vector ``x`` (n_in,)."""
        h = x
        for Wt, b, out in self._hidden:
            Wt.dot(h, out)
            out += b
            expit(out, out=out)
            h = out
        return float(self._odot(h)) + self._b_out


class MLPBaseline(ForceEstimator):
    """Static MLP from the current window's features to force.

    Parameters
    ----------
    hidden : int
        Hidden logistic units (paper: 4, the SS order).
    max_epochs : int
        Epoch limit (paper: 1000).
    learning_rate : float
        RMSprop step size.
    rho : float
        RMSprop decay of the squared-gradient average (Adam's ``beta_2``).
    tol, n_iter_no_change :
        Early stop on the validation-split score.
    validation_fraction : float
        Share of the identification data held out for early stopping.
    alpha : float
        L2 penalty on the weights.
    dt_s : float
        Window increment in seconds; streams refuse a shorter ``period_s``.
    batch_size : int
        Mini-batch size (paper: 1).
    random_state : numpy.random.Generator, int or None
        Seeds weight initialization and shuffling.

    Attributes
    ----------
    net_ : MLPRegressor
    n_epochs_ : int
    converged_ : bool
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide

    def __init__(self, *, hidden: int = 4, max_epochs: int = 1000, learning_rate: float = 1e-2,
                 rho: float = 0.9, tol: float = 1e-4, n_iter_no_change: int = 10,
                 validation_fraction: float = 0.2, alpha: float = 1e-4, dt_s: float = 0.125,
                 batch_size: int = 1,
                 random_state: np.random.Generator | int | None = None) -> None:
        self.hidden = hidden
        self.batch_size = batch_size
        self.validation_fraction = validation_fraction
        self.alpha = alpha
        self.dt_s = dt_s
        self.max_epochs = max_epochs
        self.learning_rate = learning_rate
        self.rho = rho
        self.tol = tol
        self.n_iter_no_change = n_iter_no_change
        self.random_state = random_state

    def _regressors(self, U: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Network inputs for training: the features themselves (NARX adds delays)."""
        return U

    def _target(self, y: np.ndarray) -> np.ndarray:
        """Network training target (NARX subtracts its linear term)."""
        return y

    def _network(self) -> MLPRegressor:
        """The paper's network with these hyperparameters, unfitted: logistic hidden layer,
        Adam with beta_1 = 0 (RMSProp's ``rho`` as beta_2), early stopping on a held-out
        fraction."""
        return MLPRegressor(
            hidden_layer_sizes=(self.hidden,), activation="logistic", solver="adam",
            beta_1=0.0, beta_2=self.rho, learning_rate_init=self.learning_rate,
            batch_size=self.batch_size, max_iter=self.max_epochs, tol=self.tol,
            n_iter_no_change=self.n_iter_no_change, shuffle=True, early_stopping=True,
            validation_fraction=self.validation_fraction, alpha=self.alpha,
            random_state=seed_from(self.random_state),
        )

    def fit(self, U: np.ndarray, y: np.ndarray) -> MLPBaseline:
        """Train on normalized features ``U`` (n_samples, n_inputs) and force ``y``."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        self.net_ = self._network()
        self.converged_ = fit_quietly(self.net_, self._regressors(U, y), self._target(y))
        self.n_epochs_ = int(self.net_.n_iter_)
        self.n_features_in_ = U.shape[1]
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate, shape (n_samples,); ``y`` is ignored."""
        self._mode(mode, y)
        return self.net_.predict(check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__))

    def streaming(self, mode: str = "free_run", *, scaling: MinMaxScaling | None = None,
                  period_s: float | None = None) -> object:
        """A stream running the forward pass per window (``period_s`` >= ``dt_s``)."""
        check_mode(mode, self.modes, "MLPBaseline")
        check_period(period_s, self.dt_s, "MLPBaseline")
        return scaled(_MLPStream(MLPForward(self.net_), mode), scaling)


class _MLPStream:
    uses_force = False

    def __init__(self, forward: MLPForward, mode: str) -> None:
        self._forward = forward
        self.mode = mode

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Force estimate for features ``u(k)`` (normalized)."""
        return self._forward(u)
