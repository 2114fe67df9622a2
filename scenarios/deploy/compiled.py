"""``griploop episode --compiled``: the episode's own estimator and controller, as C, in the loop.

:func:`compiled_pair` exports the calibration's fitted pipeline and the design's
runtime controller (:func:`scenarios.deploy.writer.export_c`), compiles them with
the host compiler and returns the calibration and design with their Python parts
replaced: the calibration's pipeline streams through the C estimator
(:class:`CompiledPipeline`), the design's runtime controller is the C controller, and
its bank reports the reference the C force loop tracked (the episode's
``tracked_reference_n`` trace). Everything else (the user, the features, the hand, the
metrics, the loop analyses) is the Python episode's. The C feature window is
checked separately, sample for sample (:mod:`scenarios.deploy.check`).
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path
from typing import Any

from estimation.export_c import feature_window
from estimation.features import PAPER_CHANNELS
from scenarios.deploy.build import build_export
from scenarios.deploy.library import CompiledController, CompiledLibrary, CompiledStream
from scenarios.deploy.writer import export_c
from scenarios.runners.semg_reference import HandReference
from sim.c_source import ExportError

#: The armband of the virtual subjects: 8 channels at 200 Hz.
ARMBAND_CHANNELS = 8
ARMBAND_FS_HZ = 200.0


class CompiledPipeline:
    """A fitted pipeline whose stream is the compiled estimator (what an episode asks of it)."""

    def __init__(self, library: CompiledLibrary, python: Any, *, uses_force: bool,
                 digest: str) -> None:
        self._library = library
        self.python = python
        self.uses_force = uses_force
        self.digest = digest

    def streaming(self, mode: str, **options: Any) -> CompiledStream:
        """A fresh compiled stream (``mode`` is the exported one)."""
        return CompiledStream(self._library, mode=mode, uses_force=self.uses_force)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["python"], name)


class _CoreView:
    """The design's bank, reporting the compiled controller's tracked reference."""

    def __init__(self, core: Any, compiled: CompiledController) -> None:
        self._core = core
        self._compiled = compiled

    @property
    def last_reference_n(self) -> float:
        return self._compiled.last_reference_n

    def __getattr__(self, name: str) -> Any:
        return getattr(self.__dict__["_core"], name)


def compiled_pair(calibration: Any, design: Any, *, hand_force_at_mvc_n: float,
                  build_dir: Path | None = None) -> tuple[Any, Any]:
    """The calibration and design of an episode with the estimator and controller compiled.

    Parameters
    ----------
    calibration : scenarios.runners.calibration.Calibration
        Fitted on the paper's channels of the 8-channel armband at 200 Hz.
    design : controllers.design.ControllerDesign
    hand_force_at_mvc_n : float
        The episode's force mapping (stated in the exported header).
    build_dir : Path, optional
        Where the C files and library go (default: a temporary folder, removed once
        the library is loaded).

    Returns
    -------
    calibration, design
        Copies with the compiled parts (the oracle's calibration is returned as is).

    Raises
    ------
    estimation.export_c.NotExportableError, controllers.export_c.ControllerNotExportableError
        The estimator or the controller kind has no C export.
    sim.c_source.ExportError
        The oracle (nothing to compile), or coefficients that cannot be exported.
    scenarios.deploy.build.CompilerMissingError, scenarios.deploy.build.BuildError
    """
    if calibration.pipeline is None:
        raise ExportError("estimator oracle: the oracle is the user's true force, not a model; "
                          "expected a fitted estimator to compile")
    window = feature_window(ARMBAND_FS_HZ, ARMBAND_CHANNELS, [c - 1 for c in PAPER_CHANNELS])
    with tempfile.TemporaryDirectory(prefix="griploop-compiled-") as tmp:
        out = Path(build_dir) if build_dir is not None else Path(tmp)
        export = export_c(calibration.pipeline, calibration.name, calibration.mode, window, out,
                          design=design, reference=HandReference.of_calibration(
                              calibration, hand_force_at_mvc_n))
        library = CompiledLibrary(build_export(export)[0])  # loaded: the files may go
    pipeline = CompiledPipeline(library, calibration.pipeline,
                                uses_force=bool(export.estimator.summary["uses_force"]),
                                digest=export.estimator.digest)
    controller = CompiledController(library, dt_s=design.core.dt_s, name=design.kind)
    controller.digest = export.controller.digest
    compiled_design = dataclasses.replace(design, controller=controller,
                                          core=_CoreView(design.core, controller))
    return dataclasses.replace(calibration, pipeline=pipeline), compiled_design


def maybe_compiled(compiled: bool, calibration: Any, design: Any,
                   hand_force_at_mvc_n: float) -> tuple[Any, Any]:
    """:func:`compiled_pair` when ``compiled``, else the calibration and design unchanged."""
    if not compiled:
        return calibration, design
    return compiled_pair(calibration, design, hand_force_at_mvc_n=hand_force_at_mvc_n)
