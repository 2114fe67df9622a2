"""``export-c --paradigm velocity``: the decoder, its MAV window and the velocity shaping in C.

Checked on recordings with open contractions (a virtual subject's paper session followed by
its open session), against Python's decoder stream and ``controllers.paradigms.Velocity``,
on the host and (marker ``target``) on the emulated Cortex-M4F.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from controllers.paradigms import DecoderMissingError
from estimation.export_c import feature_window
from scenarios.cli import main
from scenarios.deploy.check import (
    COMMAND_TOLERANCE,
    DECODER_TOLERANCE,
    RANGE_TOLERANCE,
    REFERENCE_TOLERANCE_N,
)
from scenarios.deploy.session import ExportSpec, export_session
from scenarios.deploy.writer import export_c
from scenarios.live.calibration_fit import with_open_contractions
from scenarios.live.recorded import fit_calibration
from scenarios.runners.semg_reference import HandReference
from scenarios.runners.trial_loop import HandSettings
from sim.user.subjects import VirtualSubject

DECODER_FILES = {"griploop_decoder.h", "griploop_decoder.c", "griploop_decoder_window.h",
                 "griploop_decoder_window.c"}


@pytest.fixture(scope="module")
def open_sessions(sessions):
    """The shared squeeze sessions, each followed by a session of open contractions."""
    subject = VirtualSubject.sample(0, 1)
    fit, replay = sessions
    return (with_open_contractions(fit, subject.open_session(np.random.default_rng(10))),
            with_open_contractions(replay, subject.open_session(np.random.default_rng(11))))


@pytest.mark.parametrize(("decoder", "controller"), [("pattern", None), ("two_site", "pid")])
def test_the_velocity_export_equals_python(c_compiler, open_sessions, tmp_path, decoder,
                                           controller):
    fit, replay = open_sessions
    spec = ExportSpec("ss_kf", [6, 7, 8], controller=controller,
                      object_name=None if controller is None else "can",
                      hand=HandSettings("self_locking", "velocity", False, decoder))
    export, report = export_session(fit, spec, tmp_path, check_recording=replay)
    assert DECODER_FILES <= {p.name for p in export.files}
    assert report["hand"]["decoder"] == decoder
    assert report["models"]["decoder"]["decoder"] == decoder
    d = report["check"]["decoder"]
    # every window of the recording, its open contractions decoded as open
    assert d["windows"] == report["check"]["windows"] > 500
    assert d["open_windows"] > 20 and d["close_windows"] > 20
    assert d["max_abs_error"] <= DECODER_TOLERANCE
    assert d["label_mismatches"] == 0
    assert d["mav_max_ulps"] <= 1.0
    assert d["reference_max_abs_error_n"] <= REFERENCE_TOLERANCE_N
    assert d["command_range_max_abs_error"] <= RANGE_TOLERANCE
    if controller is not None:
        assert report["check"]["control_steps"] > 100
        assert report["check"]["max_abs_error"]["command"] <= COMMAND_TOLERANCE
    header = (tmp_path / "griploop.h").read_text()
    assert "Paradigm velocity" in header and "GRIPLOOP_GRIP_AT_FULL_CLOSE_N" in header


def test_velocity_without_open_contractions_is_refused_in_one_line(sessions, tmp_path, capsys):
    fit, _ = sessions  # the paper's squeezes only
    path = tmp_path / "cal.npz"
    fit.save(path)
    out = tmp_path / "c"
    assert main(["export-c", "--calibration", str(path), "--estimator", "ss_kf",
                 "--paradigm", "velocity", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err
    assert "paradigm velocity needs open contractions" in err
    assert "griploop calibrate --open" in err
    assert not out.exists()


def test_export_c_refuses_velocity_without_a_decoder_before_any_file(sessions, tmp_path):
    fit, _ = sessions
    fitted = fit_calibration(fit, "ss_kf", mode="free_run", channels=[6, 7, 8], seed=0)
    window = feature_window(fit.fs_hz, fit.n_channels, fitted.channel_index)
    with pytest.raises(DecoderMissingError, match="paradigm velocity needs open and close"):
        export_c(fitted.calibration.pipeline, "ss_kf", "free_run", window, tmp_path / "c",
                 reference=HandReference(paradigm="velocity"))
    assert not (tmp_path / "c").exists()


def test_force_exports_carry_no_decoder(sessions, tmp_path):
    # force and force_hold without --decoder render the files they always did
    fit, _ = sessions
    for paradigm in ("force", "force_hold"):
        spec = ExportSpec("ss_kf", [6, 7, 8], hand=HandSettings(paradigm=paradigm))
        export, report = export_session(fit, spec, tmp_path / paradigm)
        names = {p.name for p in export.files}
        assert not names & DECODER_FILES and len(names) == 8
        assert set(report["models"]) == {"features", "estimator", "controller"}
        for name in ("griploop.h", "griploop_reference.c", "griploop_runtime.c"):
            assert "decoder" not in (tmp_path / paradigm / name).read_text()


def test_export_c_velocity_from_the_command_line(c_compiler, open_sessions, tmp_path, capsys):
    fit, replay = open_sessions
    fit.save(tmp_path / "cal.npz")
    replay.save(tmp_path / "check.npz")
    report = tmp_path / "export.json"
    assert main(["export-c", "--calibration", str(tmp_path / "cal.npz"), "--estimator",
                 "ss_kf", "--paradigm", "velocity", "--decoder", "two_site", "--out",
                 str(tmp_path / "c"), "--check", str(tmp_path / "check.npz"), "--json",
                 str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["check"]["decoder"]["label_mismatches"] == 0
    assert "decoder:" in capsys.readouterr().out


@pytest.mark.target
def test_the_velocity_target_replay_equals_the_host_within_the_budget(
        arm_tools, c_compiler, open_sessions, tmp_path):
    fit, replay = open_sessions
    spec = ExportSpec("ss_kf", [6, 7, 8], controller="pid", object_name="can",
                      hand=HandSettings("self_locking", "velocity", False, "pattern"))
    export, report = export_session(fit, spec, tmp_path, check_recording=replay,
                                    target="cortex-m4")
    t = report["target"]
    assert t["matches_host"], t["max_abs_difference_from_host"]
    windows, steps = report["check"]["windows"], report["check"]["control_steps"]
    # per window: features, estimate, reference, 8 MAV, close, open, label, 2 bounds
    assert t["outputs_compared"] == windows * (export.window.n_features + 2 + 8 + 5) + steps
    ipu = t["instructions_per_update"]
    print(f"instructions per update: features {ipu['features']}, estimator "
          f"{ipu['estimator']}, decoder {ipu['decoder']}, together "
          f"{ipu['features_estimator_decoder']}")
    assert 0 < ipu["decoder"] and ipu["features_estimator_decoder"] <= 20_000
    assert t["ram_bytes"] < 8 * 1024
