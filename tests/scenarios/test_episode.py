"""Closed-loop episodes: metric closed forms, reference timing, and real grasps."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.runners.compare import compare_references, format_comparison
from scenarios.runners.dispatch import UnsupportedScenarioError, run_scenario
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.runners.episode_metrics import episode_metrics
from scenarios.runners.reference import ReferenceStream, intended_grip_n, reference_from_windows
from scenarios.schema import parse_scenario
from sim.hand.objects import make_object
from sim.user.operator import FRAGILE_MARGIN, MIN_GRIP_N
from sim.user.subjects import VirtualSubject

CAN = make_object("can", mass_kg=0.4, friction=0.5)
TIMING_KEYS = {"t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s", "t_controller_s",
               "t_physics_s", "realtime_factor", "fit_s"}


def test_metrics_match_closed_forms() -> None:
    dt = 0.01
    t = np.arange(0, 6, dt)
    start, tau = 1.0, 0.1
    reference = np.where(t >= start, 5.0, 0.0)
    grip = np.where(t >= 1.2, 5.0 * (1 - np.exp(-(t - 1.2) / tau)), 0.0)
    oracle = reference + 0.5
    windows = np.array([0.0, 2.0, 5.0, 5.0, 4.0])
    stream = ReferenceStream(start, windows, 0.125, t, reference, oracle)
    m = episode_metrics(stream, grip, lift_s=3.4, hold=t >= 4.0)
    # first grip >= 0.5 N: 5 (1 - exp(-x / tau)) = 0.5  ->  x = tau ln(10 / 9)
    contact = 1.2 + tau * np.log(10 / 9)
    assert m["contact_time_s"] == pytest.approx(np.ceil(contact / dt) * dt, abs=1e-9)
    # within 5 % (0.25 N) once exp(-x / tau) <= 0.05  ->  x = tau ln 20
    settle = 1.2 + tau * np.log(20)
    assert m["settling_time_s"] == pytest.approx(np.ceil(settle / dt) * dt - start, abs=1e-9)
    assert m["overshoot_pct"] == 0.0
    assert m["hold_reference_n"] == 5.0
    assert m["estimation_rmse_n"] == pytest.approx(0.5)
    assert m["reference_volatility_n_per_s"] == pytest.approx((2 + 3 + 0 + 1) / (4 * 0.125))
    track = t >= m["contact_time_s"] + 0.5
    assert m["tracking_rmse_n"] == pytest.approx(np.sqrt(np.mean((5.0 - grip[track]) ** 2)))
    bumped = grip + np.where((t > 2.0) & (t < 2.1), 1.0, 0.0)
    m2 = episode_metrics(stream, bumped, lift_s=3.4, hold=t >= 4.0)
    assert m2["overshoot_pct"] == pytest.approx(100 * (max(bumped[t < 3.4]) - 5.0) / 5.0)
    assert m2["settling_time_s"] == pytest.approx(2.1 - start, abs=dt + 1e-9)
    never = episode_metrics(stream, grip * 0.5, lift_s=3.4, hold=t >= 4.0)
    assert never["settling_time_s"] is None


def test_reference_is_held_between_window_updates() -> None:
    window_t = np.array([0.395, 0.52, 0.645])
    values = np.array([1.0, 2.0, 3.0])
    control_t = np.array([0.0, 0.39, 0.395, 0.4, 0.519, 0.52, 0.9])
    held = reference_from_windows(values, window_t, control_t)
    np.testing.assert_array_equal(held, [0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 3.0])


def test_intended_grip_is_safety_times_coulomb_threshold() -> None:
    assert intended_grip_n(CAN, 1.5) == pytest.approx(1.5 * 0.4 * 9.81 / (2 * 0.5))
    light = make_object("block", mass_kg=0.05, friction=1.2)
    assert intended_grip_n(light, 1.5) == MIN_GRIP_N
    egg = make_object("egg", break_force_n=2.0)
    assert intended_grip_n(egg, 3.0) == pytest.approx(FRAGILE_MARGIN * 2.0)


@pytest.fixture(scope="module")
def oracle_episode():
    subject = VirtualSubject.sample(0, 1)
    # the scripted user: the hold reference is exactly the intended grip (a reacting user
    # would add what its corrections asked for)
    return [run_episode(subject, CAN, EpisodeSpec(estimator="oracle", controller="pid", seed=3,
                                                  user="scripted")) for _ in range(2)]


def test_oracle_pid_lifts_and_holds_the_can(oracle_episode) -> None:
    row = oracle_episode[0].row
    assert row["lifted"] and not row["dropped"] and not row["crushed"]
    assert row["estimation_rmse_n"] == 0.0
    assert row["hold_reference_n"] == pytest.approx(row["intended_grip_n"], rel=0.25)
    assert row["tracking_rmse_n"] < 0.25 * row["hold_reference_n"]
    # the margin at the force held: the scheduled PI there (interpolated between two
    # grid designs of 60 deg each) on the plant linearized at that force
    assert row["stable"] and row["phase_margin_deg"] == pytest.approx(60.0, abs=5.0)
    assert row["worst_phase_margin_deg"] >= 45.0 and row["outcome"] == "held"
    traces = oracle_episode[0].traces
    assert traces["object_height_m"][-1] > traces["object_height_m"][0] + 0.05
    assert traces["loop_A"].ndim == 2 and traces["loop_A"].shape[0] == traces["loop_B"].shape[0]


def test_same_seed_same_episode(oracle_episode) -> None:
    a, b = oracle_episode
    assert {k: v for k, v in a.row.items() if k not in TIMING_KEYS} == \
        {k: v for k, v in b.row.items() if k not in TIMING_KEYS}
    np.testing.assert_array_equal(a.traces["grip_force_n"], b.traces["grip_force_n"])


def test_bad_timing_and_missing_modes_are_named() -> None:
    subject = VirtualSubject.sample(0, 1)
    with pytest.raises(UnsupportedScenarioError, match="no time to grasp"):
        run_episode(subject, CAN, EpisodeSpec(estimator="oracle", episode_s=3.0, hold_s=2.0,
                                              user="scripted"))
    with pytest.raises(UnsupportedScenarioError, match="persistence has modes"):
        run_episode(subject, CAN, EpisodeSpec(estimator="persistence", mode="free_run"))


def test_episode_scenario_row_has_the_contract() -> None:
    scenario = parse_scenario({
        "kind": "episode", "seed": 5, "object": {"name": "block", "mass_kg": 0.2},
        "estimator": {"name": "features_rms", "mode": "free_run"},
        "controller": {"kind": "lead_lag", "slip_reflex": {"enabled": True}},
    })
    row = run_scenario(scenario)
    for key in ("tracking_rmse_n", "slip_events", "slip_distance_m", "dropped", "crushed",
                "peak_force_n", "gain_margin_db", "phase_margin_deg", "delay_margin_s", "ms",
                "reference_volatility_n_per_s", "estimation_rmse_n", "cal_r2"):
        assert key in row, key
    assert row["kind"] == "episode" and row["controller"] == "lead_lag"
    assert 0.0 < row["cal_r2"] <= 1.0
    assert set(row["traces"]) >= {"t_s", "reference_n", "grip_force_n", "intent_n", "loop_A"}


def test_episode_command_writes_margins_and_metrics(tmp_path, capsys) -> None:
    out = tmp_path / "ep.json"
    code = main(["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
                 "--mass-kg", "0.4", "--friction", "0.5", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    held = data["margins_at_held_force"]
    assert {"gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_rad_s", "ms",
            "stable"} <= set(held["margins"])
    assert {"plant", "controller", "loop"} <= set(held)
    assert data["worst_over_visited"]["phase_margin_deg"] <= held["margins"]["phase_margin_deg"]
    assert {"tracking_rmse_n", "slip_events", "slip_distance_m", "dropped", "crushed",
            "peak_force_n"} <= set(data["metrics"])
    assert "PM deg" in capsys.readouterr().out


def test_episode_command_rejects_unknown_names(capsys) -> None:
    code = main(["episode", "--controller", "pid", "--estimator", "kalmanish", "--object", "can",
                 "--json", "unused.json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "oracle" in err[0] and "ss_kf" in err[0]
    code = main(["episode", "--controller", "bangbang", "--estimator", "oracle", "--object",
                 "can", "--json", "unused.json"])
    assert code == 2 and "lead_lag" in capsys.readouterr().err


def test_compare_references_reports_each_reference() -> None:
    result = compare_references(CAN, estimators=("features_wl", "oracle"), subject_ids=(2,))
    summary = result["summary"]
    assert summary["oracle"]["estimation_rmse_n"] == 0.0
    assert summary["features_wl"]["estimation_rmse_n"] > 0.0
    assert all(s["n_ok"] + s["n_failed"] == 1 for s in summary.values())
    assert "features_wl" in format_comparison(result)


def test_episodes_of_one_subject_and_seed_share_one_calibration(monkeypatch):
    """A sweep's conditions after the calibration (controller, object) reuse its fit."""
    from scenarios.runners import calibration

    fits = []
    real = calibration.calibrate
    monkeypatch.setattr(calibration, "_CALIBRATIONS", {})
    monkeypatch.setattr(calibration, "calibrate",
                        lambda *a, **k: fits.append(a[1].estimator) or real(*a, **k))
    subject = VirtualSubject.sample(0, 1)
    rows = [run_episode(subject, make_object("can"), EpisodeSpec(
        estimator="ridge", controller=kind, seed=5, episode_s=4.0, hold_s=1.0)).row
        for kind in ("pid", "lead_lag")]
    assert fits == ["ridge"]  # fitted once, for the first episode
    assert rows[0]["cal_r2"] == rows[1]["cal_r2"] is not None
    other = run_episode(subject, make_object("can"), EpisodeSpec(
        estimator="ridge", controller="pid", seed=6, episode_s=4.0, hold_s=1.0)).row
    assert fits == ["ridge", "ridge"] and other["cal_r2"] != rows[0]["cal_r2"]  # a new seed


def test_a_trial_that_runs_out_of_time_is_an_outcome_not_an_error() -> None:
    """A self-paced trial too short to lift in ends ``not_lifted`` with its row complete."""
    result = run_episode(VirtualSubject.sample(0, 1), CAN, EpisodeSpec(estimator="oracle",
                         episode_s=1.5, practice=0))
    row = result.row
    assert row["outcome"] == "not_lifted" and row["lifted"] is False
    assert row["time_to_lift_s"] is None and row["safety_margin_pct"] is None
    assert row["attempts"] == 0 and row["simulated_s"] == pytest.approx(1.5)
