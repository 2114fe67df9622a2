"""What the prosthesis computes from sEMG: features, identification, filters, baselines, metrics."""

from estimation.features import (
    FEATURES,
    PAPER_CHANNELS,
    FeatureError,
    FeatureSet,
    align_to_windows,
    emg_features,
    extract_features,
)

__all__ = [
    "FEATURES",
    "PAPER_CHANNELS",
    "FeatureError",
    "FeatureSet",
    "align_to_windows",
    "emg_features",
    "extract_features",
]

# Force estimation: identification, filters, baselines, metrics, protocol.
from estimation.base import ForceEstimator  # noqa: E402
from estimation.errors import (  # noqa: E402
    ConstantInputError,
    EstimationInputError,
    InsufficientDataError,
    ModeError,
    RiccatiError,
    UnknownEstimatorError,
    UnstableModelError,
)
from estimation.evaluation import aggregate, evaluate_subject  # noqa: E402
from estimation.kalman import SteadyStateKalman, design_kalman  # noqa: E402
from estimation.metrics import nrmse_fit, r2_score, rmse, total_variation_rate  # noqa: E402
from estimation.order import OrderSelection, select_order  # noqa: E402
from estimation.pipeline import ForcePipeline  # noqa: E402
from estimation.registry import ESTIMATOR_NAMES, make_estimator  # noqa: E402
from estimation.state_space import SSEstimator  # noqa: E402

__all__ += [
    "ESTIMATOR_NAMES",
    "ConstantInputError",
    "EstimationInputError",
    "ForceEstimator",
    "ForcePipeline",
    "InsufficientDataError",
    "ModeError",
    "OrderSelection",
    "RiccatiError",
    "SSEstimator",
    "SteadyStateKalman",
    "UnknownEstimatorError",
    "UnstableModelError",
    "aggregate",
    "design_kalman",
    "evaluate_subject",
    "make_estimator",
    "nrmse_fit",
    "r2_score",
    "rmse",
    "select_order",
    "total_variation_rate",
]
