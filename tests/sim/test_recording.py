"""Recording: construction checks, NPZ/CSV round trips, and rejection of bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim.recording import Recording, RecordingError, load_recording


def _recording(n: int = 400, channels: int = 8, seed: int = 0) -> Recording:
    rng = np.random.default_rng(seed)
    return Recording(
        emg=rng.integers(-128, 128, size=(n, channels)).astype(np.int8),
        fs_hz=200.0,
        force_n=rng.uniform(0, 40, n),
        intent=rng.uniform(0, 1, n),
        metadata={"subject": 3, "seed": seed},
    )


def _write_csv(path: Path, header: str, rows: list[str]) -> Path:
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_round_trip_keeps_everything(tmp_path: Path, suffix: str) -> None:
    rec = _recording()
    back = load_recording(rec.save(tmp_path / f"r{suffix}"))
    assert back.emg.dtype == np.int8
    np.testing.assert_array_equal(back.emg, rec.emg)
    np.testing.assert_allclose(back.force_n, rec.force_n, rtol=1e-5)
    np.testing.assert_allclose(back.intent, rec.intent, rtol=1e-5)
    assert back.fs_hz == rec.fs_hz
    assert back.channel_names == rec.channel_names
    assert back.metadata == rec.metadata


def test_foreign_csv_any_rate_and_microvolts(tmp_path: Path) -> None:
    fs = 1000.0
    t = np.arange(600) / fs
    rows = [f"{ti:.4f},{12.5 * np.sin(ti * 300):.3f},{-3.25:.3f},{ti * 2:.3f}" for ti in t]
    rec = load_recording(_write_csv(tmp_path / "real.csv", "t,emg1,emg2,force", rows))
    assert rec.fs_hz == pytest.approx(fs, rel=1e-6)
    assert rec.emg_unit == "uV" and rec.emg.dtype == np.float64
    assert rec.n_channels == 2
    np.testing.assert_allclose(rec.force_n, t * 2, atol=1e-3)


def test_foreign_csv_with_int8_counts_is_detected(tmp_path: Path) -> None:
    rows = [f"{k / 200:.3f},{(k % 7) - 3},{-(k % 5)}" for k in range(100)]
    rec = load_recording(_write_csv(tmp_path / "myo.csv", "t,emg1,emg2", rows))
    assert rec.emg_unit == "int8" and rec.emg.dtype == np.int8
    assert rec.force_n is None


@pytest.mark.parametrize(
    ("header", "rows", "needle"),
    [
        ("t,emg1,force", ["0,1,1", "0.005,nan,1"], "column 'emg1' has NaN"),
        ("t,emg1,force", ["0,1,1", "0.005,1,inf"], "column 'force' has NaN"),
        ("t,emg1,emg3", ["0,1,1", "0.005,1,1"], "without gaps"),
        ("time,emg1", ["0,1", "0.005,1"], "no time column 't'"),
        ("time,emg1", ["0,1", "0.005,1"], "set time_column='time'"),
        ("t,emg1,force_n", ["0,1,1", "0.005,1,1"], "set force_column='force_n'"),
        ("t,emg1", ["0,1", "0.005,1", "0.004,2"], "not strictly increasing"),
        ("t,emg1", ["0,1", "0.005,1", "0.010,2", "0.030,2"], "irregular"),
        ("t,emg1,force", ["0,1", "0.005,1"], "values per row"),
        ("t,force", ["0,1", "0.005,1"], "no sEMG columns"),
    ],
)
def test_bad_csv_names_file_and_column(tmp_path: Path, header: str, rows: list[str],
                                        needle: str) -> None:
    path = _write_csv(tmp_path / "bad.csv", header, rows)
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    message = str(info.value)
    assert needle in message
    assert str(path) in message
    assert "\n" not in message and " --" not in message  # the library knows no CLI flags


def test_missing_and_unknown_format(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="no such file"):
        load_recording(tmp_path / "nope.csv")
    other = tmp_path / "x.mat"
    other.write_text("")
    with pytest.raises(RecordingError, match="unknown recording format"):
        load_recording(other)


def test_npz_with_unknown_array_is_rejected(tmp_path: Path) -> None:
    path = tmp_path / "extra.npz"
    np.savez(path, emg=np.zeros((10, 2), np.int8), fs_hz=200.0, mystery=np.ones(3))
    with pytest.raises(RecordingError, match="unknown arrays"):
        load_recording(path)


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"emg": np.zeros(10)}, "must be 2-D"),
        ({"emg": np.zeros((10, 2)), "fs_hz": 0.0}, "fs_hz"),
        ({"emg": np.full((10, 2), np.nan)}, "emg1 contains NaN"),
        ({"emg": np.zeros((10, 2)), "force_n": np.zeros(9)}, "force_n must have shape"),
        ({"emg": np.zeros((10, 2)), "emg_unit": "volts"}, "emg_unit"),
        ({"emg": np.zeros((10, 2)), "channel_names": ["a"]}, "1 channel names for 2"),
    ],
)
def test_constructor_rejects_bad_arrays(kwargs: dict, needle: str) -> None:
    kwargs.setdefault("fs_hz", 200.0)
    with pytest.raises(RecordingError, match=needle):
        Recording(**kwargs)


def test_channel_index_by_number_and_name() -> None:
    rec = _recording(channels=8)
    assert rec.channel_index(6) == 5
    assert rec.channel_index("emg8") == 7
    with pytest.raises(RecordingError, match="unknown channel 9"):
        rec.channel_index(9)


def test_slice_keeps_alignment() -> None:
    rec = _recording()
    part = rec.slice(100, 200)
    assert part.n_samples == 100
    np.testing.assert_array_equal(part.emg, rec.emg[100:200])
    np.testing.assert_array_equal(part.force_n, rec.force_n[100:200])


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_the_forearm_pitch_round_trips_and_is_sliced_with_the_emg(tmp_path: Path,
                                                                    suffix: str) -> None:
    import dataclasses

    rng = np.random.default_rng(4)
    pitch = rng.uniform(-0.5, 0.5, 400)
    rec = dataclasses.replace(_recording(), pitch_rad=pitch)
    back = load_recording(rec.save(tmp_path / f"p{suffix}"))
    np.testing.assert_allclose(back.pitch_rad, pitch, rtol=1e-5)  # CSV: 6 digits
    np.testing.assert_array_equal(rec.slice(100, 150).pitch_rad, pitch[100:150])
    assert load_recording(_recording().save(tmp_path / f"none{suffix}")).pitch_rad is None
    if suffix == ".csv":
        header = (tmp_path / "p.csv").read_text().splitlines()[0]
        assert header.endswith(",pitch_rad")


@pytest.mark.parametrize(("pitch", "match"), [
    (np.full(400, 3.5), "pitch_rad: expected |values| <= 3.14159 rad, found 3.5"),
    (np.full(399, 0.1), r"pitch_rad must have shape \(400,\)"),
    (np.r_[np.full(399, 0.1), np.nan], "column pitch_rad contains NaN")])
def test_an_impossible_pitch_is_refused(pitch, match) -> None:
    import dataclasses

    with pytest.raises(RecordingError, match=match):
        dataclasses.replace(_recording(), pitch_rad=pitch)
