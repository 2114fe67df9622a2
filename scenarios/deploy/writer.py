"""``export-c``'s Python API: a fitted pipeline (and a design) to C files in a folder.

:func:`export_c` asks each layer's emitter for its C text
(:func:`estimation.export_c.export_features`, :func:`estimation.export_c.export_estimator`,
:func:`controllers.export_c.export_controller`, and with an open/close decoder
:func:`estimation.export_c.export_decoder` and the decoder's MAV window over every armband
channel, ``griploop_decoder_window.c``) and writes the files only once every part has been
made and checked: a refused estimator, controller or decoder (an unsupported kind,
non-finite coefficients, an unstable state matrix, a paradigm that needs a decoder without
one) leaves the folder untouched.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from controllers.paradigms import DecoderMissingError, needs_decoder
from estimation.export_c import FeatureWindow, export_decoder, export_estimator, export_features
from scenarios.runners.semg_reference import HandReference
from sim.c_source import TYPES_HEADER, CModel, ExportError, render, types_header

#: Paradigms (:mod:`controllers.paradigms`) the runtime shapes the reference by.
EXPORTABLE_PARADIGMS = ("force", "force_hold", "velocity")


class ParadigmNotExportableError(ExportError):
    """A registered paradigm with no C shaping; the message lists the exportable ones."""


def check_paradigm_exportable(paradigm: str) -> None:
    """Refuse a paradigm the runtime cannot shape, in one line.

    Raises
    ------
    controllers.paradigms.UnknownParadigmError
        Not registered at all.
    ParadigmNotExportableError
        Registered, with no C export.
    """
    from controllers.paradigms import make_paradigm

    make_paradigm(paradigm)
    if paradigm not in EXPORTABLE_PARADIGMS:
        raise ParadigmNotExportableError(
            f"paradigm {paradigm!r} has no C export; exportable paradigms: "
            f"{', '.join(EXPORTABLE_PARADIGMS)}")


@dataclass(frozen=True)
class DecoderPart:
    """An open/close decoder to export beside the estimator.

    Attributes
    ----------
    decoder : estimation.decoding.OpenCloseDecoder
        Fitted on the MAV of every armband channel, per feature window.
    name : str
        Its registered name (selects the C emitter: ``two_site``, ``pattern``).
    grip_at_full_close_n : float
        The hand grip a close level of 1 asks for, N (the hand force at the user's MVC:
        ``Decoded.grip_n = close x`` this).
    """

    decoder: Any
    name: str
    grip_at_full_close_n: float


def decoder_window_files() -> dict[str, str]:
    """``griploop_decoder_window.h`` and ``.c``: the MAV of every armband channel over the
    feature window's window and increment (the decoder's input)."""
    return {name: render("scenarios.deploy", name + ".j2")
            for name in ("griploop_decoder_window.h", "griploop_decoder_window.c")}


@dataclass
class CExport:
    """An export written to a folder.

    Attributes
    ----------
    out_dir : Path
    files : list of Path
        Every file written (headers and sources).
    features, estimator : CModel
    controller : CModel or None
    window : FeatureWindow
    mode : str
        The estimator's mode.
    reference : HandReference
        How ``griploop_reference.c`` makes the hand reference of an estimate.
    facts : dict
        What the templates state: rates, window sizes and ``reference``'s fields.
    decoder : CModel or None
        The open/close decoder (``griploop_decoder.c``), with its MAV window
        (``griploop_decoder_window.c``); ``None``: none exported.
    decoder_part : DecoderPart or None
        What it was exported from.
    """

    out_dir: Path
    files: list[Path]
    features: CModel
    estimator: CModel
    controller: CModel | None
    window: FeatureWindow
    mode: str
    reference: HandReference = field(default_factory=HandReference)
    facts: dict[str, Any] = field(default_factory=dict)
    decoder: CModel | None = None
    decoder_part: DecoderPart | None = None

    @property
    def sources(self) -> list[Path]:
        """The ``.c`` files."""
        return [p for p in self.files if p.suffix == ".c"]

    def harness(self) -> str:
        """The C text of the runtime's callbacks fed from variables (for host and target checks)."""
        return render("scenarios.deploy", "griploop_harness.c.j2", features=self.features,
                      estimator=self.estimator, controller=self.controller)

    def summary(self) -> dict[str, Any]:
        """JSON-ready: digests and facts of each part."""
        parts = {"features": self.features, "estimator": self.estimator,
                 "controller": self.controller}
        if self.decoder is not None:
            parts["decoder"] = self.decoder
        return {name: None if m is None else {"digest": m.digest, **m.summary}
                for name, m in parts.items()}


def _check_parts(reference: HandReference, has_decoder: bool, pipeline: Any, estimator: str,
                 window: FeatureWindow) -> None:
    """:func:`export_c`'s refusals, before anything is made: the paradigm, its decoder, the
    rest thresholds and the estimator's update period against the feature window's."""
    check_paradigm_exportable(reference.paradigm)
    if not has_decoder and needs_decoder(reference.paradigm):
        raise DecoderMissingError(
            f"paradigm {reference.paradigm} needs open and close signals; expected a fitted "
            "open/close decoder (a calibration with open contractions), found none")
    try:
        reference.check()
    except ValueError as exc:
        raise ExportError(str(exc)) from None
    period = window.samples[1] / window.fs_hz
    fitted_dt = getattr(pipeline.estimator_, "dt_s", None)
    if fitted_dt is not None and abs(float(fitted_dt) - period) > 1e-9:
        raise ExportError(f"estimator {estimator}: fitted for a window every {fitted_dt} s; "
                          f"expected the feature window's {period:g} s")


def export_c(pipeline: Any, estimator: str, mode: str, window: FeatureWindow,
             out_dir: Path, *, design: Any = None,
             reference: HandReference | None = None,
             decoder: DecoderPart | None = None) -> CExport:
    """Write the C files of a fitted estimator (and a designed controller) to ``out_dir``.

    Parameters
    ----------
    pipeline : estimation.pipeline.ForcePipeline
        Fitted on features of ``window``.
    estimator : str
        Its registered name.
    mode : {"one_step", "free_run"}
    window : FeatureWindow
        The feature window it was fitted on (sampling rate, channels, window, increment).
    out_dir : Path
        Created if missing; existing ``griploop_*`` files are replaced.
    design : controllers.design.ControllerDesign, optional
        A design whose runtime controller is exported too.
    reference : HandReference, optional
        How the estimate becomes the hand reference, shaped by ``griploop_reference.c``
        as a trial shapes it
        (:meth:`~scenarios.runners.semg_reference.HandReference.of_calibration`): the
        rest threshold, the force mapping and ceiling (stated in ``griploop.h``), the paradigm
        (:data:`EXPORTABLE_PARADIGMS`). Default: none of them.
    decoder : DecoderPart, optional
        An open/close decoder on the MAV of every armband channel: exported with its
        window, stepped by the runtime every feature window; its close and open levels
        reach ``griploop_reference_step`` (``velocity`` needs it; ``force_hold`` then also
        releases on the open level).

    Returns
    -------
    CExport

    Raises
    ------
    estimation.export_c.NotExportableError, controllers.export_c.ControllerNotExportableError
        A kind without a C export (before any file is written).
    sim.c_source.ExportError
        Non-finite coefficients or an unstable state matrix (before any file is written).
    ParadigmNotExportableError, controllers.paradigms.UnknownParadigmError
        A paradigm without C shaping (before any file is written).
    controllers.paradigms.DecoderMissingError
        A paradigm that needs a decoder (``velocity``) without one.
    """
    reference = HandReference() if reference is None else reference
    _check_parts(reference, decoder is not None, pipeline, estimator, window)
    win, step = window.samples
    period = step / window.fs_hz
    features = export_features(window)
    est = export_estimator(pipeline, estimator, mode,
                           extra={"update period": f"{period:g} s (one feature window)"})
    controller = dec = None
    if design is not None:
        from controllers.export_c import export_controller

        controller = export_controller(design)
    if decoder is not None:
        dec = _decoder_model(decoder, window, period)
    models = [m for m in (features, est, controller, dec) if m is not None]
    texts: dict[str, str] = {TYPES_HEADER: types_header(digests=[m.digest for m in models])}
    for m in models:
        texts.update(m.files)
    if dec is not None:
        texts.update(decoder_window_files())
    facts = {"fs_hz": window.fs_hz, "window_samples": win, "step_samples": step,
             "period_s": period, **asdict(reference)}
    if decoder is not None:
        facts["grip_at_full_close_n"] = float(decoder.grip_at_full_close_n)
    for name in ("griploop.h", "griploop_reference.c", "griploop_runtime.c"):
        texts[name] = render("scenarios.deploy", name + ".j2", features=features, estimator=est,
                             controller=controller, mode=mode, decoder=dec, **facts)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = []
    for name, text in texts.items():
        path = out_dir / name
        path.write_text(text, encoding="utf-8")
        files.append(path)
    return CExport(out_dir, files, features, est, controller, window, mode, reference, facts,
                   dec, decoder)


def _decoder_model(decoder: DecoderPart, window: FeatureWindow, period_s: float) -> CModel:
    """The decoder's C, checked against the armband (its inputs: every channel's MAV)."""
    import math

    n_inputs = int(decoder.decoder.n_features_in_)
    if n_inputs != window.n_armband_channels:
        raise ExportError(f"decoder {decoder.name}: fitted on {n_inputs} channels' MAV; expected "
                          f"the armband's {window.n_armband_channels} (every channel)")
    grip = float(decoder.grip_at_full_close_n)
    if not (math.isfinite(grip) and grip > 0):
        raise ExportError(f"decoder {decoder.name}: expected a finite grip at full close > 0 N, "
                          f"found {grip!r}")
    return export_decoder(decoder.decoder, decoder.name,
                          extra={"update period": f"{period_s:g} s (one feature window)"})
