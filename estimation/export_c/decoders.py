"""Fitted open/close decoders in C: ``griploop_decoder_step`` for the prosthesis.

Each decoder kind has an emitter registered by its name (:func:`register_decoder_c_export`)
that extracts its tables; :func:`export_decoder` checks them (finite) and renders
``griploop_decoder.h`` and ``griploop_decoder.c`` from the templates:

``two_site``
    each site's mean MAV, its level ``clip((site - rest) * gain, 0, 1)``, the thresholds
    with hysteresis and the conflict rule (:mod:`estimation.decoding.two_site`);
``pattern``
    ``log(MAV + 1)`` of every channel (a polynomial logarithm in the float build, so every
    libm gives the same bits), the discriminant's scores ``coef z + intercept``, their
    argmax, and the level of the mean MAV with the class's gain
    (:mod:`estimation.decoding.pattern`).

The C API (state in static variables, one decoder per program)::

    void griploop_decoder_reset(void);
    void griploop_decoder_step(const gl_real mav[GRIPLOOP_DECODER_INPUTS],
                               gl_real *close, gl_real *open);
    int32_t griploop_decoder_label(void);   /* 0 rest, 1 close, 2 open */

``mav`` is one window's MAV of every armband channel, as ``griploop_features`` computes
it with ``features=("mav",)`` over all channels. The outputs equal
:meth:`~estimation.decoding.base.DecoderStream.step`'s to float32 rounding.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.export_c.estimators import NotExportableError
from sim.c_source import CModel, EmitterRegistry, check_finite, model_digest, render


@dataclass(frozen=True)
class DecoderTables:
    """What a decoder emitter extracts from a fitted decoder.

    Attributes
    ----------
    family : str
        The C template that runs it (``griploop_decoder_<family>.c.j2``).
    tables : dict of str to ndarray
        Real coefficient tables (float64; written as ``static const gl_real``).
    constants : dict
        Sizes, scalars and integer tables the template needs (``n_inputs``, ...).
    doc : str
        What the decoder computes, for the header.
    """

    family: str
    tables: dict[str, np.ndarray]
    constants: dict[str, Any]
    doc: str = ""


DecoderEmitter = Callable[[Any], DecoderTables]

_EMITTERS = EmitterRegistry("decoder", NotExportableError)


def register_decoder_c_export(name: str, emitter: DecoderEmitter | str, *,
                              replace: bool = False) -> None:
    """Register how the decoder ``name`` is exported to C.

    Parameters
    ----------
    name : str
        The decoder's registered name (:mod:`estimation.decoding.registry`).
    emitter : callable or str
        ``emitter(decoder) -> DecoderTables`` for a fitted decoder, or its
        ``"module:attribute"``.
    replace : bool
        Allow replacing an existing registration.
    """
    _EMITTERS.register(name, emitter, replace=replace)


def c_exportable_decoders() -> tuple[str, ...]:
    """Decoder names with a C export, in registration order."""
    return _EMITTERS.names()


def _thresholds(decoder: Any) -> dict[str, float]:
    return {"on": float(decoder.on_fraction), "off": float(decoder.off_fraction)}


def two_site_tables(decoder: Any) -> DecoderTables:
    """Tables of a fitted :class:`~estimation.decoding.two_site.TwoSiteDecoder`."""
    flexor = [int(i) for i in decoder.flexor_index_]
    extensor = [int(i) for i in decoder.extensor_index_]
    tables = {"rest": np.asarray(decoder.rest_, float), "gain": np.asarray(decoder.gain_, float)}
    constants = {"n_inputs": int(decoder.n_features_in_), "flexor": flexor,
                 "extensor": extensor, "conflict": str(decoder.conflict), **_thresholds(decoder)}
    doc = (f"two sites: flexors on channels {', '.join(str(i + 1) for i in flexor)} close, "
           f"extensors on channels {', '.join(str(i + 1) for i in extensor)} open; "
           f"both on: {decoder.conflict} rule")
    return DecoderTables("two_site", tables, constants, doc)


def pattern_tables(decoder: Any) -> DecoderTables:
    """Tables of a fitted :class:`~estimation.decoding.pattern.PatternDecoder`."""
    tables = {"coef": np.asarray(decoder.coef_, float),
              "intercept": np.asarray(decoder.intercept_, float),
              "gain": np.asarray(decoder.gain_, float)}
    n = int(decoder.n_features_in_)
    constants = {"n_inputs": n, "n_classes": int(tables["coef"].shape[0]),
                 "rest": float(decoder.rest_), **_thresholds(decoder)}
    doc = (f"linear discriminant on log(MAV + 1) of channels 1-{n} (rest, close, open), "
           "speed from the mean MAV")
    return DecoderTables("pattern", tables, constants, doc)


register_decoder_c_export("two_site", two_site_tables)
register_decoder_c_export("pattern", pattern_tables)


def check_decoder_exportable(name: str) -> None:
    """Refuse a decoder name without a C export (before anything is fitted).

    Raises
    ------
    NotExportableError
        The message lists the decoders that have one.
    """
    _EMITTERS.check(name)


def export_decoder(decoder: Any, name: str, extra: Mapping[str, Any] | None = None) -> CModel:
    """``griploop_decoder.h`` and ``.c`` of a fitted decoder (module notes).

    Parameters
    ----------
    decoder : OpenCloseDecoder
        Fitted (:mod:`estimation.decoding`).
    name : str
        Its registered decoder name (selects the emitter).
    extra : mapping, optional
        Facts to state in the header (e.g. ``{"update period": "0.125 s"}``).

    Returns
    -------
    CModel
        Kind ``"decoder"``; its summary names the decoder, its inputs and coefficients.

    Raises
    ------
    NotExportableError
        ``name`` has no C export; the message lists the decoders that have one.
    sim.c_source.ExportError
        A non-finite coefficient; nothing is rendered then.
    """
    from sklearn.utils.validation import check_is_fitted

    check_is_fitted(decoder)
    t = _EMITTERS.emitter(name)(decoder)
    who = f"decoder {name}"
    check_finite(who, t.tables)
    check_finite(who, {k: np.asarray(v, float) for k, v in t.constants.items()
                       if isinstance(v, float)})
    digest = model_digest(f"decoder {t.family} {name}", t.tables, t.constants)
    ctx = dict(t.constants, tables=t.tables, name=name, family=t.family, digest=digest,
               doc=t.doc, extra=dict(extra or {}))
    files = {"griploop_decoder.h": render("estimation.export_c", "griploop_decoder.h.j2", **ctx),
             "griploop_decoder.c": render("estimation.export_c",
                                          f"griploop_decoder_{t.family}.c.j2", **ctx)}
    summary = {"decoder": name, "family": t.family, "n_inputs": int(t.constants["n_inputs"]),
               "on_fraction": t.constants["on"], "off_fraction": t.constants["off"],
               "coefficients": int(sum(np.asarray(v).size for v in t.tables.values())),
               "computes": t.doc}
    return CModel("decoder", files, digest, summary)
