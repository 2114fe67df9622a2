"""Hostile and unlucky recording files: only RecordingError escapes, loads are bounded.

Property-based tests (hypothesis) feed the CSV and NPZ loaders random and
mutated files; whatever loads must satisfy the :class:`Recording` invariants.
A decompression bomb is loaded in a subprocess whose peak memory is measured.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import tempfile
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from sim.recording import (
    DUPLICATES,
    EMG_UNITS,
    MAX_FORCE_N,
    MAX_FS_HZ,
    TIME_UNITS,
    ColumnMap,
    Recording,
    RecordingError,
    load_recording,
    read_column_file,
    sidecar_path,
)

FUZZ = settings(
    max_examples=300,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def _check_invariants(rec: Recording) -> None:
    assert rec.emg.ndim == 2 and rec.n_samples >= 2 and rec.n_channels >= 1
    assert rec.emg.dtype.kind in "iuf"
    assert np.isfinite(rec.fs_hz) and 0 < rec.fs_hz <= MAX_FS_HZ
    assert rec.emg_unit in EMG_UNITS
    if rec.emg_unit == "int8":
        assert rec.emg.min() >= -128 and rec.emg.max() <= 127
    else:
        assert np.all(np.isfinite(rec.emg))
    assert len(rec.channel_names) == rec.n_channels
    assert all(isinstance(c, str) for c in rec.channel_names)
    for name in ("force_n", "intent_force_n"):
        value = getattr(rec, name)
        if value is not None:
            assert value.shape == (rec.n_samples,)
            assert np.all(np.isfinite(value)) and np.max(np.abs(value)) <= MAX_FORCE_N
    assert isinstance(rec.metadata, dict)


def _load(path: Path, **kwargs) -> None:
    try:
        rec = load_recording(path, **kwargs)
    except RecordingError as exc:
        message = str(exc)
        assert str(path) in message, message
        assert "\n" not in message, message
        return
    _check_invariants(rec)


# ---------------------------------------------------------------- CSV

_CELLS = st.one_of(
    st.integers(-300, 300).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["", "nan", "inf", "-inf", "1e300", "1.3e17", "x", "0x10", " 1 ", "1,2"]),
    st.text(max_size=4),
)
_COLUMNS = st.sampled_from(
    ["t", "emg1", "emg2", "emg3", "emg10", "force", "intent", "intent_force_n", "time", "", "t"]
)
_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                 max_size=3),
    max_leaves=8,
)
_META = st.one_of(
    _JSON,
    st.fixed_dictionaries(
        {},
        optional={
            "fs_hz": st.one_of(st.sampled_from([200.0, 5000.0, 0, -1, True, "200"]), _JSON),
            "emg_unit": st.one_of(st.sampled_from(EMG_UNITS), _JSON),
            "channel_names": st.one_of(st.lists(st.text(max_size=3), max_size=4), _JSON),
            "metadata": _JSON,
        },
    ),
)


@st.composite
def csv_bytes(draw) -> bytes:
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=300))
    lines = []
    if draw(st.booleans()):
        lines.append("# griploop " + json.dumps(draw(_META), allow_nan=True))
    header = ["t"] + draw(st.lists(_COLUMNS, min_size=0, max_size=4))
    if draw(st.booleans()):
        header = ["t"] + [f"emg{i + 1}" for i in range(draw(st.integers(1, 3)))]
        header += draw(st.lists(st.sampled_from(["force", "intent"]), max_size=1, unique=True))
    lines.append(",".join(header))
    n_rows = draw(st.integers(0, 6))
    regular = draw(st.booleans())
    for i in range(n_rows):
        if regular:
            cells = [f"{i * 0.005:.6f}"] + [draw(_CELLS) for _ in header[1:]]
        else:
            cells = [draw(_CELLS) for _ in header]
        lines.append(",".join(cells))
    text = "\n".join(lines) + draw(st.sampled_from(["", "\n", "\r\n"]))
    data = text.encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        data = b"\xef\xbb\xbf" + data
    return data


@FUZZ
@given(data=csv_bytes())
def test_csv_fuzz_only_recording_error_escapes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fuzz.csv"
        path.write_bytes(data)
        _load(path)


_NAMES = st.sampled_from(["t", "time", "emg1", "emg2", "force", "intent", "", "x"])
_OPTIONS = st.fixed_dictionaries(
    {},
    optional={
        "columns": st.builds(
            ColumnMap,
            time=st.one_of(st.none(), _NAMES),
            emg=st.one_of(st.none(), _NAMES, st.sampled_from(
                ["emg*", "*", "emg1..emg3", "emg1..3", "emg3..emg1", "emg1,emg2", "e[", "t,t",
                 "x0..x99999999999"]), st.lists(_NAMES, max_size=3)),
            force=st.one_of(st.none(), _NAMES),
        ),
        "time_unit": st.sampled_from(TIME_UNITS),
        "fs_hz": st.sampled_from([200.0, 1e6, 1e-3, 5.0]),
        "resample_hz": st.sampled_from([200.0, 1e6, 0.5, 1e-300]),
        "duplicates": st.sampled_from(DUPLICATES),
        "emg_unit": st.sampled_from(EMG_UNITS),
        "max_bytes": st.sampled_from([10**3, 10**5]),
    },
)


@FUZZ
@given(data=csv_bytes(), options=_OPTIONS, sidecar=st.one_of(st.none(), _META))
def test_csv_fuzz_with_layout_options(data: bytes, options: dict, sidecar) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fuzz.csv"
        path.write_bytes(data)
        if sidecar is not None:
            sidecar_path(path).write_text(json.dumps(sidecar, allow_nan=True))
        _load(path, **options)


@FUZZ
@given(text=st.one_of(st.text(max_size=80), st.dictionaries(
    st.sampled_from(["time_column", "emg_columns", "force_column", "time_unit", "fs_hz",
                     "emg_unit", "resample_hz", "duplicates", "other"]),
    _JSON, max_size=4).map(json.dumps)), suffix=st.sampled_from([".yaml", ".json"]))
def test_column_map_fuzz_only_recording_error_escapes(text: str, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"layout{suffix}"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        try:
            kwargs = read_column_file(path)
        except RecordingError as exc:
            assert str(path) in str(exc) and "\n" not in str(exc)
            return
        assert isinstance(kwargs["columns"], ColumnMap)


# ---------------------------------------------------------------- NPZ

_DTYPES = st.sampled_from(
    [np.int8, np.int64, np.float64, np.float32, np.bool_, np.complex128, "U3", "M8[s]", "m8[s]"]
)
_NPZ_KEYS = st.sampled_from(
    ["emg", "fs_hz", "force_n", "channel_names", "emg_unit", "metadata_json", "intent",
     "intent_force_n", "mystery"]
)


@st.composite
def npz_bytes(draw) -> bytes:
    arrays = {}
    if draw(st.booleans()):
        n, c = draw(st.integers(0, 5)), draw(st.integers(0, 3))
        arrays["emg"] = draw(hnp.arrays(draw(_DTYPES), (n, c)))
        arrays["fs_hz"] = draw(hnp.arrays(draw(_DTYPES), draw(hnp.array_shapes(min_dims=0,
                                                                               max_dims=1))))
    for key in draw(st.lists(_NPZ_KEYS, max_size=4, unique=True)):
        shape = draw(hnp.array_shapes(min_dims=0, max_dims=2, max_side=5))
        arrays[key] = draw(hnp.arrays(draw(_DTYPES), shape))
    if draw(st.booleans()):
        arrays["metadata_json"] = np.array(json.dumps(draw(_JSON)))
    buffer = io.BytesIO()
    if draw(st.booleans()):
        np.savez_compressed(buffer, **arrays)
    else:
        np.savez(buffer, **arrays)
    data = bytearray(buffer.getvalue())
    mutation = draw(st.integers(0, 3))
    if mutation == 1 and data:
        data = data[: draw(st.integers(0, len(data)))]
    elif mutation == 2 and data:
        for _ in range(draw(st.integers(1, 8))):
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    return bytes(data)


@FUZZ
@given(data=npz_bytes())
def test_npz_fuzz_only_recording_error_escapes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fuzz.npz"
        path.write_bytes(data)
        _load(path)


# ---------------------------------------------------------------- findings


def _csv(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_bom_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbft,emg1,force\n0,1,2\n0.005,2,3\n0.01,3,4\n")
    rec = load_recording(path)
    assert rec.fs_hz == pytest.approx(200.0) and rec.emg_unit == "int8"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("# griploop {\"fs_hz\": 5000}\nt,emg1\n0,1\n0.005,1\n0.01,1\n",
         "metadata fs_hz 5000 Hz contradicts column 't' (200 Hz"),
        ("# griploop {\"emg_unit\": \"int8\"}\nt,emg1\n0,130000000000000000\n0.005,1\n",
         "int8 but values are not integers in -128..127"),
        ("t,emg1,force\n0,1,1e300\n0.005,1,2\n", "force_n: expected |values| <= 10000 N"),
        ("# griploop [1, 2]\nt,emg1\n0,1\n0.005,1\n", "expected a JSON object, found list"),
        ("# griploop {\"fs_hz\": [1]}\nt,emg1\n0,1\n0.005,1\n", "metadata fs_hz: expected"),
        ("# griploop {\"channel_names\": 7}\nt,emg1\n0,1\n0.005,1\n", "channel_names"),
        ("t," + ",".join(f"emg{i}" for i in range(1, 400)) + "\n", "columns (expected at most"),
    ],
)
def test_csv_garbage_is_refused(tmp_path: Path, text: str, needle: str) -> None:
    path = _csv(tmp_path / "bad.csv", text)
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    assert needle in str(info.value) and str(path) in str(info.value)


def test_undecodable_csv_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "latin.csv"
    path.write_bytes(b"t,emg1\n0,\xff\n")
    with pytest.raises(RecordingError, match=f"{path}: not UTF-8 text"):
        load_recording(path)


def test_oversized_csv_is_refused_before_reading(tmp_path: Path) -> None:
    path = _csv(tmp_path / "big.csv", "t,emg1\n" + "0,1\n" * 1000)
    with pytest.raises(RecordingError, match="expected at most 100"):
        load_recording(path, max_bytes=100)


@pytest.mark.parametrize(
    ("arrays", "needle"),
    [
        ({"emg": np.zeros((1, 2), np.int8), "fs_hz": 200.0}, "at least 2 samples"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": 200.0,
          "force_n": np.arange(9).astype("M8[s]")}, "force_n: expected a numeric"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": np.array(["200"])}, "fs_hz: expected"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": np.zeros((2, 2))}, "fs_hz: expected"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": 200.0, "channel_names": np.zeros(2)},
         "channel_names: expected"),
        ({"emg": np.full((9, 2), 2**40), "fs_hz": 200.0}, "expected int8 counts"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": 200.0,
          "metadata_json": np.array("[1]")}, "metadata_json: expected a JSON object"),
        ({"emg": np.zeros((9, 2), np.int8), "fs_hz": 200.0,
          "force_n": np.full(9, 1e300)}, "force_n: expected |values|"),
    ],
)
def test_npz_garbage_is_refused(tmp_path: Path, arrays: dict, needle: str) -> None:
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    assert needle in str(info.value) and str(path) in str(info.value)


def test_random_bytes_npz_gives_no_pickle_advice(tmp_path: Path) -> None:
    path = tmp_path / "noise.npz"
    path.write_bytes(np.random.default_rng(0).bytes(500))
    with pytest.raises(RecordingError) as info:
        load_recording(path)
    assert "not an NPZ file" in str(info.value) and "pickle" not in str(info.value)


# ---------------------------------------------------------------- bombs

_PEAK = textwrap.dedent(
    """
    import resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))  # a bomb fails, not the host
    from sim.recording import RecordingError, load_recording
    try:
        load_recording(sys.argv[1])
        print("loaded")
    except RecordingError as exc:
        print("refused:", exc)
    # peak RSS of this program: VmHWM (ru_maxrss would include the forking parent's)
    try:
        with open("/proc/self/status") as fh:
            hwm = [line for line in fh if line.startswith("VmHWM:")][0]
        print(int(hwm.split()[1]) // 1024)
    except (OSError, IndexError):
        print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
    """
)


def _peak_mb(path: Path) -> tuple[str, int]:
    proc = subprocess.run(
        [sys.executable, "-c", _PEAK, str(path)],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    message, peak = proc.stdout.strip().rsplit("\n", 1)
    return message, int(peak)


def _npy_header(shape: tuple, dtype: str = "|i1") -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": dtype, "fortran_order": False, "shape": shape}
    )
    return buffer.getvalue()


def test_deflate_bomb_is_refused_from_zip_headers(tmp_path: Path) -> None:
    path = tmp_path / "bomb.npz"
    n = 2**30  # 1 GiB of zeros, about 1 MB compressed
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        with zf.open("emg.npy", "w", force_zip64=True) as fp:
            fp.write(_npy_header((n // 8, 8)))
            chunk = bytes(2**22)
            for _ in range(n // len(chunk)):
                fp.write(chunk)
        zf.writestr("fs_hz.npy", _npy_header((), "<f8") + np.float64(200).tobytes())
    assert path.stat().st_size < 5 * 2**20
    message, peak = _peak_mb(path)
    assert "refused" in message and "bytes uncompressed (expected at most" in message
    assert peak < 300, f"peak {peak} MB"


def test_lying_npy_header_is_refused_before_allocation(tmp_path: Path) -> None:
    path = tmp_path / "liar.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("emg.npy", _npy_header((2**31, 8)) + bytes(64))
        zf.writestr("fs_hz.npy", _npy_header((), "<f8") + np.float64(200).tobytes())
    message, peak = _peak_mb(path)
    assert "refused" in message and "header declares shape" in message
    assert peak < 300, f"peak {peak} MB"
