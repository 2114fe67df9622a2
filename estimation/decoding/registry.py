"""Open/close decoders by name: ``make_decoder(name, **params)`` and :func:`register_decoder`.

==========  ================================================================
name        decoder
==========  ================================================================
two_site    flexor and extensor sites' amplitudes, thresholds over rest
            (:class:`~estimation.decoding.two_site.TwoSiteDecoder`)
pattern     LDA over all channels for the direction, mean MAV for the speed
            (:class:`~estimation.decoding.pattern.PatternDecoder`)
==========  ================================================================

A decoder is a scikit-learn estimator with ``fit(X, y)``, ``decode(X)``, ``predict(X)``,
``stream()`` and ``n_features_in_`` (:class:`~estimation.decoding.base.OpenCloseDecoder`
provides all but ``fit`` and the per-window state machine). A plugin registers its own
class (or its ``"module:attribute"``), and a C emitter for it with
:func:`estimation.export_c.decoders.register_decoder_c_export`.
"""

from __future__ import annotations

from typing import Any

from sim.errors import GriploopError
from sim.registry import Registry


class UnknownDecoderError(GriploopError, LookupError):
    """A decoder name is not in the registry."""


_DECODERS = Registry("decoder", UnknownDecoderError)

def register_decoder(name: str, factory: Any, *, replace: bool = False) -> None:
    """Register a decoder.

    Parameters
    ----------
    name : str
        New name.
    factory : callable or str
        ``factory(**params) -> decoder`` (usually the class), or its ``"module:attribute"``.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, or ``name`` taken and ``replace`` false.
    """
    _DECODERS.register(name, factory, replace=replace)


unregister_decoder, decoder_names = _DECODERS.functions(__name__, "decoder")


def make_decoder(name: str, **params: Any) -> Any:
    """A new (unfitted) decoder of a registered name.

    Parameters
    ----------
    name : str
        A registered decoder (:func:`decoder_names`).
    **params
        Its hyperparameters.

    Raises
    ------
    UnknownDecoderError
        An unknown name; the message lists the registered decoders.
    """
    return _DECODERS.get(name)(**params)


register_decoder("two_site", "estimation.decoding.two_site:TwoSiteDecoder")
register_decoder("pattern", "estimation.decoding.pattern:PatternDecoder")
