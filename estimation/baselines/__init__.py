"""Baseline force estimators the paper compares against, plus simple references.

All work in normalized units (features and force scaled 0..1 on identification
data) and follow :class:`estimation.state_space.SSEstimator`'s interface:
``fit(U, y)``, ``predict(U, y=None, mode=...)``, ``streaming(mode, scaling=None)``
and a class attribute ``modes``.
"""

from sim.lazy import lazy_exports

#: Public names, imported on first use: using one baseline does not import the
#: others (the MLP and LDA modules import scikit-learn's networks and discriminants).
_LAZY = {"LDAQPF": "estimation.baselines.lda_qpf", "MLPBaseline": "estimation.baselines.mlp",
         "NARXBaseline": "estimation.baselines.narx",
         "Persistence": "estimation.baselines.persistence",
         "SingleFeatureLinear": "estimation.baselines.single_feature"}
__all__ = sorted(_LAZY)


__getattr__ = lazy_exports(__name__, _LAZY)
