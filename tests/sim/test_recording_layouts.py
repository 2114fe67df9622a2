"""Recordings as other tools write them: column maps, time units, resampling, the sidecar.

Files are written here as pandas, a MYO dump and a 1000 Hz microvolt logger would
write them, loaded through ``load_recording``, and evaluated through
``griploop evaluate`` (in tests/scenarios/test_cli_recording_layouts.py).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from sim.recording import (
    OPTIONS,
    ColumnMap,
    Fix,
    Recording,
    RecordingError,
    load_recording,
    read_column_file,
    sidecar_path,
)


def session(fs_hz: float, seconds: float = 40.0, *, seed: int = 0, int8: bool = True):
    """Squeezes every 8 s: (force N, sEMG (n, 8)) whose amplitude follows the force."""
    rng = np.random.default_rng(seed)
    n = int(seconds * fs_hz)
    t = np.arange(n) / fs_hz
    force = 25.0 * np.clip(np.sin(2 * np.pi * t / 8.0), 0, None) ** 2
    gain = 1.0 + 1.2 * force[:, None] * np.linspace(0.5, 1.5, 8)
    emg = gain * rng.standard_normal((n, 8))
    if int8:
        emg = np.clip(np.round(emg), -128, 127).astype(np.int8)
    return t, force, emg


def write_pandas_style(path: Path, *, index_name: str = "") -> Path:
    """``DataFrame.to_csv`` defaults: the index as an unnamed first column, any names."""
    t, force, emg = session(200.0)
    label = np.where(force > 1.0, "squeeze", "rest")
    names = [f"emg_{k}" for k in range(8)]
    lines = [",".join([index_name, "time_s", *names, "force_n", "label"])]
    for i in range(t.size):
        lines.append(",".join([str(i), repr(float(t[i])), *map(str, emg[i].tolist()),
                               repr(float(force[i])), label[i]]))
    path.write_text("\n".join(lines) + "\n")
    return path


def write_myo_dump(path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """A MYO SDK dump: ms time stamps, two samples per 10 ms packet share one stamp."""
    t, force, emg = session(200.0)
    stamp = 1_700_000_000_000 + 10 * (np.arange(t.size) // 2)  # epoch ms
    lines = ["timestamp,emg1,emg2,emg3,emg4,emg5,emg6,emg7,emg8,force"]
    for i in range(t.size):
        lines.append(f"{stamp[i]}," + ",".join(map(str, emg[i].tolist())) + f",{force[i]:.4f}")
    path.write_text("\n".join(lines) + "\n")
    return path, emg, force


def write_logger(path: Path, *, with_time: bool, jitter_s: float = 0.0) -> Path:
    """A 1000 Hz amplifier logger: float microvolts, its own channel and force names."""
    t, force, emg = session(1000.0, seconds=30.0, int8=False)
    emg = 40.0 * emg  # microvolts
    rng = np.random.default_rng(1)
    t = t + rng.uniform(-jitter_s, jitter_s, t.size)
    header = ([] if not with_time else ["time"]) + [f"ch{k:02d}" for k in range(1, 9)]
    lines = [",".join(header + ["grip_N", "marker"])]
    for i in range(t.size):
        cells = ([f"{t[i]:.6f}"] if with_time else []) + [f"{v:.2f}" for v in emg[i]]
        lines.append(",".join(cells + [f"{force[i]:.4f}", "0"]))
    path.write_text("\n".join(lines) + "\n")
    return path


# ----------------------------------------------------------------- files of other tools


@pytest.mark.parametrize("index_name", ["", "Unnamed: 0"])
def test_pandas_style_file_with_a_column_map(tmp_path, index_name) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv", index_name=index_name)
    with pytest.raises(RecordingError, match="set time_column='time_s'"):
        load_recording(path)
    rec = load_recording(path, columns=ColumnMap(time="time_s", emg="emg_*", force="force_n"))
    t, force, emg = session(200.0)
    assert rec.fs_hz == pytest.approx(200.0) and rec.emg_unit == "int8"
    assert rec.channel_names == [f"emg_{k}" for k in range(8)]
    np.testing.assert_array_equal(rec.emg, emg)
    np.testing.assert_allclose(rec.force_n, force)
    assert rec.metadata["csv_layout"] == {
        "time": "time_s", "time_unit": "s", "emg": rec.channel_names, "force": "force_n",
        "ignored": [index_name, "label"]}
    same = load_recording(path, columns=ColumnMap(time="time_s", emg="emg_0..emg_7",
                                                  force="force_n"))
    np.testing.assert_array_equal(same.emg, rec.emg)


def test_myo_dump_needs_ms_then_resampling(tmp_path) -> None:
    path, emg, force = write_myo_dump(tmp_path / "myo.csv")
    columns = ColumnMap(time="timestamp")
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=columns)
    assert "time column 'timestamp' in ms? found steps of 10 s" in str(info.value)
    assert "set time_unit='ms'" in str(info.value)
    assert info.value.fixes == (Fix.set("time_unit", "ms"),)
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=columns, time_unit="ms")
    assert "not strictly increasing (4000 duplicates" in str(info.value)
    assert str(info.value).endswith("; set resample_hz")
    spread = load_recording(path, columns=columns, time_unit="ms", resample_hz=200,
                            duplicates="spread")
    assert spread.fs_hz == 200.0 and spread.emg.dtype == np.int8
    # the packet's two samples were 5 ms apart: spreading recovers them exactly
    np.testing.assert_array_equal(spread.emg, emg[: spread.n_samples])
    assert spread.n_samples == emg.shape[0]
    avg = load_recording(path, columns=columns, time_unit="ms", resample_hz=100)
    pairs = emg[: 2 * (emg.shape[0] // 2)].reshape(-1, 2, 8).astype(float).mean(axis=1)
    assert avg.emg.shape == pairs.shape and avg.emg.dtype == np.int8
    assert np.max(np.abs(avg.emg - pairs)) <= 0.5 + 1e-9  # pair means rounded to counts
    assert avg.metadata["resampled"]["duplicates"] == "average"
    # the rule does nothing without resampling: refused rather than silently ignored
    with pytest.raises(RecordingError, match="rule 'spread' applies when resampling only"):
        load_recording(path, columns=columns, time_unit="ms", duplicates="spread")


def test_logger_without_time_column_in_microvolts(tmp_path) -> None:
    path = write_logger(tmp_path / "logger.csv", with_time=False)
    columns = ColumnMap(time=None, emg="ch01..ch08", force="grip_N")
    with pytest.raises(RecordingError, match="no time column and no sampling rate; set fs_hz"):
        load_recording(path, columns=columns)
    rec = load_recording(path, columns=columns, fs_hz=1000.0)
    assert rec.fs_hz == 1000.0 and rec.emg_unit == "uV" and rec.n_channels == 8
    assert rec.channel_names[0] == "ch01" and rec.duration_s == pytest.approx(30.0)
    # the default 't' is absent, so fs_hz alone is enough
    alone = load_recording(path, columns=ColumnMap(emg="ch*", force="grip_N"), fs_hz=1000.0)
    np.testing.assert_array_equal(alone.emg, rec.emg)


def test_jittered_logger_is_resampled(tmp_path) -> None:
    path = write_logger(tmp_path / "jitter.csv", with_time=True, jitter_s=0.3e-3 / 2)
    columns = ColumnMap(time="time", emg="ch*", force="grip_N")
    with pytest.raises(RecordingError, match=r"irregular at data row \d+ .*; set resample_hz"):
        load_recording(path, columns=columns)
    rec = load_recording(path, columns=columns, resample_hz=1000.0)
    assert rec.fs_hz == 1000.0 and rec.emg_unit == "uV"
    assert abs(rec.n_samples - 30_000) <= 2
    _, force, _ = session(1000.0, seconds=30.0, int8=False)
    assert np.max(np.abs(rec.force_n - force[: rec.n_samples])) < 0.2


# ----------------------------------------------------------------- griploop's own CSV


def _saved(tmp_path) -> tuple[Recording, Path]:
    t, force, emg = session(200.0, seconds=5.0)
    rec = Recording(emg=emg, fs_hz=200.0, force_n=force, intent=force / 25.0,
                    metadata={"subject": 1})
    return rec, rec.save_csv(tmp_path / "own.csv")


def test_own_csv_reads_with_numpy_loadtxt(tmp_path) -> None:
    rec, path = _saved(tmp_path)
    with open(path) as fh:
        data = np.loadtxt(fh, delimiter=",", skiprows=1)
    assert data.shape == (rec.n_samples, 1 + 8 + 2)
    np.testing.assert_allclose(data[:, 0], rec.t_s, atol=1e-6)
    np.testing.assert_array_equal(data[:, 1:9], rec.emg)
    np.testing.assert_allclose(data[:, 9], rec.force_n, rtol=1e-5)
    named = np.genfromtxt(path, delimiter=",", names=True)
    assert named.dtype.names[:2] == ("t", "emg1") and named["force"].shape == (rec.n_samples,)


def test_own_csv_reads_with_csv_module_defaults(tmp_path) -> None:
    rec, path = _saved(tmp_path)
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", *[f"emg{k}" for k in range(1, 9)], "force", "intent"]
    assert len(rows) == rec.n_samples + 1 and all(len(r) == len(rows[0]) for r in rows)
    with open(path, newline="") as fh:
        first = next(csv.DictReader(fh))
    assert float(first["t"]) == 0.0 and int(first["emg3"]) == rec.emg[0, 2]


def test_own_csv_reads_with_pandas(tmp_path) -> None:
    pd = pytest.importorskip("pandas")
    rec, path = _saved(tmp_path)
    frame = pd.read_csv(path)
    assert frame.shape == (rec.n_samples, 11) and list(frame.columns[:2]) == ["t", "emg1"]


def test_sidecar_holds_the_metadata(tmp_path) -> None:
    rec, path = _saved(tmp_path)
    assert path.read_text().splitlines()[0] == "t," + ",".join(
        f"emg{k}" for k in range(1, 9)) + ",force,intent"
    side = json.loads(sidecar_path(path).read_text())
    assert side["fs_hz"] == 200.0 and side["emg_unit"] == "int8"
    assert side["metadata"] == {"subject": 1} and side["units"]["force"] == "N"
    assert sidecar_path(path).name == "own.csv.json"
    back = load_recording(path)
    assert back.metadata == {"subject": 1} and back.fs_hz == 200.0
    sidecar_path(path).unlink()  # without it: the rate from 't', unit detected
    bare = load_recording(path)
    assert bare.fs_hz == pytest.approx(200.0) and bare.metadata == {}


def test_old_commented_form_is_still_read(tmp_path) -> None:
    path = tmp_path / "old.csv"
    meta = {"fs_hz": 200.0, "emg_unit": "int8", "channel_names": ["a", "b"],
            "metadata": {"seed": 4}}
    path.write_text("# griploop " + json.dumps(meta) + "\nt,emg1,emg2,force\n"
                    + "".join(f"{k / 200:.6f},{k % 5},{-k % 3},{k / 10}\n" for k in range(50)))
    rec = load_recording(path)
    assert rec.channel_names == ["a", "b"] and rec.metadata == {"seed": 4}
    assert rec.fs_hz == 200.0


def test_extra_columns_are_ignored(tmp_path) -> None:
    path = tmp_path / "extra.csv"
    path.write_text("t,emg1,label,force,temperature\n"
                    + "".join(f"{k / 200:.3f},{k % 5},\"a, b\",{k / 10},36.6\n" for k in range(20)))
    rec = load_recording(path)
    assert rec.n_channels == 1 and rec.force_n[3] == pytest.approx(0.3)


# ----------------------------------------------------------------- column-map files


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_column_map_file(tmp_path, suffix) -> None:
    path = write_pandas_style(tmp_path / "pandas.csv")
    layout = {"time_column": "time_s", "emg_columns": [f"emg_{k}" for k in range(8)],
              "force_column": "force_n", "time_unit": "s"}
    mapping = tmp_path / f"layout{suffix}"
    if suffix == ".json":
        mapping.write_text(json.dumps(layout))
    else:
        import yaml

        mapping.write_text(yaml.safe_dump(layout))
    kwargs = read_column_file(mapping)
    assert kwargs["columns"] == ColumnMap(time="time_s", emg=tuple(layout["emg_columns"]),
                                          force="force_n")
    rec = load_recording(path, **kwargs)
    assert rec.n_channels == 8 and rec.force_n is not None


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("time_colum: t\n", "unknown key 'time_colum'"),
        ("- t\n", "expected a mapping"),
        ("time_unit: hours\n", "time_unit: expected one of s, ms, us"),
        ("fs_hz: -3\n", "fs_hz: expected a positive number"),
        ("emg_columns: 3\n", "emg_columns: expected names"),
        ("a: [\n", "not valid YAML"),
    ],
)
def test_bad_column_map_files(tmp_path, text, needle) -> None:
    mapping = tmp_path / "layout.yaml"
    mapping.write_text(text)
    with pytest.raises(RecordingError) as info:
        read_column_file(mapping)
    assert needle in str(info.value) and str(mapping) in str(info.value)


# ----------------------------------------------------------------- errors name the fix

#: Bad layouts: (header, rows, load_recording kwargs, what the message says, the layout
#: option the error names (at fault or to set)). The command line says the option as its
#: flag (tests/scenarios/test_cli_recording_layouts.py, ``CLI_ERRORS``).
LAYOUT_ERRORS = [
    ("t,emg_0,emg_1", ["0,1,1", "0.005,1,1"], {}, "set emg_columns='emg_*'", "emg_columns"),
    ("t,emg1,emg3", ["0,1,1", "0.005,1,1"], {}, "without gaps or repeats", "emg_columns"),
    ("t,emg1,Force", ["0,1,1", "0.005,1,1"], {},
     "set force_column='Force', or force_column=None to load without force", "force_column"),
    ("time_s,emg1", ["0,1", "0.005,1"], {},
     "set time_column='time_s', or time_column=None and fs_hz if the file has no time column",
     "time_column"),
    ("c1", ["1", "1"], {"columns": ColumnMap(time=None, emg="c1")},
     "no time column and no sampling rate; set fs_hz", "fs_hz"),
    ("t,emg1", ["0,1", "0.005,1"], {"columns": ColumnMap(emg="x*")}, "match no column",
     "emg_columns"),
    ("t,emg1", ["0,1", "0.005,1"], {"columns": ColumnMap(emg="emg1..emg3")},
     "sEMG column 'emg2' not in the header", "emg_columns"),
    ("t,emg1", ["0,1", "0.005,1"], {"columns": ColumnMap(force="grip")},
     "no force column 'grip'", "force_column"),
    ("t,emg1,t", ["0,1,0", "0.005,1,0"], {}, "column 't' appears 2 times", "time_column"),
    ("t,emg1", ["0,300", "0.005,1"], {"emg_unit": "int8"},
     "set emg_unit='uV', or emg_unit='mV', or emg_unit='a.u.'", "emg_unit"),
    ("t,emg1", ["0,1", "0.005,1"], {"fs_hz": 1000.0}, "sampling rate 1000 Hz contradicts",
     "fs_hz"),
    ("t,emg1", ["0,1", "5,1", "10,2"], {"time_unit": "ms", "resample_hz": 1e6,
                                        "max_bytes": 999},
     "choose another rate", "resample_hz"),
    ("t,emg1", ["0,1", "5,1", "10,2"], {}, "set time_unit='ms'", "time_unit"),
    ("t,emg1", ["0,1", "0.005,1", "0.005,2"], {}, "1 duplicates", "resample_hz"),
    ("t,emg1", ["0,1", "0.005,1", "0.010,2"], {"duplicates": "spread"},
     "duplicates rule 'spread' applies when resampling only", "duplicates"),
    ("c1", ["1", "1"], {"columns": ColumnMap(time=None, emg="c1"), "resample_hz": 100.0,
                        "fs_hz": 100.0}, "resampling needs a time column", "resample_hz"),
]


def _named_options(exc: RecordingError) -> set[str]:
    named = {exc.option} - {None}
    return named | {option for fix in exc.fixes for option, _ in fix.settings}


@pytest.mark.parametrize(("header", "rows", "kwargs", "needle", "option"), LAYOUT_ERRORS)
def test_errors_name_what_was_expected_and_the_option(tmp_path, header, rows, kwargs, needle,
                                                     option) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(RecordingError) as info:
        load_recording(path, **kwargs)
    message = str(info.value)
    assert needle in message and str(path) in message and "\n" not in message
    assert " --" not in message  # the library knows no CLI flags; the CLI adds them
    assert option in _named_options(info.value) and _named_options(info.value) <= set(OPTIONS)
    assert message.startswith(info.value.detail)


@pytest.mark.parametrize(
    ("header", "rows", "kwargs", "needle"),
    [
        ("t,emg1", ["0,1", "0.005,1", "0.010,1", "0.5,1"], {"resample_hz": 200},
         "split the file there"),
        ("t,emg1", ["0,1", "0.005,1", "0.004,1"], {"resample_hz": 200}, "goes back"),
        ("t;emg1", ["0;1", "0.005;1"], {}, "looks ';'-separated"),
    ],
)
def test_errors_without_an_option_to_set(tmp_path, header, rows, kwargs, needle) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(RecordingError) as info:
        load_recording(path, **kwargs)
    assert needle in str(info.value) and not _named_options(info.value)


def test_npz_refuses_csv_only_options(tmp_path) -> None:
    rec, _ = _saved(tmp_path)
    path = rec.save_npz(tmp_path / "r.npz")
    with pytest.raises(RecordingError, match="the time unit applies to CSV files only") as info:
        load_recording(path, time_unit="ms")
    assert info.value.option == "time_unit"
    # the sEMG unit and the duplicates rule are the CSV's too: never silently ignored
    with pytest.raises(RecordingError, match="the sEMG unit applies to CSV files only"):
        load_recording(path, emg_unit="uV")
    with pytest.raises(RecordingError, match="the duplicates rule applies to CSV files only"):
        load_recording(path, duplicates="spread")
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=ColumnMap(force="grip"))
    assert info.value.option == "force_column"
    assert load_recording(path).n_samples == rec.n_samples


def test_fix_and_error_refuse_unknown_options() -> None:
    with pytest.raises(ValueError, match="expected options among"):
        Fix.set("time-unit", "ms")
    with pytest.raises(ValueError, match="expected an option among"):
        RecordingError("x", option="--fs-hz")


def test_emg_column_named_twice_in_the_header_is_refused(tmp_path) -> None:
    # "a" twice: taking the first one silently would drop a channel the user asked for
    path = tmp_path / "dup.csv"
    rows = [f"{k * 0.005:.3f},{k % 7},{k % 5},{k % 3},1.0" for k in range(20)]
    path.write_text("t,a,b,a,force\n" + "\n".join(rows) + "\n")
    with pytest.raises(RecordingError) as info:
        load_recording(path, columns=ColumnMap(emg="a,b"))
    assert str(path) in str(info.value) and "'a'" in str(info.value)
    assert "appears 2 times" in str(info.value)
    assert load_recording(path, columns=ColumnMap(emg="b")).n_channels == 1


def test_rate_of_a_time_column_rounded_to_microseconds(tmp_path) -> None:
    # 2048 Hz (HD-sEMG amplifiers) written as %.6f: steps of 488 or 489 us; the rate
    # must come from the whole span, not the median step (2049.18 Hz, 0.06 % fast)
    n, fs = 4096, 2048.0
    path = tmp_path / "hd.csv"
    np.savetxt(path, np.column_stack([np.arange(n) / fs, np.arange(2 * n).reshape(n, 2) % 7]),
               fmt=["%.6f", "%d", "%d"], delimiter=",", header="t,emg1,emg2", comments="")
    rec = load_recording(path)
    assert abs(rec.fs_hz / fs - 1) < 1e-6, rec.fs_hz
