"""``export-c``'s Python API: a fitted pipeline (and a design) to C files in a folder.

:func:`export_c` asks each layer's emitter for its C text
(:func:`estimation.export_c.export_features`, :func:`estimation.export_c.export_estimator`,
:func:`controllers.export_c.export_controller`) and writes the files only once every
part has been made and checked: a refused estimator or controller (an unsupported
kind, non-finite coefficients, an unstable state matrix) leaves the folder untouched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from estimation.export_c import FeatureWindow, export_estimator, export_features
from sim.c_source import TYPES_HEADER, CModel, ExportError, render, types_header

#: Paradigms (:mod:`controllers.paradigms`) the runtime shapes the reference by.
EXPORTABLE_PARADIGMS = ("force", "force_hold")


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
    """

    out_dir: Path
    files: list[Path]
    features: CModel
    estimator: CModel
    controller: CModel | None
    window: FeatureWindow
    mode: str
    facts: dict[str, Any] = field(default_factory=dict)

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
        return {name: None if m is None else {"digest": m.digest, **m.summary}
                for name, m in parts.items()}


def export_c(pipeline: Any, estimator: str, mode: str, window: FeatureWindow,
             out_dir: Path, *, design: Any = None, to_hand: float | None = None,
             reference_max_n: float | None = None, rest_on_n: float = 0.0,
             rest_off_n: float = 0.0, paradigm: str = "force") -> CExport:
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
    to_hand, reference_max_n : float, optional
        The episode's force mapping (hand N per estimated N) and reference ceiling, N,
        stated in ``griploop.h`` for the developer.
    rest_on_n, rest_off_n : float
        The hand's rest threshold on the estimate, N (:mod:`estimation.rest_gate`, the
        calibration's ``rest_on_n`` and ``rest_off_n``; 0: none), applied by
        ``griploop_reference.c`` before the mapping.
    paradigm : str
        How the reference follows the estimate (:data:`EXPORTABLE_PARADIGMS`), shaped by
        ``griploop_reference.c`` as :mod:`controllers.paradigms` shapes it.

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
    """
    check_paradigm_exportable(paradigm)
    win, step = window.samples
    period = step / window.fs_hz
    fitted_dt = getattr(pipeline.estimator_, "dt_s", None)
    if fitted_dt is not None and abs(float(fitted_dt) - period) > 1e-9:
        raise ExportError(f"estimator {estimator}: fitted for a window every {fitted_dt} s; "
                          f"expected the feature window's {period:g} s")
    features = export_features(window)
    est = export_estimator(pipeline, estimator, mode,
                           extra={"update period": f"{period:g} s (one feature window)"})
    controller = None
    if design is not None:
        from controllers.export_c import export_controller

        controller = export_controller(design)
    models = [m for m in (features, est, controller) if m is not None]
    texts: dict[str, str] = {TYPES_HEADER: types_header(digests=[m.digest for m in models])}
    for m in models:
        texts.update(m.files)
    if not (math.isfinite(rest_on_n) and math.isfinite(rest_off_n)
            and 0.0 <= rest_off_n <= rest_on_n):
        raise ExportError(f"rest threshold: expected 0 <= off <= on (finite, N), found on "
                          f"{rest_on_n!r}, off {rest_off_n!r}")
    facts = {"fs_hz": window.fs_hz, "window_samples": win, "step_samples": step,
             "period_s": period, "to_hand": to_hand, "reference_max_n": reference_max_n,
             "rest_on_n": float(rest_on_n), "rest_off_n": float(rest_off_n),
             "paradigm": paradigm}
    for name in ("griploop.h", "griploop_reference.c", "griploop_runtime.c"):
        texts[name] = render("scenarios.deploy", name + ".j2", features=features, estimator=est,
                             controller=controller, mode=mode, **facts)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = []
    for name, text in texts.items():
        path = out_dir / name
        path.write_text(text, encoding="utf-8")
        files.append(path)
    return CExport(out_dir, files, features, est, controller, window, mode, facts)
