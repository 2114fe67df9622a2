"""The hand's settings downstream (issue 35): the CLI flags, the JSON contracts, the report's
factors and bad input. The mechanisms are tested in tests/sim/test_drive.py and
tests/controllers/test_paradigms.py; the C runtime's shaping in tests/deploy."""

from __future__ import annotations

import json

import pytest

from controllers.design_cache import grasp_design
from scenarios.cli.main import main
from scenarios.report import factors as FA
from scenarios.runners.trial_loop import HandSettings
from sim.hand.objects import make_object


def test_episode_metrics_name_the_paradigm_drive_and_auto_grip(tmp_path, capsys) -> None:
    out = tmp_path / "ep.json"
    assert main(["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
                 "--paradigm", "force_hold", "--drive", "self_locking", "--auto-grip",
                 "--episode-s", "6", "--json", str(out)]) == 0
    m = json.loads(out.read_text())["metrics"]
    assert (m["paradigm"], m["drive"], m["auto_grip"]) == ("force_hold", "self_locking", True)
    assert "paradigm force_hold, self_locking drive, auto-grip on" in capsys.readouterr().out


def test_a_benchmark_compares_its_paradigms_on_the_same_seeds(tmp_path) -> None:
    out = tmp_path / "force.json"
    db = tmp_path / "force.db"
    assert main(["force-matching", "--controller", "pid", "--estimator", "latent_kf",
                 "--subjects", "2", "--targets", "0.4", "--feedback", "none", "--paradigm",
                 "force,force_hold", "--drive", "self_locking", "--db", str(db),
                 "--json", str(out), "--no-progress"]) == 0
    data = json.loads(out.read_text())
    assert set(data["by_paradigm"]) == {"force", "force_hold"}
    # the top level is the first paradigm's, so a reader of one paradigm's contract
    # finds it where it was
    assert data["by_feedback"] == data["by_paradigm"]["force"]["by_feedback"]
    for entry in data["by_paradigm"].values():
        (target,) = entry["by_feedback"]["none"]["targets"]
        assert {"abs_error_n", "cv", "time_to_target_s", "time_to_target_ci95"} <= set(target)
        assert target["n"] == 2
    from scenarios.store import ResultStore

    with ResultStore(db) as store:
        rows = [r for r in store.rows() if r.get("status", "ok") == "ok"]
    seeds = {p: sorted((r["result"]["subject_id"], r["config"]["seed"]) for r in rows
                       if r["result"]["paradigm"] == p) for p in ("force", "force_hold")}
    assert seeds["force"] == seeds["force_hold"] and len(seeds["force"]) == 2
    assert {r["result"]["drive"] for r in rows} == {"self_locking"}


def test_compare_references_gains_by_paradigm(tmp_path) -> None:
    out = tmp_path / "cmp.json"
    assert main(["compare-references", "--estimators", "oracle", "--subjects", "1",
                 "--paradigm", "force,force_hold", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert set(data["by_paradigm"]) == {"force", "force_hold"}
    assert data["by_paradigm"]["force_hold"]["paradigm"] == "force_hold"
    assert data["paradigm"] == "force" and data["drive"] == "backdrivable"


@pytest.mark.parametrize("argv, expected", [
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
      "--paradigm", "hold"],
     "--paradigm: expected one of ['force', 'force_hold', 'velocity'], found 'hold'"),
    (["eggs", "--controller", "pid", "--estimator", "oracle", "--paradigm", "force,hold"],
     "--paradigm: expected one of ['force', 'force_hold', 'velocity'], found 'hold'"),
    (["slip-recovery", "--controller", "pid", "--estimator", "oracle", "--drive", "worm"],
     "--drive: expected one of ['backdrivable', 'self_locking'], found 'worm'"),
    (["compare-references", "--paradigm", "grab"], "--paradigm: expected one of"),
    (["transfers", "--controller", "pid", "--estimator", "oracle", "--drive", "worm"],
     "--drive: expected one of"),
    (["force-matching", "--controller", "pid", "--estimator", "oracle", "--paradigm", "x"],
     "--paradigm: expected one of"),
])
def test_unknown_paradigms_and_drives_are_one_line(argv, expected, capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]


def test_live_refuses_an_unknown_drive_before_reading_anything(tmp_path, capsys) -> None:
    cal = tmp_path / "cal.npz"  # never read: the flags are checked first
    assert main(["live", "--lsl", "nobody", "--calibration", str(cal), "--controller", "pid",
                 "--object", "can", "--drive", "worm", "--no-video"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--drive: expected one of" in err[0]


def test_paradigm_drive_and_auto_grip_are_report_factors() -> None:
    episodes = [{"config": {"paradigm": p, "hand": {"drive": d}, "auto_grip": g, "seed": 1},
                 "result": {"paradigm": p, "drive": d, "auto_grip": g}}
                for p, d, g in (("force", "backdrivable", False),
                                ("force_hold", "self_locking", True))]
    assert set(FA.swept_factors(episodes)) == {"paradigm", "hand.drive", "auto_grip"}
    assert FA.factor_name("hand.drive") == "drive"
    assert FA.factor_value(episodes[1], "hand.drive") == "self_locking"


def test_auto_grip_wraps_any_controller_once() -> None:
    hand = HandSettings(auto_grip=True)
    spec = hand.controller_spec(None)
    assert spec == {"slip_reflex": {"latency_s": 0.05, "gain": 0.3}}
    # a specification with its own reflex keeps it: one reflex, not two
    own = {"slip_reflex": {"latency_s": 0.1, "gain": 0.5}}
    assert hand.controller_spec(own) == own
    assert HandSettings().controller_spec(None) is None
    # around the MPC, whose force bound also rises with the slips it senses
    design = grasp_design(make_object("can"), "mpc", 0.01, spec)
    reflex = design.controller
    assert type(reflex).__name__ == "SlipReflex"
    assert all(mpc.slip_sensing is not None for mpc in design.core.designs)
