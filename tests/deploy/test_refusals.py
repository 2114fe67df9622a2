"""What the export refuses, before any file is written, and what it says without a compiler."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from controllers.export_c import ControllerNotExportableError, export_controller
from estimation.export_c import NotExportableError, feature_window
from scenarios.deploy.build import CompilerMissingError, build_export
from scenarios.deploy.writer import export_c
from scenarios.live.recorded import fit_calibration
from sim.c_source import ExportError, check_stable, model_digest
from sim.hand.objects import make_object


@pytest.fixture(scope="module")
def fitted(sessions):
    fit, _ = sessions
    return fit, fit_calibration(fit, "ss_kf", mode="free_run", seed=0)


def _window(recording, fitted_cal):
    return feature_window(recording.fs_hz, recording.n_channels, fitted_cal.channel_index)


def test_an_estimator_without_export_is_refused_naming_the_exportable(fitted, tmp_path):
    recording, _ = fitted
    narx = fit_calibration(recording, "narx", mode="free_run", seed=0)
    with pytest.raises(NotExportableError) as err:
        export_c(narx.calibration.pipeline, "narx", "free_run", _window(recording, narx),
                 tmp_path / "out")
    message = str(err.value)
    assert "\n" not in message and "'narx'" in message
    assert "ss_kf" in message and "transfer_mlp" in message
    assert not (tmp_path / "out").exists()


def test_the_mpc_is_refused_naming_the_exportable_controllers():
    design = grasp_design(make_object("can"), "mpc", 0.01, None)
    with pytest.raises(ControllerNotExportableError, match=r"'mpc'.*pid, lead_lag"):
        export_controller(design)


def test_an_unstable_state_matrix_is_refused_before_any_file(fitted, tmp_path, monkeypatch):
    recording, cal = fitted
    est = cal.calibration.pipeline.estimator_
    F, Gu, Gy, h = est.lti("free_run")
    unstable = F * (1.5 / np.max(np.abs(np.linalg.eigvals(F))))  # spectral radius 1.5
    monkeypatch.setattr(est, "lti", lambda mode: (unstable, Gu, Gy, h))
    with pytest.raises(ExportError, match="spectral radius 1.5"):
        export_c(cal.calibration.pipeline, "ss_kf", "free_run", _window(recording, cal),
                 tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_non_finite_coefficient_is_refused_before_any_file(fitted, tmp_path):
    recording, cal = fitted
    scaling = cal.calibration.pipeline.scaling_
    saved = scaling.u_min.copy()
    try:
        scaling.u_min[2] = np.nan
        with pytest.raises(ExportError, match="u_min holds a non-finite value"):
            export_c(cal.calibration.pipeline, "ss_kf", "free_run", _window(recording, cal),
                     tmp_path / "out")
    finally:
        scaling.u_min[:] = saved
    assert not (tmp_path / "out").exists()


def test_stability_check_allows_a_controllers_integrator_only_when_asked():
    integrator = np.array([[1.0]])
    assert check_stable("pi", integrator, allow_unit=True) == pytest.approx(1.0)
    with pytest.raises(ExportError):
        check_stable("estimator", integrator)


def test_without_a_compiler_the_files_are_written_and_the_build_says_what_to_install(
        fitted, tmp_path, monkeypatch):
    recording, cal = fitted
    ex = export_c(cal.calibration.pipeline, "ss_kf", "free_run", _window(recording, cal),
                  tmp_path)
    assert {p.name for p in ex.files} >= {"griploop.h", "griploop_features.c",
                                          "griploop_estimator.c", "griploop_types.h"}
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    monkeypatch.delenv("CC", raising=False)
    with pytest.raises(CompilerMissingError, match="apt-get install gcc") as err:
        build_export(ex)
    assert "\n" not in str(err.value)


def test_every_file_names_the_version_and_its_model_digest(fitted, tmp_path):
    recording, cal = fitted
    ex = export_c(cal.calibration.pipeline, "ss_kf", "free_run", _window(recording, cal),
                  tmp_path)
    est = (tmp_path / "griploop_estimator.c").read_text()
    assert ex.estimator.digest in est and "Written by griploop" in est
    assert "static const gl_real gl_M[" in est and "malloc" not in est
    includes = {line.split()[1] for p in ex.files for line in p.read_text().splitlines()
                if line.startswith("#include <")}
    assert includes == {"<math.h>", "<stdint.h>"}
    # the digest is of the coefficients: another fit, another digest
    assert model_digest("x", {"a": np.ones(2)}, {}) != model_digest("x", {"a": np.zeros(2)}, {})


def test_a_rest_threshold_open_above_its_close_is_refused_before_any_file(fitted, tmp_path):
    from scenarios.runners.semg_reference import HandReference

    recording, cal = fitted
    with pytest.raises(ExportError, match="expected 0 <= off <= on"):
        export_c(cal.calibration.pipeline, "ss_kf", "free_run", _window(recording, cal),
                 tmp_path / "out", reference=HandReference(rest_on_n=1.0, rest_off_n=2.0))
    assert not (tmp_path / "out").exists()
