import json

import control
import numpy as np
import pytest

from controllers import loop_margins
from scenarios.cli import main

CAN = ["--object", "can", "--mass-kg", "0.4", "--friction", "0.5"]


@pytest.mark.parametrize("controller", ["pid", "lead_lag", "mpc"])
def test_margins_command_writes_contract(tmp_path, capsys, controller):
    out = tmp_path / "m.json"
    plots = tmp_path / "figs"
    status = main(["margins", "--controller", controller, *CAN, "--json", str(out),
                   "--plots", str(plots)])
    assert status == 0
    printed = capsys.readouterr().out
    assert f"margins of {controller}" in printed and "phase margin" in printed
    result = json.loads(out.read_text())
    m = result["margins"]
    for key in ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_rad_s",
                "ms", "closed_loop_poles", "stable", "loop"):
        assert key in m
    assert m["stable"] is True
    assert isinstance(m["crossover_rad_s"], list) and m["crossover_rad_s"]
    # the loop in the file reproduces the reported figures (up to the round-off of
    # one more state-space <-> polynomial conversion)
    loop = m["loop"]
    rebuilt = control.ss(loop["A"], loop["B"], loop["C"], loop["D"], loop["dt"])
    again = loop_margins(rebuilt)
    assert again.phase_margin_deg == pytest.approx(m["phase_margin_deg"], abs=1e-3)
    assert again.crossover_rad_s == pytest.approx(m["crossover_rad_s"], rel=1e-5)
    assert again.ms == pytest.approx(m["ms"], rel=1e-5)
    assert result["force_bounds_n"]["min"] == pytest.approx(1.5 * 0.4 * 9.81 / (2 * 0.5))
    for suffix in ("bode", "nyquist", "pz"):
        png = plots / f"{controller}_can_{suffix}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_pid_spec_is_met_on_the_design_plant(tmp_path):
    out = tmp_path / "pid.json"
    assert main(["margins", "--controller", "pid", *CAN, "--json", str(out),
                 "--phase-margin-deg", "55", "--crossover-rad-s", "25"]) == 0
    m = json.loads(out.read_text())["margins"]
    assert m["phase_margin_deg"] == pytest.approx(55.0, abs=1.0)
    assert m["crossover_rad_s"] == pytest.approx([25.0], rel=0.02)
    assert m["delay_margin_s"] == pytest.approx(np.deg2rad(m["phase_margin_deg"]) / 25.0,
                                                rel=0.02)


def test_identified_plant_option(tmp_path):
    out = tmp_path / "ll.json"
    assert main(["margins", "--controller", "lead_lag", *CAN, "--plant", "identified",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["plant"]["method"] == "identified"
    assert result["plant"]["fit"]["fit_percent"] > 90.0


def test_unknown_controller_lists_valid_ones(tmp_path, capsys):
    status = main(["margins", "--controller", "bangbang", *CAN, "--json", str(tmp_path / "x")])
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
    assert "deg of lead; a PI gives at most 0 deg" in err
    assert not (tmp_path / "x").exists()


def test_mpc_rejects_loop_shaping_options(tmp_path, capsys):
    status = main(["margins", "--controller", "mpc", *CAN, "--json", str(tmp_path / "x"),
                   "--phase-margin-deg", "50"])
    assert status == 2
    assert "mpc is specified by horizon and weights" in capsys.readouterr().err
