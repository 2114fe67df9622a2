"""C and Python, sample for sample: features, estimates and commands on whole recordings.

Tolerances (docs/DEPLOY.md): features within one float32 unit in the last place of the
Python value (the C divides and takes square roots in float32); estimate and command
within 1e-3 (N, command units) over the whole recording.
"""

from __future__ import annotations

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from estimation.export_c import feature_window
from scenarios.deploy import check
from scenarios.deploy.build import build_export
from scenarios.deploy.library import CompiledLibrary
from scenarios.deploy.writer import export_c
from scenarios.live.recorded import fit_calibration
from sim.hand.objects import make_object
from sim.recording import load_recording

TO_HAND_AT_MVC_N = 30.0


def _export(tmp_path, recording, estimator, mode, *, design=None, channels=(6, 7, 8)):
    fitted = fit_calibration(recording, estimator, mode=mode, channels=list(channels), seed=0)
    window = feature_window(recording.fs_hz, recording.n_channels, fitted.channel_index)
    ex = export_c(fitted.calibration.pipeline, estimator, mode, window, tmp_path, design=design,
                  to_hand=TO_HAND_AT_MVC_N / fitted.calibration.mvc_cal_n,
                  reference_max_n=1.2 * TO_HAND_AT_MVC_N)
    library_path, warnings = build_export(ex)
    assert warnings == "", warnings  # the export compiles clean with -Wall -Wextra -Wpedantic
    return fitted, ex, CompiledLibrary(library_path)


def _replay(library, fitted, ex, recording):
    return check.replay_estimator(library, recording, fitted.calibration.pipeline, ex.mode,
                                  channels=fitted.channels, window_ms=ex.window.window_ms,
                                  step_ms=ex.window.step_ms,
                                  uses_force=ex.estimator.summary["uses_force"])


@pytest.mark.parametrize(("estimator", "mode"), [
    ("ss_kf", "one_step"), ("ss_kf", "free_run"), ("latent_kf", "free_run"),
    ("mlp", "free_run"), ("features_rms", "free_run")])
def test_a_virtual_subjects_recording_replays_alike(c_compiler, sessions, tmp_path, estimator,
                                                    mode):
    fit, replay_rec = sessions
    fitted, ex, library = _export(tmp_path, fit, estimator, mode)
    r = _replay(library, fitted, ex, replay_rec)
    assert r.samples == replay_rec.n_samples and r.windows > 400
    assert r.feature_ulps <= check.FEATURE_TOLERANCE_ULPS
    assert r.estimate_error_n <= check.ESTIMATE_TOLERANCE_N
    # the estimate moves: a C stream stuck at a constant would not pass
    assert np.ptp(r.estimate_py_n) > 5.0


@pytest.mark.parametrize("estimator", ["transfer_mlp", "adaptive_mlp"])
def test_the_ensembles_replay_alike(c_compiler, sessions, tmp_path, estimator):
    # adaptive_mlp (the recommended estimator) weights the person's network, which reads
    # the current window only, against the adapted ensemble on the lagged windows
    fit, replay_rec = sessions
    fitted, ex, library = _export(tmp_path, fit, estimator, "free_run", channels=range(1, 9))
    r = _replay(library, fitted, ex, replay_rec)
    assert ex.estimator.summary["n_inputs"] == 24
    assert r.feature_ulps <= check.FEATURE_TOLERANCE_ULPS
    assert r.estimate_error_n <= check.ESTIMATE_TOLERANCE_N
    assert np.ptp(r.estimate_py_n) > 5.0
    if estimator == "adaptive_mlp":
        assert fitted.calibration.pipeline.estimator_.networks_  # the weighted form ran


def test_an_imported_csv_recording_replays_alike(c_compiler, sessions, tmp_path):
    fit, replay_rec = sessions
    # another tool's layout: pandas index, time in ms, emg_0..emg_7, force_n, a label column
    path = tmp_path / "other_tool.csv"
    t_ms = np.arange(replay_rec.n_samples) * 1000.0 / replay_rec.fs_hz
    header = ",time_ms," + ",".join(f"emg_{i}" for i in range(8)) + ",force_n,label"
    rows = [f"{k},{t_ms[k]:.3f}," + ",".join(str(int(v)) for v in replay_rec.emg[k])
            + f",{replay_rec.force_n[k]:.6f},rest" for k in range(replay_rec.n_samples)]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    from sim.recording import ColumnMap

    imported = load_recording(path, columns=ColumnMap(time="time_ms", emg="emg_*",
                                                      force="force_n"), time_unit="ms")
    assert imported.emg.dtype == np.int8 and imported.n_samples == replay_rec.n_samples
    fitted, ex, library = _export(tmp_path / "out", fit, "ss_kf", "one_step")
    r = _replay(library, fitted, ex, imported)
    assert r.feature_ulps <= check.FEATURE_TOLERANCE_ULPS
    assert r.estimate_error_n <= check.ESTIMATE_TOLERANCE_N


@pytest.mark.parametrize(("kind", "object_name"), [
    ("pid", "can"), ("lead_lag", "can"), ("pid", "egg"), ("lead_lag", "egg")])
def test_controller_commands_agree_on_the_hands_observations(c_compiler, sessions, tmp_path,
                                                              kind, object_name):
    fit, replay_rec = sessions
    obj = make_object(object_name)
    # the egg with the slip reflex on, the can without: both wrappers are exercised
    spec = {"slip_reflex": {"latency_s": 0.05, "gain": 0.3}} if object_name == "egg" else None
    design = grasp_design(obj, kind, 0.01, spec)
    fitted, ex, library = _export(tmp_path, fit, "ss_kf", "free_run", design=design)
    r = _replay(library, fitted, ex, replay_rec)
    # the recording replayed in a trial, mapped so that its strongest estimate asks about
    # 1.3 x the object's slip force: the hand closes, holds and follows the estimate
    scale = (3.0 if object_name == "egg" else 8.0) / max(float(np.max(r.estimate_py_n)), 1e-9)
    observations, commands = check.hand_observations(
        design, obj, replay_rec, fitted,
        hand_force_at_mvc_n=scale * fitted.calibration.mvc_cal_n, duration_s=5.0)
    c_commands = check.replay_controller(library, design, observations)
    assert len(observations) > 300
    assert any(o.both_sides for o in observations)  # the gate handed over to force control
    assert np.max(np.abs(c_commands - commands)) <= check.COMMAND_TOLERANCE
