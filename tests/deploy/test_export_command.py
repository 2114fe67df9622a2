"""``griploop export-c``: files, the JSON contract, the host check and refusals in one line."""

from __future__ import annotations

import json

import pytest

from scenarios.cli import main
from scenarios.deploy.check import (
    COMMAND_TOLERANCE,
    ESTIMATE_TOLERANCE_N,
    REFERENCE_TOLERANCE_N,
)


@pytest.fixture(scope="module")
def files(sessions, tmp_path_factory):
    fit, replay = sessions
    folder = tmp_path_factory.mktemp("recordings")
    fit.save(folder / "cal.npz")
    replay.save(folder / "check.npz")
    return folder / "cal.npz", folder / "check.npz"


def test_export_c_writes_the_files_and_checks_them(c_compiler, files, tmp_path, capsys):
    cal, replay = files
    out = tmp_path / "c"
    report = tmp_path / "export.json"
    assert main(["export-c", "--calibration", str(cal), "--estimator", "ss_kf", "--controller",
                 "lead_lag", "--object", "can", "--out", str(out), "--check", str(replay),
                 "--json", str(report)]) == 0
    data = json.loads(report.read_text())
    assert set(data) >= {"files", "check"} and "target" not in data
    assert {p.split("/")[-1] for p in data["files"]} == {
        "griploop.h", "griploop_types.h", "griploop_runtime.c", "griploop_reference.c",
        "griploop_features.h",
        "griploop_features.c", "griploop_estimator.h", "griploop_estimator.c",
        "griploop_controller.h", "griploop_controller.c"}
    err = data["check"]["max_abs_error"]
    assert data["check"]["samples"] > 10000
    assert data["hand"] == {"paradigm": "force", "drive": "backdrivable", "auto_grip": False}
    assert err["estimate_n"] <= ESTIMATE_TOLERANCE_N
    assert err["reference_n"] <= REFERENCE_TOLERANCE_N
    assert err["command"] is not None and err["command"] <= COMMAND_TOLERANCE
    assert "max |C - Python|" in capsys.readouterr().out


def test_export_c_without_check_has_no_check_key(files, tmp_path):
    cal, _ = files
    report = tmp_path / "export.json"
    assert main(["export-c", "--calibration", str(cal), "--estimator", "latent_kf", "--out",
                 str(tmp_path / "c"), "--json", str(report)]) == 0
    data = json.loads(report.read_text())
    assert "check" not in data and "target" not in data and len(data["files"]) == 8


@pytest.mark.parametrize(("args", "expected"), [
    (["--estimator", "gbt"], "exportable estimators: ss_kf"),
    (["--estimator", "ss_kf", "--controller", "mpc", "--object", "can"],
     "exportable controllers: pid, lead_lag"),
    (["--estimator", "ss_kf", "--controller", "pid"], "--controller and --object go together"),
    (["--estimator", "ss_kf", "--target", "cortex-m4"], "found no --check"),
    (["--estimator", "ss_kf", "--paradigm", "hold"],
     "--paradigm: expected one of ['force', 'force_hold', 'velocity'], found 'hold'"),
    (["--estimator", "ss_kf", "--drive", "worm"],
     "--drive: expected one of ['backdrivable', 'self_locking'], found 'worm'"),
])
def test_export_c_refuses_in_one_line(files, tmp_path, capsys, args, expected):
    cal, _ = files
    assert main(["export-c", "--calibration", str(cal), "--out", str(tmp_path / "c"),
                 *args]) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and "\n" not in err
    assert not (tmp_path / "c").exists()


def test_export_c_carries_the_hands_settings(c_compiler, files, tmp_path, capsys):
    # force_hold shapes the C runtime's reference (checked against Python on the
    # recording), auto_grip exports the controller with the slip reflex, and the check's
    # hand runs on the self-locking drive
    cal, replay = files
    report = tmp_path / "export.json"
    assert main(["export-c", "--calibration", str(cal), "--estimator", "ss_kf", "--controller",
                 "pid", "--object", "can", "--out", str(tmp_path / "c"), "--check", str(replay),
                 "--paradigm", "force_hold", "--drive", "self_locking", "--auto-grip",
                 "--json", str(report)]) == 0
    data = json.loads(report.read_text())
    assert data["hand"] == {"paradigm": "force_hold", "drive": "self_locking",
                            "auto_grip": True}
    err = data["check"]["max_abs_error"]
    assert err["reference_n"] <= REFERENCE_TOLERANCE_N
    assert err["command"] <= COMMAND_TOLERANCE
    assert data["models"]["controller"]["slip_reflex"]
    header = (tmp_path / "c" / "griploop.h").read_text()
    assert "Paradigm force_hold" in header
    assert "reference (force_hold)" in capsys.readouterr().out
