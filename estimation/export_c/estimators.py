"""Fitted estimators in C: each exportable kind's tables, checked, then written from a template.

Two C families cover the exportable estimators:

``lti``
    Every estimator whose stream is an affine LTI recursion
    (:class:`~estimation.streaming.DelayedLTIStream`,
    :class:`~estimation.streaming.DirectLTIStream`): the paper's SS model with or
    without its Kalman predictor (``ss_kf``, ``ss``; eq. 16 in ``one_step``, the
    model alone in ``free_run``), the latent-state Kalman decoder (``latent_kf``),
    the single-feature fits (``features_*``) and ``persistence``. The C code is the
    stream's own matrix in normalized units: with ``z = [s, u_n, (y_n), 1]``,
    ``[s(k); yhat_n(k)] = M z``, where ``u_n = (u - u_min) / u_span`` and
    ``y_n = (y - y_min) / y_span`` (the pipeline's min-max scaling), and the estimate
    is ``y_span yhat_n + y_min`` in newtons. A delayed stream's ``z`` holds the
    previous window's features (its first call returns ``y_min``).
``mlp``
    Logistic multilayer perceptrons on the current and ``lags`` past windows'
    normalized features (the first window repeated before the start), averaged
    over an ensemble: ``mlp`` (one network, no lags), ``transfer_mlp``, and
    ``adaptive_mlp`` (the person's network on the current window, weight ``w``, and
    the adapted ensemble on the lagged windows sharing ``1 - w``).

An estimator kind is exported by the emitter registered for its name
(:func:`register_c_export`); a plugin registers its own. An emitter returns
:class:`EstimatorTables`; :func:`export_estimator` refuses non-finite tables and
an unstable state matrix before any text is made.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim.c_source import (
    CModel,
    EmitterRegistry,
    ExportError,
    check_finite,
    check_stable,
    model_digest,
    render,
)


class NotExportableError(ExportError, LookupError):
    """The estimator has no C export (an unsupported kind, or a plugin without one)."""


@dataclass(frozen=True)
class EstimatorTables:
    """What an emitter extracts from a fitted pipeline.

    Attributes
    ----------
    family : {"lti", "mlp"}
        The C template that runs it.
    tables : dict of str to ndarray
        Coefficient tables (float64; written as ``static const gl_real``).
    constants : dict
        Sizes and scalars the template needs (``n_inputs``, ``uses_force``, ...).
    state_matrix : ndarray, shape (n_states, n_states)
        The recursion's state matrix (empty for a static map), checked for stability.
    state_doc : str
        What the C state holds, for the header.
    """

    family: str
    tables: dict[str, np.ndarray]
    constants: dict[str, Any]
    state_matrix: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    state_doc: str = ""


Emitter = Callable[[Any, str], EstimatorTables]

_EMITTERS = EmitterRegistry("estimator", NotExportableError)


def register_c_export(name: str, emitter: Emitter | str, *, replace: bool = False) -> None:
    """Register how the estimator ``name`` is exported to C.

    Parameters
    ----------
    name : str
        The estimator's registered name (:mod:`estimation.registry`).
    emitter : callable or str
        ``emitter(pipeline, mode) -> EstimatorTables`` for a fitted
        :class:`~estimation.pipeline.ForcePipeline`, or its ``"module:attribute"``.
    replace : bool
        Allow replacing an existing registration.
    """
    _EMITTERS.register(name, emitter, replace=replace)


def c_exportable_estimators() -> tuple[str, ...]:
    """Estimator names with a C export, in registration order."""
    return _EMITTERS.names()


def _scaling_tables(pipeline: Any) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    sc = pipeline.scaling_
    tables = {"u_min": np.asarray(sc.u_min, float), "u_inv_span": 1.0 / np.asarray(sc.u_span)}
    return tables, {"y_min": float(sc.y_min_n), "y_span": float(sc.y_span_n)}


def lti_tables(pipeline: Any, mode: str) -> EstimatorTables:
    """Tables of an estimator whose stream is a Delayed/Direct LTI stream (see module notes).

    Raises
    ------
    ExportError
        The estimator's stream in ``mode`` is not an LTI stream.
    """
    from estimation.streaming import DelayedLTIStream, DirectLTIStream

    stream = pipeline.estimator_.streaming(mode)  # normalized units: M unscaled
    if not isinstance(stream, (DelayedLTIStream, DirectLTIStream)):
        raise ExportError(f"{type(pipeline.estimator_).__name__} in {mode}: expected an LTI "
                          f"stream, found {type(stream).__name__}")
    ns, m = stream.n_states, stream.n_inputs
    M = np.array(stream._M, dtype=np.float64)  # the matrix the Python stream multiplies by
    tables, scalars = _scaling_tables(pipeline)
    tables["M"] = M
    delayed = isinstance(stream, DelayedLTIStream)
    constants = {"n_states": ns, "n_inputs": m, "delayed": delayed,
                 "uses_force": bool(stream.uses_force), "n_z": int(M.shape[1]), **scalars}
    doc = (f"{ns} states, the {'previous' if delayed else 'current'} window's {m} normalized "
           f"features{' and force' if stream.uses_force else ''}, and a constant 1")
    return EstimatorTables("lti", tables, constants, M[:ns, :ns], doc)


def _networks(estimator: Any) -> tuple[list[tuple[list[np.ndarray], list[np.ndarray]]], int,
                                       list[float] | None]:
    """``([(coefs, intercepts) per network], lags, weights)`` of an MLP-based estimator.

    ``weights`` is None for a plain mean (``mlp``, ``transfer_mlp``); for ``adaptive_mlp``
    the scratch network's share first, then the ensemble's networks sharing the rest.
    """
    scratch = getattr(estimator, "scratch_", None)
    if scratch is not None:  # AdaptiveMLP: its own network, then the adapted ensemble
        net = scratch.net_
        nets = [(list(net.coefs_), list(net.intercepts_))]
        nets += [(list(n.coefs), list(n.intercepts)) for n in estimator.networks_]
        w = float(estimator.weight_)
        rest = len(estimator.networks_)
        weights = [w] + ([(1.0 - w) / rest] * rest if rest else [])
        return nets, int(estimator.lags) if rest else 0, weights
    if hasattr(estimator, "networks_"):
        nets = [(list(n.coefs), list(n.intercepts)) for n in estimator.networks_]
        return nets, int(estimator.lags), None
    net = estimator.net_
    return [(list(net.coefs_), list(net.intercepts_))], 0, None


def mlp_tables(pipeline: Any, mode: str) -> EstimatorTables:
    """Tables of a logistic MLP or an ensemble of them (``mlp``, ``transfer_mlp``,
    ``adaptive_mlp``).

    Raises
    ------
    ExportError
        A network with an activation other than logistic, or a second output.
    """
    est = pipeline.estimator_
    own = getattr(est, "scratch_", est)  # adaptive_mlp: the person's network is checked
    act = getattr(getattr(own, "net_", None), "activation", "logistic")
    if act != "logistic":
        raise ExportError(f"{type(est).__name__}: expected logistic hidden units, found {act}")
    nets, lags, weights = _networks(est)
    tables, scalars = _scaling_tables(pipeline)
    layers = []
    for n, (coefs, intercepts) in enumerate(nets):
        sizes = []
        for i, (W, b) in enumerate(zip(coefs, intercepts, strict=True)):
            tables[f"W{n}_{i}"] = np.asarray(W, float).T  # (n_out, n_in), row-major
            tables[f"b{n}_{i}"] = np.asarray(b, float).ravel()
            sizes.append((int(W.shape[0]), int(W.shape[1])))
        if sizes[-1][1] != 1:
            raise ExportError(f"{type(est).__name__}: expected one output, found {sizes[-1][1]}")
        layers.append(sizes)
    m = int(pipeline.n_features_in_)
    width = max(max(n_out for _, n_out in sizes) for sizes in layers)
    constants = {"n_inputs": m, "lags": lags, "n_x": m * (lags + 1), "layers": layers,
                 "n_networks": len(nets), "width": width, "uses_force": False,
                 "weights": weights,
                 "delayed": False, **scalars}
    doc = f"the normalized features of the current and {lags} past windows ({m * (lags + 1)})"
    return EstimatorTables("mlp", tables, constants, np.zeros((0, 0)), doc)


for _name in ("ss_kf", "ss", "latent_kf", "features_mav", "features_rms", "features_wl",
              "persistence"):
    register_c_export(_name, lti_tables)
for _name in ("mlp", "transfer_mlp", "adaptive_mlp"):
    register_c_export(_name, mlp_tables)


def check_exportable(name: str) -> None:
    """Refuse an estimator name without a C export (before anything is fitted).

    Raises
    ------
    NotExportableError
        The message lists the estimators that have one.
    """
    _EMITTERS.check(name)


def estimator_tables(pipeline: Any, name: str, mode: str) -> EstimatorTables:
    """The registered emitter's tables for a fitted pipeline, checked.

    Raises
    ------
    NotExportableError
        ``name`` has no C export; the message lists the estimators that have one.
    ExportError
        Non-finite coefficients, or a state matrix with spectral radius >= 1.
    """
    out = _EMITTERS.emitter(name)(pipeline, mode)
    who = f"estimator {name} ({mode})"
    check_finite(who, out.tables)
    check_finite(who, {k: np.asarray(v, float) for k, v in out.constants.items()
                       if isinstance(v, float)})
    check_stable(who, out.state_matrix)
    return out


def export_estimator(pipeline: Any, name: str, mode: str,
                     extra: Mapping[str, Any] | None = None) -> CModel:
    """``griploop_estimator.h`` and ``.c`` of a fitted :class:`~estimation.pipeline.ForcePipeline`.

    Parameters
    ----------
    pipeline : ForcePipeline
        Fitted (raw features and newtons in and out).
    name : str
        Its registered estimator name (selects the emitter).
    mode : {"one_step", "free_run"}
        The mode it streams in.
    extra : mapping, optional
        Facts to state in the header (e.g. ``{"update period": "0.125 s"}``).

    Raises
    ------
    NotExportableError, ExportError
        As :func:`estimator_tables`; nothing is rendered then.
    """
    t = estimator_tables(pipeline, name, mode)
    digest = model_digest(f"estimator {t.family} {name} {mode}", t.tables,
                          {k: v for k, v in t.constants.items()})
    ctx = dict(t.constants, tables=t.tables, name=name, mode=mode, digest=digest,
               family=t.family, state_doc=t.state_doc, extra=dict(extra or {}))
    files = {"griploop_estimator.h": render("estimation.export_c", "griploop_estimator.h.j2",
                                            **ctx),
             "griploop_estimator.c": render("estimation.export_c",
                                            f"griploop_estimator_{t.family}.c.j2", **ctx)}
    summary = {"estimator": name, "mode": mode, "family": t.family,
               "n_inputs": int(t.constants["n_inputs"]),
               "uses_force": bool(t.constants["uses_force"]),
               "coefficients": int(sum(np.asarray(v).size for v in t.tables.values())),
               "state": t.state_doc}
    return CModel("estimator", files, digest, summary)
