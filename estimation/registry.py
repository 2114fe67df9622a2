"""Estimators by name: ``make_estimator(name, **params)``.

============  ==============================================================
name          estimator (modes)
============  ==============================================================
ss_kf         paper's SS model with steady-state Kalman predictor (both)
ss            paper's SS model without Kalman filter (both)
mlp           MLP, 4 logistic hidden units, RMSprop-like Adam (both, no force)
narx          NARX network, delays = 4 (one_step series-parallel, free_run)
lda_qpf       LDA to 1-D + quadratic (both, no force)
latent_kf     force as latent Kalman state, sEMG as observations (both, no force)
persistence   yhat(k) = y(k-1) (one_step)
features_mav  linear fit of the MAV columns (both, no force); also _rms, _wl
ridge         ridge on sqrt-compressed features, lags, smoother chosen on validation (deployable)
gbt           ridge plus boosted trees on its residuals (deployable)
ss_sim        paper SS structure refined on the free-run simulation error (free_run)
============  ==============================================================

Every estimator is a scikit-learn regressor (:class:`estimation.base.ForceEstimator`):
``clone``, ``get_params`` / ``set_params``, ``score`` and ``cross_val_score`` work on
the bare estimators and on the :class:`~estimation.pipeline.ForcePipeline` that
``make_estimator`` returns (its parameters are ``estimator__<name>``). A new
estimator subclasses ``ForceEstimator`` and is added to ``_FACTORIES``.
"""

from __future__ import annotations

from collections.abc import Callable

from estimation.baselines import LDAQPF, MLPBaseline, NARXBaseline, Persistence, SingleFeatureLinear
from estimation.deployable import BoostedLogRidge, LogRidge
from estimation.errors import UnknownEstimatorError
from estimation.latent_kf import LatentKalman
from estimation.pipeline import ForcePipeline
from estimation.ss_sim import SimulationErrorSS
from estimation.state_space import SSEstimator

_FACTORIES: dict[str, Callable[..., object]] = {
    "ss_kf": lambda **kw: SSEstimator(kalman=True, **kw),
    "ss": lambda **kw: SSEstimator(kalman=False, **kw),
    "mlp": MLPBaseline,
    "narx": NARXBaseline,
    "lda_qpf": LDAQPF,
    "latent_kf": LatentKalman,
    "persistence": Persistence,
    "features_mav": lambda **kw: SingleFeatureLinear(feature="mav", **kw),
    "features_rms": lambda **kw: SingleFeatureLinear(feature="rms", **kw),
    "features_wl": lambda **kw: SingleFeatureLinear(feature="wl", **kw),
    "ridge": LogRidge,
    "gbt": BoostedLogRidge,
    "ss_sim": SimulationErrorSS,
}

#: Every registered estimator name, in the JSON contract's order.
ESTIMATOR_NAMES = tuple(_FACTORIES)


def make_estimator(name: str, *, normalize: bool = True, **params: object) -> object:
    """A fresh estimator by name.

    Parameters
    ----------
    name : str
        One of :data:`ESTIMATOR_NAMES`.
    normalize : bool
        Wrap in :class:`~estimation.pipeline.ForcePipeline` (raw features and
        newtons in and out). ``False`` returns the bare normalized-unit estimator.
    **params
        Hyperparameters of the estimator (e.g. ``order=4``, ``random_state=rng``).

    Raises
    ------
    UnknownEstimatorError
        ``name`` is not registered; the message lists the valid names.
    """
    try:
        factory = _FACTORIES[name]
    except KeyError:
        raise UnknownEstimatorError(
            f"unknown estimator {name!r}; expected one of {', '.join(ESTIMATOR_NAMES)}"
        ) from None
    est = factory(**params)
    return ForcePipeline(est) if normalize else est
