"""``griploop subjects`` and ``griploop plot-recording`` through ``scenarios.cli.main.main``."""

from __future__ import annotations

import numpy as np

from scenarios.cli import main
from sim.recording import load_recording
from sim.user.subjects import make_population


def test_subjects_writes_npz_and_csv_per_subject(tmp_path, capsys):
    out = tmp_path / "pop"
    assert main(["subjects", "--n", "2", "--seed", "3", "--out", str(out)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith("subject01") and "mvc" in lines[0]
    for i, subject in enumerate(make_population(2, seed=3), start=1):
        npz = load_recording(out / f"subject{i:02d}.npz")
        csv = load_recording(out / f"subject{i:02d}.csv")
        direct = subject.paper_session(generator="noise")
        np.testing.assert_array_equal(npz.emg, direct.emg)
        np.testing.assert_array_equal(csv.emg, direct.emg)
        np.testing.assert_allclose(csv.force_n, direct.force_n, rtol=1e-5, atol=1e-6)
        assert npz.metadata["subject_id"] == i and csv.metadata["seed"] == 3


def test_subjects_with_motor_units(tmp_path, capsys):
    assert main(["subjects", "--n", "1", "--generator", "motor_units", "--out",
                 str(tmp_path)]) == 0
    rec = load_recording(tmp_path / "subject01.npz")
    assert rec.metadata["generator"] == "motor_units" and rec.emg.dtype == np.int8


def test_plot_recording_writes_a_png(tmp_path, capsys):
    rec = make_population(1, seed=0)[0].paper_session()
    src = rec.save_npz(tmp_path / "s1.npz")
    png = tmp_path / "s1.png"
    assert main(["plot-recording", str(src), "--out", str(png)]) == 0
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000


def test_bad_inputs_give_exit_2_and_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,emg1,force\n0.0,1,0.5\n0.005,x,0.5\n")
    assert main(["plot-recording", str(bad), "--out", str(tmp_path / "b.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("griploop plot-recording: error:")
    assert "unparsable" in err[0] and not (tmp_path / "b.png").exists()
    assert main(["subjects", "--n", "0", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["griploop subjects: error: --n must be at least 1, found 0"]
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["subjects", "--n", "1", "--out", str(blocker)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
