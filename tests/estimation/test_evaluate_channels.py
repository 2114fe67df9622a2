"""``griploop evaluate --channels all`` and channel-set errors, in process."""

from __future__ import annotations

import json

import numpy as np
import pytest

from estimation.reproduce import evaluate_recording, parse_channels
from scenarios.cli import main
from sim.recording import Recording
from sim.user.subjects import make_population


@pytest.fixture(scope="module")
def recording_file(tmp_path_factory):
    rec = make_population(1, seed=3)[0].paper_session()
    return rec.save_npz(tmp_path_factory.mktemp("rec") / "s1.npz")


def test_parse_channels():
    assert parse_channels("all") is None and parse_channels(" ALL ") is None
    assert parse_channels("6,7,8") == [6, 7, 8]
    assert parse_channels("emg1,2") == ["emg1", 2]
    with pytest.raises(ValueError, match="expected 'all' or a comma-separated list"):
        parse_channels(" , ")


def test_evaluate_all_channels_from_the_cli(recording_file, tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = main(["evaluate", "--recording", str(recording_file), "--channels", "all",
                 "--estimators", "ridge,gbt,ss_kf,persistence", "--json", str(out)])
    assert code == 0
    result = json.loads(out.read_text())
    assert result["recording"]["channels"] == "all"
    assert set(result["estimators"]) == {"ridge", "gbt", "ss_kf", "persistence"}
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5
    assert result["training"]["ridge"]["compress"] == "sqrt"
    assert "ridge" in capsys.readouterr().out


def test_all_channels_works_on_any_eight_channel_recording():
    rng = np.random.default_rng(5)
    n, fs = 4000, 500.0  # another rate and float sEMG: a real recording's shape
    force = np.clip(np.sin(np.linspace(0, 6 * np.pi, n)), 0, None) * 20
    emg = rng.standard_normal((n, 8)) * (1 + force[:, None] / 5)
    rec = Recording(emg=emg, fs_hz=fs, force_n=force, channel_names=[f"c{i}" for i in range(8)],
                    emg_unit="mV", source="synthetic")
    res = evaluate_recording(rec, channels="all", estimators=["ridge", "gbt", "mlp"])
    assert res["recording"]["n_windows"] > 20
    assert res["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_a_channel_the_recording_lacks_is_one_line(recording_file, capsys):
    code = main(["evaluate", "--recording", str(recording_file), "--channels", "6,9",
                 "--estimators", "ridge"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert "unknown channel 9" in err and "expected 1..8" in err


def _entry(values):
    ok = [v for v in values if v is not None]
    return {"r2_mean": float(np.mean(ok)), "r2_sd": 0.0, "r2_min": min(ok), "n_ok": len(ok),
            "per_subject": [{"r2": v, "status": "ok" if v is not None else "unstable"}
                            for v in values]}


def test_recommendation_follows_the_numbers():
    from estimation.reproduce import recommendation

    result = {"config": {"channels": "all"}, "estimators": {
        "ss_kf": {"one_step": _entry([0.95, 0.93]), "free_run": _entry([0.5, 0.4])},
        "ridge": {"free_run": _entry([0.90, 0.88])},
        "mlp": {"free_run": _entry([0.99, None])},  # not run on every subject: not eligible
    }}
    rec = recommendation(result)
    assert rec["estimator"] == "ridge" and rec["channels"] == "all" and rec["mode"] == "free_run"
    assert "use RIDGE in free_run on all 8 channels" in rec["reason"] and "below" in rec["reason"]
    assert rec["r2_mean"] == pytest.approx(0.89) and rec["r2_min"] == pytest.approx(0.88)
    result["estimators"]["ridge"]["free_run"] = _entry([0.97, 0.96])
    assert "above the paper's SS_KF one_step figure (0.940)" in recommendation(result)["reason"]
