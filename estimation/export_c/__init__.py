"""What the prosthesis computes from sEMG, as C99: the feature window, the fitted estimator
and the open/close decoder.

:func:`export_features` writes the incremental MAV/RMS/WL window over the int8
ring (:mod:`.features`); :func:`export_estimator` writes a fitted
:class:`~estimation.pipeline.ForcePipeline` through the emitter registered for its
estimator (:mod:`.estimators`; :func:`register_c_export` adds one for a plugin);
:func:`export_decoder` writes a fitted open/close decoder (:mod:`.decoders`;
:func:`register_decoder_c_export` adds one for a plugin).
Each returns a :class:`sim.c_source.CModel` (file names and texts, digest); writing,
compiling and checking them against Python is :mod:`scenarios.deploy`.
"""

from estimation.export_c.decoders import (
    DecoderTables,
    c_exportable_decoders,
    check_decoder_exportable,
    export_decoder,
    register_decoder_c_export,
)
from estimation.export_c.estimators import (
    EstimatorTables,
    NotExportableError,
    c_exportable_estimators,
    check_exportable,
    estimator_tables,
    export_estimator,
    lti_tables,
    mlp_tables,
    register_c_export,
)
from estimation.export_c.features import (
    FeatureWindow,
    export_features,
    feature_window,
    paper_window_ms,
)

__all__ = ["DecoderTables", "EstimatorTables", "FeatureWindow", "NotExportableError",
           "c_exportable_decoders", "c_exportable_estimators", "check_decoder_exportable",
           "check_exportable", "estimator_tables", "export_decoder", "export_estimator",
           "export_features", "feature_window", "lti_tables", "mlp_tables", "paper_window_ms",
           "register_c_export", "register_decoder_c_export"]
