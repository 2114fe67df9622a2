"""Baseline force estimators the paper compares against, plus simple references.

All work in normalized units (features and force scaled 0..1 on identification
data) and follow :class:`estimation.state_space.SSEstimator`'s interface:
``fit(U, y)``, ``predict(U, y=None, mode=...)``, ``streaming(mode, scaling=None)``
and a class attribute ``modes``.
"""

from estimation.baselines.lda_qpf import LDAQPF
from estimation.baselines.mlp import MLPBaseline
from estimation.baselines.narx import NARXBaseline
from estimation.baselines.persistence import Persistence
from estimation.baselines.single_feature import SingleFeatureLinear

__all__ = ["LDAQPF", "MLPBaseline", "NARXBaseline", "Persistence", "SingleFeatureLinear"]
