"""What the prosthesis computes from sEMG: features, identification, filters, baselines, metrics.

:mod:`estimation.features` windows sEMG into MAV/RMS/WL features,
:mod:`estimation.state_space` and :mod:`estimation.kalman` identify the paper's
state-space model and its Kalman predictor, :mod:`estimation.baselines` and
:mod:`estimation.deployable` hold the other estimators, :mod:`estimation.metrics`
and :mod:`estimation.evaluation` score them as the paper does, and
:mod:`estimation.registry` names them (:func:`~estimation.registry.register_estimator`).
:mod:`estimation.protocols` states what an estimator and its stream provide.

May import: numpy, scipy, scikit-learn, python-control, and :mod:`sim` only for
the types it exchanges (:class:`sim.recording.Recording`, :mod:`sim.errors`,
:mod:`sim.registry`). Never :mod:`controllers` or :mod:`scenarios`.

The public names below are imported on first use, so that ``import
estimation.registry`` (listing the estimator names) does not import scikit-learn.
"""

from sim.lazy import lazy_exports

#: Public names, imported on first use: ``name -> module``.
_LAZY = {
    "FEATURES": "estimation.features", "PAPER_CHANNELS": "estimation.features",
    "FeatureError": "estimation.features", "FeatureSet": "estimation.features",
    "align_to_windows": "estimation.features", "emg_features": "estimation.features",
    "extract_features": "estimation.features",
    "ForceEstimator": "estimation.base",
    "ConstantInputError": "estimation.errors", "EstimationInputError": "estimation.errors",
    "InsufficientDataError": "estimation.errors", "ModeError": "estimation.errors",
    "RiccatiError": "estimation.errors", "UnstableModelError": "estimation.errors",
    "UnknownEstimatorError": "estimation.registry",
    "aggregate": "estimation.evaluation", "evaluate_subject": "estimation.evaluation",
    "SteadyStateKalman": "estimation.kalman", "design_kalman": "estimation.kalman",
    "nrmse_fit": "estimation.metrics", "r2_score": "estimation.metrics",
    "rmse": "estimation.metrics", "total_variation_rate": "estimation.metrics",
    "OrderSelection": "estimation.order", "select_order": "estimation.order",
    "ForcePipeline": "estimation.pipeline",
    "ESTIMATOR_NAMES": "estimation.registry", "make_estimator": "estimation.registry",
    "register_estimator": "estimation.registry",
    "Estimator": "estimation.protocols", "Stream": "estimation.protocols",
    "SSEstimator": "estimation.state_space",
}
__all__ = sorted(_LAZY)


__getattr__ = lazy_exports(__name__, _LAZY)
