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
