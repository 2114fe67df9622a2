import json

import control
import numpy as np
import pytest

from controllers import loop_margins
from scenarios.cli import main

CAN = ["--object", "can", "--mass-kg", "0.4", "--friction", "0.5"]


@pytest.mark.parametrize("controller", ["pid", "lead_lag", "mpc"])
def test_margins_command_writes_the_operating_point_contract(tmp_path, capsys, controller):
    out = tmp_path / "m.json"
    plots = tmp_path / "figs"
    status = main(["margins", "--controller", controller, *CAN, "--at-force", "3,5,10,20",
                   "--json", str(out), "--plots", str(plots)])
    assert status == 0
    printed = capsys.readouterr().out
    assert f"margins of {controller}" in printed and "worst" in printed
    assert "built in" in printed  # the plant family's build time
    result = json.loads(out.read_text())
    points = result["operating_points"]
    assert [p["force_n"] for p in points] == [3.0, 5.0, 10.0, 20.0]
    for p in points:
        m = p["margins"]
        assert set(m) >= {"gain_margin_db", "phase_margin_deg", "delay_margin_s",
                          "crossover_rad_s", "ms", "stable"}
        assert m["stable"] is True and isinstance(m["crossover_rad_s"], list)
        assert m["phase_margin_deg"] >= 45.0
        for key in ("plant", "controller", "loop"):
            assert set(p[key]) == {"A", "B", "C", "D", "dt"} and p[key]["dt"] == 0.01
        # the loop in the file reproduces the reported figures
        loop = p["loop"]
        rebuilt = control.ss(loop["A"], loop["B"], loop["C"], loop["D"], loop["dt"])
        again = loop_margins(rebuilt)
        assert again.phase_margin_deg == pytest.approx(m["phase_margin_deg"], abs=1e-3)
        assert again.crossover_rad_s == pytest.approx(m["crossover_rad_s"], rel=1e-5)
    worst = result["worst_case"]
    assert worst["phase_margin_deg"] == pytest.approx(
        min(p["margins"]["phase_margin_deg"] for p in points))
    assert result["design"]["spec"]["scheduled"] is True
    png = plots / f"{controller}_can_margins_over_force.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_without_at_force_the_whole_grid_is_analysed(tmp_path):
    out = tmp_path / "pid.json"
    assert main(["margins", "--controller", "pid", *CAN, "--phase-margin-deg", "55",
                 "--crossover-rad-s", "25", "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    grid = [p["force_n"] for p in result["design"]["plant_family"]]
    assert [p["force_n"] for p in result["operating_points"]] == grid
    m = result["operating_points"][grid.index(10.0)]["margins"]
    assert m["phase_margin_deg"] == pytest.approx(55.0, abs=1.0)
    assert m["crossover_rad_s"] == pytest.approx([25.0], rel=0.02)
    assert m["delay_margin_s"] == pytest.approx(np.deg2rad(m["phase_margin_deg"]) / 25.0,
                                                rel=0.02)


def test_a_fixed_design_tells_the_truth_away_from_its_force(tmp_path):
    out = tmp_path / "fixed.json"
    assert main(["margins", "--controller", "pid", *CAN, "--fixed-at-n", "10",
                 "--at-force", "4,10", "--json", str(out)]) == 0
    soft, stiff = json.loads(out.read_text())["operating_points"]
    assert stiff["margins"]["crossover_rad_s"] == pytest.approx([30.0], rel=0.02)
    assert soft["margins"]["crossover_rad_s"][0] < 20.0  # the soft pads: far from the design


def test_the_default_egg_is_designable_by_every_controller(tmp_path):
    for controller in ("pid", "lead_lag", "mpc"):
        out = tmp_path / f"{controller}.json"
        assert main(["margins", "--controller", controller, "--object", "egg",
                     "--at-force", "2.87", "--json", str(out)]) == 0
        point = json.loads(out.read_text())["operating_points"][0]
        assert point["margins"]["stable"] is True


def test_force_outside_the_range_is_one_line_naming_the_range(tmp_path, capsys):
    status = main(["margins", "--controller", "pid", *CAN, "--at-force", "3,80"])
    assert status == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "1..36 N" in err and "80" in err


def test_unknown_controller_lists_valid_ones(tmp_path, capsys):
    status = main(["margins", "--controller", "bangbang", *CAN])
    assert status == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "['pid', 'lead_lag', 'mpc']" in err and "'bangbang'" in err


def test_unreachable_spec_is_one_line_naming_the_limit(tmp_path, capsys):
    status = main(["margins", "--controller", "pid", *CAN, "--json", str(tmp_path / "x"),
                   "--phase-margin-deg", "80", "--crossover-rad-s", "150"])
    assert status == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert "a PI gives at most" in err
    assert not (tmp_path / "x").exists()


def test_mpc_rejects_loop_shaping_options(tmp_path, capsys):
    status = main(["margins", "--controller", "mpc", *CAN, "--phase-margin-deg", "50"])
    assert status == 2
    assert "mpc is specified by horizon and weights" in capsys.readouterr().err


def test_measure_loop_command(tmp_path, capsys):
    out = tmp_path / "measured.json"
    status = main(["measure-loop", "--controller", "pid", "--object", "can", "--mass-kg", "0.2",
                   "--friction", "1.0", "--at-force", "5", "--frequencies", "24,30,37",
                   "--json", str(out), "--plots", str(tmp_path)])
    assert status == 0
    m = json.loads(out.read_text())["measurements"][0]
    assert not m["failed"]
    assert m["measured"]["phase_margin_deg"] == pytest.approx(
        m["predicted"]["phase_margin_deg"], abs=6.0)
    assert len(m["points"]) == 3
    assert (tmp_path / "pid_can_5N_measured.png").exists()
