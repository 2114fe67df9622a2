"""Open and close from the armband: two decoders of the MAV of every channel.

- :mod:`~estimation.decoding.windows`: labels, ``decoder_windows``, calibration errors;
- :mod:`~estimation.decoding.base`: ``OpenCloseDecoder``, the shared ``decode``,
  ``predict`` and stream;
- :mod:`~estimation.decoding.two_site`: ``TwoSiteDecoder``, a flexor and an extensor
  site, as clinicians set them;
- :mod:`~estimation.decoding.pattern`: ``PatternDecoder``, LDA over every channel, speed
  from the amplitude;
- :mod:`~estimation.decoding.metrics`: ``unrequested_opens``, ``unrequested_closes``;
- :mod:`~estimation.decoding.registry`: ``make_decoder``, ``register_decoder``,
  ``decoder_names``.

Each decoder maps a window's MAV of the 8 channels to ``(close_level, open_level)``, each
0..1 and at most one nonzero, with hysteresis; ``decode(X)`` runs a sequence,
``stream().step(row)`` one window at a time, and
:func:`estimation.export_c.decoders.export_decoder` writes it as C. See docs/DECODERS.md.
"""

from estimation.decoding.metrics import Unrequested, unrequested_closes, unrequested_opens
from estimation.decoding.registry import (
    UnknownDecoderError,
    decoder_names,
    make_decoder,
    register_decoder,
    unregister_decoder,
)
from estimation.decoding.windows import (
    CLOSE,
    LABELS,
    OPEN,
    REST,
    DecoderCalibrationError,
    NoOpenContractionsError,
    decoded_labels,
    decoder_windows,
)

__all__ = ["CLOSE", "DEFAULT_DECODER", "LABELS", "OPEN", "REST", "DecoderCalibrationError",
           "DecoderStream", "NoOpenContractionsError", "OpenCloseDecoder", "PatternDecoder",
           "TwoSiteDecoder", "Unrequested",
           "UnknownDecoderError", "decoded_labels", "decoder_names", "decoder_windows",
           "make_decoder", "register_decoder", "unregister_decoder", "unrequested_closes",
           "unrequested_opens"]


#: The decoder a paradigm that needs one uses unless told otherwise: ``pattern``, whose
#: classifier reads squeezes as close whatever their extensor co-contraction (docs/DECODERS.md).
DEFAULT_DECODER = "pattern"

#: Names imported on first use: the decoders import scikit-learn, listing names does not.
_LAZY = {"DecoderStream": "base", "OpenCloseDecoder": "base", "TwoSiteDecoder": "two_site",
         "PatternDecoder": "pattern"}


def __getattr__(name: str) -> object:
    """The decoder classes, imported on first use (``_LAZY``)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"estimation.decoding.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
