"""C and Python, sample for sample: features, estimates and commands on whole recordings.

Tolerances (docs/DEPLOY.md): features within one float32 unit in the last place of the
Python value (the C divides and takes square roots in float32); estimate and command
within 1e-3 (N, command units) over the whole recording.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from estimation.export_c import feature_window
from scenarios.deploy import check
from scenarios.deploy.build import build_export
from scenarios.deploy.library import CompiledLibrary
from scenarios.deploy.writer import export_c
from scenarios.live.recorded import fit_calibration
from scenarios.runners.semg_reference import HandReference
from sim.hand.objects import make_object
from sim.recording import load_recording

TO_HAND_AT_MVC_N = 30.0


def _export(tmp_path, recording, estimator, mode, *, design=None, channels=(6, 7, 8),
            paradigm="force", rest=False):
    fitted = fit_calibration(recording, estimator, mode=mode, channels=list(channels), seed=0)
    window = feature_window(recording.fs_hz, recording.n_channels, fitted.channel_index)
    cal = fitted.calibration
    reference = HandReference.of_calibration(cal, TO_HAND_AT_MVC_N, paradigm)
    if not rest:
        reference = replace(reference, rest_on_n=0.0, rest_off_n=0.0)
    ex = export_c(cal.pipeline, estimator, mode, window, tmp_path, design=design,
                  reference=reference)
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


def _running_max_while_positive(values):
    """force_hold from the force reference, recomputed: the largest value of each run of
    positive values so far, 0 outside them."""
    out, held = np.zeros_like(values), 0.0
    for k, v in enumerate(values):
        held = max(held, v) if v > 0 else 0.0
        out[k] = held
    return out


@pytest.mark.parametrize("paradigm", ["force", "force_hold"])
def test_the_runtimes_hand_reference_follows_python(c_compiler, sessions, tmp_path, paradigm):
    # griploop_reference.c (rest threshold, force mapping, paradigm) on the C estimates of a
    # whole recording, against griploop's Python parts fed the same estimates
    fit, replay_rec = sessions
    fitted, ex, library = _export(tmp_path, fit, "ss_kf", "free_run", paradigm=paradigm,
                                  rest=True)
    assert ex.reference.rest_on_n > 0.0 and ex.facts["paradigm"] == paradigm
    r = _replay(library, fitted, ex, replay_rec)
    c_ref, py_ref = check.replay_reference(library, r.estimate_c_n, ex.reference)
    assert np.max(np.abs(c_ref - py_ref)) <= check.REFERENCE_TOLERANCE_N
    closed = c_ref > 0
    # the gate closes and opens again several times: both edges are exercised
    assert closed.any() and np.count_nonzero(np.diff(closed.astype(int)) == -1) >= 2
    force = check.python_reference(r.estimate_c_n, replace(ex.reference, paradigm="force"))
    if paradigm == "force":
        assert np.array_equal(py_ref, force)
    else:
        np.testing.assert_allclose(c_ref, _running_max_while_positive(force), atol=1e-3)
        assert np.all(c_ref >= force - 1e-3) and np.max(c_ref - force) > 1.0
        # never falls while the gate stays closed; 0 at the first update it opens
        for k in np.flatnonzero(closed[1:] & closed[:-1]) + 1:
            assert c_ref[k] >= c_ref[k - 1]
        assert np.all(c_ref[np.flatnonzero(~closed)] == 0.0)


def test_a_paradigm_without_c_shaping_is_refused_before_any_file(sessions, tmp_path):
    from controllers.paradigms import Force, register_paradigm, unregister_paradigm
    from scenarios.deploy.writer import ParadigmNotExportableError

    fit, _ = sessions
    fitted = fit_calibration(fit, "ss_kf", mode="free_run", channels=[6, 7, 8], seed=0)
    window = feature_window(fit.fs_hz, fit.n_channels, fitted.channel_index)
    register_paradigm("plugin_hold", Force)
    try:
        with pytest.raises(ParadigmNotExportableError, match="exportable paradigms: force, "
                           "force_hold"):
            export_c(fitted.calibration.pipeline, "ss_kf", "free_run", window,
                     tmp_path / "c", reference=HandReference(paradigm="plugin_hold"))
    finally:
        unregister_paradigm("plugin_hold")
    assert not (tmp_path / "c").exists()
