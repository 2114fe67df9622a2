"""``griploop evaluate`` on recordings as pandas, a MYO dump and a 1000 Hz logger write them."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.cli.recording_options import FLAGS
from sim.recording import OPTIONS, Recording


def _writers():
    """The file writers of tests/sim/test_recording_layouts.py (tests are not a package)."""
    path = Path(__file__).resolve().parents[1] / "sim" / "test_recording_layouts.py"
    spec = importlib.util.spec_from_file_location("_recording_layout_writers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_W = _writers()
write_logger, write_myo_dump, write_pandas_style = (
    _W.write_logger, _W.write_myo_dump, _W.write_pandas_style)

ESTIMATORS = "ridge,persistence"


def _evaluate(argv, tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = main(["evaluate", *argv, "--channels", "all", "--estimators", ESTIMATORS,
                 "--json", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "ridge" in captured.out  # the table is printed
    return json.loads(out.read_text())


def test_pandas_file_through_options(tmp_path, capsys) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv")
    result = _evaluate(["--recording", str(path), "--time-column", "time_s",
                        "--emg-columns", "emg_*", "--force-column", "force_n"], tmp_path, capsys)
    assert result["recording"]["fs_hz"] == pytest.approx(200.0)
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_pandas_file_through_a_column_map(tmp_path, capsys) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv", index_name="Unnamed: 0")
    layout = tmp_path / "layout.yaml"
    layout.write_text("time_column: time_s\nemg_columns: emg_0..emg_7\nforce_column: force_n\n")
    result = _evaluate(["--recording", str(path), "--columns", str(layout)], tmp_path, capsys)
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_myo_dump_through_options(tmp_path, capsys) -> None:
    path, _, _ = write_myo_dump(tmp_path / "myo.csv")
    assert main(["evaluate", "--recording", str(path), "--time-column", "timestamp",
                 "--estimators", "ridge"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith("pass --time-unit ms")
    assert main(["evaluate", "--recording", str(path), "--time-column", "timestamp",
                 "--time-unit", "ms", "--estimators", "ridge"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith("pass --resample HZ")
    result = _evaluate(["--recording", str(path), "--time-column", "timestamp", "--time-unit",
                        "ms", "--resample", "200", "--duplicates", "spread"], tmp_path, capsys)
    assert result["recording"]["fs_hz"] == 200.0
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_logger_in_microvolts_through_options(tmp_path, capsys) -> None:
    path = write_logger(tmp_path / "logger.csv", with_time=False)
    result = _evaluate(["--recording", str(path), "--fs-hz", "1000", "--emg-columns",
                        "ch01..ch08", "--force-column", "grip_N", "--emg-unit", "uV"],
                       tmp_path, capsys)
    assert result["recording"]["fs_hz"] == 1000.0
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_jittered_logger_through_resampling(tmp_path, capsys) -> None:
    path = write_logger(tmp_path / "jitter.csv", with_time=True, jitter_s=0.15e-3)
    layout = tmp_path / "layout.json"
    layout.write_text(json.dumps({"time_column": "time", "emg_columns": "ch*",
                                  "force_column": "grip_N", "resample_hz": 1000}))
    result = _evaluate(["--recording", str(path), "--columns", str(layout)], tmp_path, capsys)
    assert result["estimators"]["ridge"]["free_run"]["r2_mean"] > 0.5


def test_json_is_optional(tmp_path, capsys) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv")
    code = main(["evaluate", "--recording", str(path), "--time-column", "time_s",
                 "--emg-columns", "emg_*", "--force-column", "force_n", "--estimators", "ridge"])
    out = capsys.readouterr().out
    assert code == 0 and "ridge" in out
    assert f"{path}: ignored columns '', 'label'" in out


def test_missing_force_names_the_option(tmp_path, capsys) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv")
    code = main(["evaluate", "--recording", str(path), "--time-column", "time_s",
                 "--emg-columns", "emg_*", "--force-column", "none", "--estimators", "ridge"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert err[0].endswith("pass --force-column NAME (unused columns: '', 'force_n', 'label')")


def test_bad_column_map_is_one_line(tmp_path, capsys) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv")
    layout = tmp_path / "layout.yaml"
    layout.write_text("time: time_s\n")
    assert main(["evaluate", "--recording", str(path), "--columns", str(layout)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown key 'time'" in err[0] and str(layout) in err[0]


def test_plot_recording_takes_the_same_options(tmp_path, capsys) -> None:
    path, _, _ = write_myo_dump(tmp_path / "myo.csv")
    png = tmp_path / "myo.png"
    assert main(["plot-recording", str(path), "--out", str(png), "--time-column", "timestamp",
                 "--time-unit", "ms", "--resample", "200", "--duplicates", "spread"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ----------------------------------------------------------------- the flags that fix a file

#: (header, rows, layout options, what the one-line error says). The library names
#: its options as column-map keys (tests/sim/test_recording_layouts.py, ``LAYOUT_ERRORS``);
#: the command line says them as its flags: every hint family, fix and option at fault.
CLI_ERRORS = [
    ("time_s,emg1", ["0,1", "0.005,1"], [],
     "no time column 't' (columns: 'time_s', 'emg1'); pass --time-column time_s, or "
     "--time-column none --fs-hz HZ if the file has no time column"),
    ("c1", ["1", "1"], ["--time-column", "none", "--emg-columns", "c1"],
     "no time column and no sampling rate; pass --fs-hz HZ"),
    ("t,emg_0,emg_1", ["0,1,1", "0.005,1,1"], [], "; pass --emg-columns 'emg_*'"),
    ("t,emg1,emg3", ["0,1,1", "0.005,1,1"], [], "without gaps or repeats, found ['emg1', "
     "'emg3']; pass --emg-columns SPEC"),
    ("t,emg1", ["0,1", "0.005,1"], ["--emg-columns", "x*"],
     "sEMG columns 'x*' match no column; expected a glob matching some of 't', 'emg1' "
     "(option --emg-columns)"),
    ("t,emg1", ["0,1", "0.005,1"], ["--emg-columns", "emg1..emg3"],
     "sEMG column 'emg2' not in the header; expected columns among 't', 'emg1' "
     "(option --emg-columns)"),
    ("t,emg1,Force", ["0,1,1", "0.005,1,1"], [],
     "no column 'force' but found 'Force'; pass --force-column Force, or --force-column none "
     "to load without force"),
    ("t,emg1", ["0,1", "0.005,1"], ["--force-column", "grip"],
     "no force column 'grip'; expected one of 't', 'emg1' (option --force-column)"),
    ("t,emg1,t", ["0,1,0", "0.005,1,0"], [],
     "column 't' appears 2 times; expected one: rename it or choose another column; pass "
     "--time-column NAME"),
    ("t,emg1", ["0,300", "0.005,1"], ["--emg-unit", "int8"],
     "; pass --emg-unit uV, or --emg-unit mV, or --emg-unit a.u."),
    ("t,emg1", ["0,1", "0.005,1"], ["--fs-hz", "1000"],
     "sampling rate 1000 Hz contradicts column 't' (200 Hz from its 0.005 s step); expected "
     "them to agree within 1% (option --fs-hz)"),
    ("t,emg1", ["0,1", "0.005,1"], ["--fs-hz", "-3"],
     "sampling rate: expected a positive number of hertz up to 1e+06, found -3.0 "
     "(option --fs-hz)"),
    ("t,emg1", ["0,1", "5,1", "10,2"], [], "(0.2 Hz, expected 10..1e+06 Hz); pass --time-unit ms"),
    ("t,emg1", ["0,1", "0.005,1", "0.005,2"], [],
     "(1 duplicates, first at data row 3); expected one row per stamp, or resampling; pass "
     "--resample HZ"),
    ("t,emg1", ["0,1", "0.005,1", "0.010,2"], ["--resample", "0.001"],
     "choose another rate (option --resample)"),
    ("c1", ["1", "1"], ["--time-column", "none", "--emg-columns", "c1", "--fs-hz", "100",
                        "--resample", "100"],
     "resampling needs a time column (found none) (option --resample)"),
    ("t,emg1", ["0,1", "0.005,1", "0.010,2"], ["--duplicates", "spread"],
     "the duplicates rule 'spread' applies when resampling only (found no resampling rate) "
     "(option --duplicates); pass --resample HZ"),
]


def test_every_layout_option_has_a_flag() -> None:
    assert set(FLAGS) == set(OPTIONS)


@pytest.mark.parametrize(("header", "rows", "options", "needle"), CLI_ERRORS)
def test_errors_name_the_flag_that_fixes_the_file(tmp_path, capsys, header, rows, options,
                                                  needle) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    assert main(["evaluate", "--recording", str(path), *options, "--estimators", "ridge"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"griploop evaluate: error: {path}: ")
    assert needle in err[0]
    assert "set " not in err[0] and "_hz" not in err[0]  # no library names of the options


def test_npz_names_the_csv_only_flag(tmp_path, capsys) -> None:
    path = Recording(emg=np.zeros((20, 2), np.int8), fs_hz=200.0).save(tmp_path / "r.npz")
    png = tmp_path / "r.png"
    assert main(["plot-recording", str(path), "--out", str(png), "--time-unit", "ms"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith(
        "the time unit applies to CSV files only (an NPZ recording carries its own layout and "
        "rate) (option --time-unit)")
