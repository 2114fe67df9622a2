"""The feedback benchmarks: kinds, commands and JSON contracts, bad input, the report section.

The acceptance figures over ten virtual subjects are the ``slow`` tests at the end, one
per benchmark; where the model does not reproduce a published direction the claim is a
strict ``xfail`` naming the results section (docs/results/) that says what the model lacks.
"""

from __future__ import annotations

import json
import textwrap

import pytest

from scenarios.cli import main
from scenarios.feedback_summary import aggregate
from scenarios.report import factors as FA
from scenarios.runners.dispatch import run_scenario
from scenarios.schema import ScenarioError, load_sweep, parse_scenario
from scenarios.stats import wilson_interval

FAST = {"estimator": {"name": "latent_kf"}, "controller": {"kind": "pid"}, "seed": 4}


def _scenario(kind: str, protocol: dict, obj: dict, **user) -> object:
    return parse_scenario({**FAST, "kind": kind, "protocol": protocol, "object": obj,
                           "user": {"kind": "reacting", **user}}, source="test")


# ------------------------------------------------------------------ contracts
def test_eggs_contract_from_rows() -> None:
    rows = [{"feedback": m, "break_force_n": f, "transfers": 3, "success": s, "broken": 3 - s,
             "dropped": 0} for m in ("none", "force_vibration") for f, s in ((0.4, 0), (4.2, 3))]
    out = aggregate("eggs", rows)
    assert set(out["by_feedback"]) == {"none", "force_vibration"}
    mode = out["by_feedback"]["none"]
    assert mode["success_rate"] == 0.5 and mode["transfers"] == 6
    assert mode["ci95"] == pytest.approx(list(wilson_interval(3, 6)))
    assert [set(e) for e in mode["eggs"]] == [{"break_force_n", "transfers", "success", "broken",
                                              "dropped", "ci95"}] * 2
    assert [e["break_force_n"] for e in mode["eggs"]] == [0.4, 4.2]


def test_slip_recovery_and_force_matching_contracts_from_rows() -> None:
    slip = aggregate("slip_recovery", [
        {"feedback": "none", "n": 3, "recovered": 1, "not_lifted": 0, "no_slip": 0},
        {"feedback": "none", "n": 2, "recovered": 2, "not_lifted": 1, "no_slip": 0}])
    assert slip["by_feedback"]["none"] == {"n": 5, "recovered": 3, "recovered_rate": 0.6,
                                           "ci95": pytest.approx(list(wilson_interval(3, 5))),
                                           "no_slip": 0, "reaction_s": None,
                                           "reaction_ci95": [None, None]}
    assert slip["excluded"]["none"] == {"not_lifted": 1, "no_slip": 0}
    force = aggregate("force_matching", [
        {"feedback": "none", "target_fraction": 0.4, "abs_error_n": e, "cv": 0.05,
         "user_cv": 0.04} for e in (1.0, 2.0, 3.0)])
    target = force["by_feedback"]["none"]["targets"][0]
    assert target["target_fraction"] == 0.4 and target["abs_error_n"] == 2.0
    assert target["cv"] == pytest.approx(0.05) and target["n"] == 3
    lo, hi = target["abs_error_ci95"]
    assert lo < 2.0 < hi and hi - 2.0 == pytest.approx(2.0 - lo)


# ------------------------------------------------------------------ runners
def test_each_kind_runs_and_returns_its_row() -> None:
    eggs = run_scenario(_scenario("eggs", {"name": "virtual_eggs", "episode_s": 4.0,
                                           "hold_s": 1.0, "trials": 2},
                                  {"name": "vet_block", "break_force_n": 4.2}))
    assert eggs["kind"] == "eggs" and eggs["transfers"] == 2
    assert eggs["success"] + eggs["broken"] + eggs["dropped"] == 2
    slip = run_scenario(_scenario("slip_recovery", {"name": "slip_recovery", "episode_s": 10.0,
                                                    "hold_s": 7.4, "trials": 1,
                                                    "load_rate_n_s": 3.0},
                                  {"name": "can"}, feedback="slip_vibration"))
    assert slip["n"] + slip["not_lifted"] + slip["no_slip"] == 1
    assert slip["feedback"] == "slip_vibration"
    force = run_scenario(_scenario("force_matching", {"name": "force_matching", "episode_s": 5.0,
                                                      "hold_s": 2.0, "target_fraction": 0.4,
                                                      "trials": 1},
                                   {"name": "block"}, feedback="force_vibration"))
    assert force["target_n"] == pytest.approx(12.0)
    assert force["abs_error_n"] == pytest.approx(abs(force["mean_force_n"] - 12.0))
    assert 0 < force["cv"] < 1 and 0 < force["user_cv"] < 1


# ------------------------------------------------------------------ commands
def test_eggs_command_writes_the_contract_and_a_report(tmp_path, capsys) -> None:
    out, db = tmp_path / "eggs.json", tmp_path / "eggs.sqlite"
    assert main(["eggs", "--controller", "pid", "--estimator", "latent_kf", "--subjects", "1",
                 "--transfers", "1", "--eggs", "0.4,4.2", "--json", str(out),
                 "--db", str(db), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    assert set(result["by_feedback"]) == {"none", "force_vibration"}
    for mode in result["by_feedback"].values():
        assert {"success_rate", "eggs"} <= set(mode)
        assert [e["break_force_n"] for e in mode["eggs"]] == [0.4, 4.2]
        assert all(e["transfers"] == e["success"] + e["broken"] + e["dropped"] == 1
                   for e in mode["eggs"])
    printed = capsys.readouterr().out
    assert "success rate" in printed and "force_vibration" in printed
    assert main(["report", str(db), "--out", str(tmp_path / "report")]) == 0
    html = (tmp_path / "report" / "index.html").read_text()
    assert "Feedback benchmarks" in html and "Virtual Eggs Test" in html


def test_slip_recovery_and_force_matching_commands_write_their_contracts(tmp_path) -> None:
    slip = tmp_path / "slip.json"
    assert main(["slip-recovery", "--controller", "pid", "--estimator", "latent_kf",
                 "--subjects", "1", "--trials", "1", "--load-rate", "3", "--json", str(slip),
                 "--no-progress"]) == 0
    modes = json.loads(slip.read_text())["by_feedback"]
    assert set(modes) == {"none", "slip_vibration"}
    assert all({"n", "recovered", "recovered_rate", "ci95", "no_slip", "reaction_s",
                "reaction_ci95"} == set(m) for m in modes.values())
    force = tmp_path / "force.json"
    assert main(["force-matching", "--controller", "pid", "--estimator", "latent_kf",
                 "--subjects", "1", "--targets", "0.4", "--feedback", "none",
                 "--json", str(force), "--no-progress"]) == 0
    targets = json.loads(force.read_text())["by_feedback"]["none"]["targets"]
    assert [t["target_fraction"] for t in targets] == [0.4]
    assert {"target_fraction", "abs_error_n", "cv"} <= set(targets[0])


@pytest.mark.parametrize("argv, expected", [
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "ball",
      "--feedback", "buzz"], "--feedback: expected one of ['none', 'force_vibration', "
     "'slip_vibration', 'touch'], found 'buzz'"),
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "ball",
      "--user", "scripted", "--feedback", "slip_vibration"],
     "--feedback: the scripted user takes feedback none only (found slip_vibration); "
     "feedback needs --user reacting"),
    (["eggs", "--controller", "pid", "--estimator", "oracle", "--feedback", "none,buzz"],
     "--feedback: expected one of"),
    (["compare-references", "--user", "psychic"], "--user: expected one of ['reacting', "
     "'scripted'], found 'psychic'"),
])
def test_bad_user_options_are_one_line_naming_the_choices(argv, expected, capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]


def test_out_of_range_operator_parameters_are_refused_at_load(tmp_path) -> None:
    for line, expected in (("vision_delay_s: -0.1", "greater than or equal to 0"),
                           ("motor_noise_cv: 1.5", "less than or equal to 1")):
        path = tmp_path / "sweep.yaml"
        path.write_text(textwrap.dedent(f"""\
            name: x
            base:
              user:
                kind: reacting
                params:
                  {line}
            """))
        with pytest.raises(ScenarioError) as info:
            load_sweep(path)
        message = str(info.value)
        key = line.split(":")[0]
        assert message.startswith(f"{path}:6: base.user.params.{key}:") and expected in message
    path.write_text("name: x\nbase:\n  user:\n    kind: scripted\n    feedback: slip_vibration\n")
    with pytest.raises(ScenarioError, match=r"sweep.yaml:3: base.user: .*feedback "
                                            "slip_vibration needs a user kind that takes "
                                            "feedback \\(reacting\\)"):
        load_sweep(path)


def test_closed_loop_scenarios_default_to_the_reacting_user_with_vision_only() -> None:
    scenario = parse_scenario({"kind": "episode"}, source="test")
    assert (scenario.user.kind, scenario.user.feedback) == ("reacting", "none")
    assert scenario.user.operator_params().vision_delay_s == 0.2


# ------------------------------------------------------------------ acceptance
def _run(tmp_path, argv):
    out = tmp_path / f"{argv[0]}.json"
    assert main([*argv, "--controller", "pid", "--estimator", "latent_kf", "--subjects", "10",
                 "--workers", "2", "--json", str(out), "--no-progress"]) == 0
    return json.loads(out.read_text())["by_feedback"]


@pytest.fixture(scope="module")
def slip_results(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("slip"), ["slip-recovery", "--trials", "1"])


@pytest.mark.slow
@pytest.mark.verdict
def test_slip_recovery_counts_ten_subjects(slip_results) -> None:
    for mode in ("none", "slip_vibration"):
        assert slip_results[mode]["n"] >= 5


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the losses come with dips of the estimate that the "
                   "force-tracking hand follows and with contact chatter once the can slides, "
                   "not with how soon the slip is perceived: docs/results/person-in-the-loop.md, "
                   "'Slip recovery by feature window'")
@pytest.mark.verdict
def test_slip_vibration_recovers_at_least_95_percent_and_15_points_more(slip_results) -> None:
    vib, vision = slip_results["slip_vibration"], slip_results["none"]
    assert vib["recovered_rate"] >= 0.95
    assert vib["recovered_rate"] >= vision["recovered_rate"] + 0.15


@pytest.mark.slow
@pytest.mark.verdict
def test_eggs_success_rises_with_the_break_force_and_practised_users_still_break_some(
        tmp_path) -> None:
    eggs = "0.4,0.78,2.14,4.2,5.87,11.5"
    modes = _run(tmp_path, ["eggs", "--transfers", "1", "--eggs", eggs])
    for mode in modes.values():
        rates = [e["success"] / e["transfers"] for e in mode["eggs"]]
        assert rates[-1] > rates[3] > rates[0] and rates == sorted(rates)
        near_6, sturdiest = mode["eggs"][4], mode["eggs"][5]
        assert near_6["broken"] >= 1  # as surface-EMG users break the 6 N blocks
        assert sturdiest["broken"] <= near_6["broken"]


@pytest.fixture(scope="module")
def force_results(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("force"), ["force-matching", "--targets", "0.4"])


@pytest.mark.slow
@pytest.mark.verdict
def test_force_vibration_lowers_the_absolute_error(force_results) -> None:
    vib, vision = (force_results[m]["targets"][0] for m in ("force_vibration", "none"))
    assert vib["abs_error_n"] < vision["abs_error_n"]
    assert 0.03 <= vision["user_cv"] <= 0.08  # the user's own force: Baweja et al. 2009


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the hand's CV includes the estimator's fluctuation: "
                   "docs/results/person-in-the-loop.md, 'Benchmarks that read like clinical "
                   "tests', force matching")
@pytest.mark.verdict
def test_force_matching_cv_at_the_middle_target_is_3_to_8_percent(force_results) -> None:
    assert 0.03 <= force_results["none"]["targets"][0]["cv"] <= 0.08


def test_user_kind_and_feedback_are_report_factors() -> None:

    episodes = [{"config": {"user": {"kind": "reacting", "feedback": mode}, "seed": i},
                 "result": {"user": "reacting", "feedback": mode}}
                for i, mode in enumerate(("none", "slip_vibration"))]
    assert FA.swept_factors(episodes) == ["user.feedback"]
    assert FA.factor_name("user.feedback") == "feedback" and FA.factor_name("user.kind") == "user"
    assert FA.factor_value(episodes[1], "user.feedback") == "slip_vibration"


def test_the_tables_print_the_intact_hand_after_the_feedback_modes() -> None:
    from scenarios.cli.commands.force_matching import format_force_matching
    from scenarios.cli.commands.slip_recovery import format_slip_recovery

    slip = aggregate("slip_recovery", [{"feedback": "none", "n": 3, "recovered": 1,
                                        "not_lifted": 0, "no_slip": 1}])
    slip["intact"] = aggregate("slip_recovery", [{"feedback": "touch", "n": 3, "recovered": 3,
                                                  "not_lifted": 0, "no_slip": 0}])
    lines = format_slip_recovery(slip).splitlines()
    assert lines[1].split()[:3] == ["none", "3", "1"]
    assert lines[2].split()[:5] == ["intact", "(touch)", "3", "3", "100"]
    force = aggregate("force_matching", [
        {"feedback": "none", "target_fraction": 0.4, "abs_error_n": 2.0, "cv": 0.2,
         "user_cv": 0.05}])
    force["intact"] = aggregate("force_matching", [
        {"feedback": "touch", "target_fraction": 0.4, "abs_error_n": 0.3, "cv": 0.05,
         "user_cv": 0.05}])
    rows = [line.split() for line in format_force_matching(force).splitlines()[1:3]]
    assert rows[0][1] == "none" and rows[1][1:3] == ["intact", "(touch)"]
    assert float(rows[1][3]) == pytest.approx(0.3)
