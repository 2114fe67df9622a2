"""``griploop export-c`` from start to end: fit, export, build, replay, and the target.

:func:`export_session` fits the estimator on a calibration recording
(:func:`scenarios.live.calibration_fit.fit_calibration`, as ``evaluate`` and ``live`` fit it),
designs the controller for the object (:func:`controllers.design_cache.grasp_design`,
as an episode does), writes the C files, and with ``check`` replays a recording
through C and Python (:mod:`scenarios.deploy.check`); with ``target`` it also runs the
replay on the emulated Cortex-M4F (:mod:`scenarios.deploy.target`). It returns the
JSON contract of ``export-c --json`` (docs/FORMAT.md).

A paradigm that needs open and close signals (``velocity``), or a ``decoder`` asked for,
fits an open/close decoder on the calibration's open contractions too and exports it
with its MAV window; a calibration without open contractions is refused in one line
before anything is fitted or written
(:func:`scenarios.live.calibration_fit.calibration_decoder`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from estimation.export_c import feature_window
from scenarios.deploy import check
from scenarios.deploy.build import build_export
from scenarios.deploy.library import CompiledLibrary
from scenarios.deploy.writer import CExport, DecoderPart, export_c
from scenarios.runners.episode import HAND_FORCE_AT_MVC_N
from scenarios.runners.semg_reference import HandReference
from scenarios.runners.trial_loop import DEFAULT_HAND, HandSettings
from sim.recording import Recording

#: Length of the hand run whose observations check the controller, s.
CONTROLLER_CHECK_S = 6.0


@dataclass(frozen=True)
class ExportSpec:
    """What ``export-c`` exports: an estimator, and a controller for an object.

    Attributes
    ----------
    estimator : str
        A registered estimator with a C export.
    channels : sequence or None
        Channels the estimator uses (``None``: all).
    mode : {"free_run", "one_step"}
    controller, object_name : str, optional
        A controller kind and the object it is designed for (both or neither).
    seed : int
        Seeds the estimator's fit and the hand.
    control_dt_s : float
        Control period of the design, s.
    hand : HandSettings
        The paradigm the runtime shapes the reference by, the slip response the
        controller carries (``auto_grip``), and the drive of the checked hand.
    """

    estimator: str
    channels: Sequence[int | str] | None
    mode: str = "free_run"
    controller: str | None = None
    object_name: str | None = None
    seed: int = 0
    control_dt_s: float = 0.01
    hand: HandSettings = DEFAULT_HAND


def _check_spec(calibration: Recording, spec: ExportSpec) -> str | None:
    """Refuse what cannot be exported before the fit and the design; the decoder to fit.

    Raises
    ------
    estimation.export_c.NotExportableError, controllers.export_c.ControllerNotExportableError
    scenarios.deploy.writer.ParadigmNotExportableError
    estimation.decoding.NoOpenContractionsError
        A paradigm that needs a decoder (or a decoder asked for) and a calibration without
        open contractions, in one line.
    """
    from controllers.export_c import check_controller_exportable
    from estimation.export_c import check_decoder_exportable, check_exportable
    from scenarios.deploy.writer import check_paradigm_exportable
    from scenarios.live.recorded import calibration_decoder

    check_exportable(spec.estimator)
    spec.hand.check()
    check_paradigm_exportable(spec.hand.paradigm)
    if spec.controller is not None:
        check_controller_exportable(spec.controller)
    decoder = spec.hand.effective_decoder
    if decoder is not None:
        check_decoder_exportable(decoder)
        calibration_decoder(calibration, spec.hand)  # no open contractions: one line
    return decoder


def export_session(calibration: Recording, spec: ExportSpec, out_dir: Path, *,
                   check_recording: Recording | None = None,
                   target: str | None = None) -> tuple[CExport, dict[str, Any]]:
    """Export (and check) an estimator fitted on ``calibration`` and a controller for an object.

    Parameters
    ----------
    calibration : Recording
        sEMG with the measured force (any recording ``evaluate`` reads).
    spec : ExportSpec
        The estimator (its channels, mode and seed) and the controller, object and hand.
    out_dir : Path
    check_recording : Recording, optional
        Replayed through C and Python (host build).
    target : {"cortex-m4"}, optional
        Also run the replay on the emulated board (needs ``check_recording``).

    Returns
    -------
    export : CExport
    report : dict
        ``{"files": [...], "models": {...}, "hand": {...}, "check": {...},
        "target": {...}}`` (``check`` and ``target`` as asked).
    """
    from scenarios.live.recorded import fit_calibration

    estimator, channels, mode, seed = spec.estimator, spec.channels, spec.mode, spec.seed
    controller, hand = spec.controller, spec.hand
    decoder = _check_spec(calibration, spec)
    fitted = fit_calibration(calibration, estimator, mode=mode, channels=channels, seed=seed,
                             decoder=decoder)
    cal = fitted.calibration
    design = obj = None
    if controller is not None:
        from controllers.design_cache import grasp_design
        from sim.hand.objects import make_object

        obj = make_object(spec.object_name)
        design = grasp_design(obj, controller, spec.control_dt_s, hand.controller_spec(None))
    window = feature_window(calibration.fs_hz, calibration.n_channels, fitted.channel_index)
    part = None if decoder is None else DecoderPart(cal.decoder, decoder, HAND_FORCE_AT_MVC_N)
    export = export_c(cal.pipeline, estimator, mode, window, out_dir, design=design,
                      reference=HandReference.of_calibration(cal, HAND_FORCE_AT_MVC_N,
                                                             hand.paradigm),
                      decoder=part)
    report: dict[str, Any] = {"files": [str(p) for p in export.files],
                              "models": export.summary(), "hand": hand.fields()}
    if check_recording is None:
        return export, report
    library = CompiledLibrary(build_export(export)[0])
    replay = check.replay_estimator(library, check_recording, cal.pipeline, mode,
                                    channels=fitted.channels, window_ms=window.window_ms,
                                    step_ms=window.step_ms,
                                    uses_force=bool(export.estimator.summary["uses_force"]))
    decoded = None
    if part is None:
        c_reference, py_reference = check.replay_reference(library, replay.estimate_c_n,
                                                           export.reference)
    else:
        decoded = check.DecoderCheck.of(library, check_recording, export, replay)
        c_reference = decoded.shaping.reference_c_n
        py_reference = decoded.shaping.reference_py_n
    command_error = c_commands = None
    observations: list = []
    if design is not None:
        run = check.hand_run(design, obj, check_recording, fitted,
                             duration_s=CONTROLLER_CHECK_S, seed=seed, hand=hand)
        observations = run.observations
        c_commands = check.replay_controller(library, design, observations)
        bounded = c_commands if part is None else check.clip_commands(c_commands, run.bounds)
        command_error = float(np.max(np.abs(bounded - run.commands), initial=0.0))
    report["check"] = {"samples": replay.samples, "windows": replay.windows,
                       "control_steps": len(observations),
                       "max_abs_error": {"features": replay.feature_error,
                                         "estimate_n": replay.estimate_error_n,
                                         "reference_n": float(np.max(np.abs(
                                             c_reference - py_reference), initial=0.0)),
                                         "command": command_error},
                       "features_max_ulps": replay.feature_ulps}
    if decoded is not None:
        report["check"]["decoder"] = decoded.summary()
    if target is not None:
        from scenarios.deploy.target import run_target

        report["target"] = run_target(export, check_recording, replay, observations,
                                      c_commands=c_commands, c_reference=c_reference,
                                      decoded=decoded)
    return export, report
