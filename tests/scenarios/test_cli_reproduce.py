"""``griploop reproduce`` and ``griploop evaluate``: outputs, JSON contract, errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from scenarios.cli import main
from sim.recording import Recording


def _toy(path: Path, *, with_force: bool = True, fs_hz: float = 500.0,
         duration_s: float = 30.0) -> Path:
    """A recording at a non-MYO rate whose sEMG amplitude follows the force."""
    rng = np.random.default_rng(0)
    t = np.arange(int(duration_s * fs_hz)) / fs_hz
    intent = np.clip(np.sin(2 * np.pi * t / 10.0), 0, None) * np.repeat([0.3, 0.6, 1.0],
                                                                        t.size // 3 + 1)[:t.size]
    emg = (1.0 + 20.0 * intent[:, None] * np.ones(8)) * rng.standard_normal((t.size, 8))
    force = 30.0 * intent + 0.1 * rng.standard_normal(t.size)
    rec = Recording(emg=emg, fs_hz=fs_hz, emg_unit="uV",
                    force_n=force if with_force else None, source="toy")
    return rec.save(path)


def test_reproduce_writes_the_json_contract(tmp_path, capsys) -> None:
    out = tmp_path / "rep.json"
    code = main(["reproduce", "--subjects", "2", "--seed", "1", "--max-epochs", "3",
                 "--json", str(out), "--csv", str(tmp_path / "csv")])
    assert code == 0
    text = capsys.readouterr().out
    assert "Table 2 (one_step)" in text and "Table 2 (free_run)" in text and "Table 3" in text
    data = json.loads(out.read_text())
    assert data["estimators"]["ss_kf"]["free_run"]["per_subject"][1]["r2"] is not None
    assert {"A", "B", "C", "Gamma", "Q", "R", "predictor_gain", "order"} <= set(data["model"])
    assert data["timing"]["ss_kf"]["train_ms_median"] > 0
    assert (tmp_path / "csv" / "table3.csv").exists()


def test_evaluate_on_a_recording_file(tmp_path, capsys) -> None:
    rec = _toy(tmp_path / "rec.npz")
    out = tmp_path / "eval.json"
    code = main(["evaluate", "--recording", str(rec), "--channels", "6,7,8",
                 "--estimators", "ss_kf,persistence,latent_kf", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert set(data["estimators"]) == {"ss_kf", "persistence", "latent_kf"}
    # 125 ms at 500 Hz rounds to 62 samples: the model's sample time follows the features
    assert data["recording"]["dt_s"] == 62 / 500 and data["recording"]["fs_hz"] == 500.0
    assert data["model"]["order"] == 4 and data["model"]["dt_s"] == 62 / 500
    assert "ss_kf" in capsys.readouterr().out


def test_an_identification_half_too_short_to_adapt_is_said_in_one_line(tmp_path, capsys):
    # 20 s: 157 windows of 400 ms every 125 ms, 78 to identify, under adaptive_mlp's 96;
    # it fits the person's MLP alone and the terminal gets one line, not Python's
    # file-and-line warning
    rec = _toy(tmp_path / "short.npz", fs_hz=200.0, duration_s=20.0)
    out = tmp_path / "eval.json"
    code = main(["evaluate", "--recording", str(rec), "--channels", "all",
                 "--estimators", "adaptive_mlp", "--json", str(out)])
    assert code == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["griploop evaluate: warning: AdaptiveMLP: 78 identification windows are "
                   "too few to adapt the pretrained ensemble (at least 96); using the "
                   "person's own MLP alone"], err
    assert json.loads(out.read_text())["estimators"]["adaptive_mlp"]["free_run"]["r2_mean"] > 0.5


def test_user_errors_are_one_line(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    rec = _toy(tmp_path / "rec.npz")
    no_force = _toy(tmp_path / "noforce.npz", with_force=False)
    cases = [
        (["evaluate", "--recording", str(tmp_path / "missing.npz")], "no such file"),
        (["evaluate", "--recording", str(rec), "--estimators", "kalman"], "unknown estimator"),
        (["evaluate", "--recording", str(rec), "--channels", "6,9"], "unknown channel"),
        (["evaluate", "--recording", str(no_force)], "no force"),
    ]
    for args, needle in cases:
        assert main(args) == 2
        err = capsys.readouterr().err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], err
        assert lines[0].startswith("griploop evaluate: error: ")


def test_reproduce_exits_nonzero_on_bad_option() -> None:
    proc = subprocess.run([sys.executable, "-m", "scenarios.cli", "reproduce", "--subjects", "0"],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "positive integer" in proc.stderr


def test_an_unknown_judge_population_is_refused_before_any_work(capsys, monkeypatch) -> None:
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    assert main(["reproduce", "--subjects", "1", "--judge", "nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["griploop reproduce: error: unknown population 'nope'; expected one of "
                   "default, wide, extensor_dominant"]
