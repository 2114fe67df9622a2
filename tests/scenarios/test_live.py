"""Live sessions: incremental windows, the real-time core, and sessions over LSL loopback.

The loopback tests stream a virtual subject's recordings with ``griploop stream`` in a
separate process and run ``griploop live`` / ``griploop calibrate`` in this one, in
real time (8 s sessions): they are the acceptance tests of issue 21.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from portable import assert_close_across_paths, steps_with_equal_inputs

from estimation.features import emg_features, extract_features
from scenarios.cli.main import main
from scenarios.live.calibrate import cue_levels, cue_schedule
from scenarios.live.display import render_states
from scenarios.live.recorded import episode_on_recording, fit_calibration
from scenarios.live.samples import SampleGuard
from scenarios.live.session import LiveGrasp, SessionSettings
from scenarios.live.windowing import IncrementalFeatures
from sim.hand.objects import make_object
from sim.recording import load_recording

CAN = make_object("can")
CONTROLLER = "mpc"
SESSION_S = 8.0
#: Stream names carry this run's id: parallel test workers, and other test runs on the
#: machine (LSL resolves names across the whole host), never see each other's streams.
RUN_ID = uuid.uuid4().hex[:8]
CONTRACT = {"samples": dict, "latency_ms": dict, "deadline_misses": int, "control_steps": int,
            "gaps": list, "metrics": dict}


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A virtual subject's calibration session and grasp of the can, written by the CLI."""
    out = tmp_path_factory.mktemp("live")
    assert main(["subjects", "--n", "1", "--out", str(out), "--grasp", "can",
                 "--grasp-s", "9"]) == 0
    return {"cal": out / "subject01.npz", "grasp": out / "subject01_grasp.npz", "dir": out}


@pytest.fixture(scope="module")
def calibration(files):
    return fit_calibration(load_recording(files["cal"]), "ridge")


@pytest.fixture(scope="module")
def offline(files, calibration):
    """The offline episode on the grasp recording (the design is cached for the session)."""
    return episode_on_recording(load_recording(files["grasp"]), calibration, CAN,
                                controller=CONTROLLER, episode_s=SESSION_S)


class Streamer:
    """``griploop stream FILE`` in its own process (as a lab's player or armband would be)."""

    def __init__(self, path: Path, name: str, *extra: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "scenarios.cli", "stream", str(path), "--name", name, *extra],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

    def __enter__(self) -> Streamer:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
        self.output = self.proc.communicate(timeout=10)[0]


def _stream_name(what: str) -> str:
    return f"griploop.test.{RUN_ID}.{what}"


def _live(name: str, files: dict[str, Path], json_path: Path, *extra: str) -> dict:
    status = main(["live", "--lsl", name, "--calibration", str(files["cal"]),
                   "--controller", CONTROLLER, "--object", "can", "--json", str(json_path),
                   "--no-video", "--resolve-timeout-s", "20", *extra])
    assert status == 0
    return json.loads(json_path.read_text())


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# ----------------------------------------------------------------------------- windows
@pytest.mark.portable
@pytest.mark.parametrize("dtype", ["int8", "float64"])
def test_incremental_windows_equal_extract_features(dtype) -> None:
    """int8 windows are integer sums: equal bit for bit; float windows are sums in another
    order than the batch's: equal to PATH_RTOL (tests/portable.py)."""
    same = np.testing.assert_array_equal if dtype == "int8" else assert_close_across_paths
    rng = np.random.default_rng(3)
    n = 2003
    if dtype == "int8":
        x = rng.integers(-128, 128, size=(n, 8)).astype(np.int8)
    else:
        x = rng.normal(0.0, 40.0, size=(n, 8)) * np.exp(rng.normal(0, 2, size=(n, 1)))
    for fs, channels in ((200.0, [5, 6, 7]), (1000.0, list(range(8))), (150.0, [0])):
        w = IncrementalFeatures(fs, channels, integer=dtype == "int8")
        rows = [r.copy() for s in x.astype(w.dtype) if (r := w.push(s)) is not None]
        same(np.array(rows), emg_features(x[:, channels], fs), err_msg=f"{fs} {channels}")
        # after a reset the windows start again with the next sample
        w.reset()
        rows = [r.copy() for s in x[500:].astype(w.dtype) if (r := w.push(s)) is not None]
        same(np.array(rows), emg_features(x[500:, channels], fs))


def test_incremental_windows_on_a_subject_recording(files) -> None:
    rec = load_recording(files["grasp"])
    w = IncrementalFeatures(rec.fs_hz, [5, 6, 7])
    rows = [r.copy() for s in rec.emg.astype(w.dtype) if (r := w.push(s)) is not None]
    assert np.array_equal(np.array(rows), extract_features(rec).X)


# ----------------------------------------------------------------------------- the core
@pytest.mark.portable
def test_the_live_core_fed_sample_by_sample_is_the_offline_episode(files, calibration,
                                                                    offline) -> None:
    rec = load_recording(files["grasp"])
    grasp = LiveGrasp(calibration, CAN, controller=CONTROLLER,
                      settings=SessionSettings(duration_s=SESSION_S, frame_dt_s=0.04))
    grasp.start()
    for i in range(rec.n_samples):
        grasp.feed(rec.emg[i:i + 1], np.array([1000.0 + i / rec.fs_hz]), time.perf_counter())
        if grasp.finished:
            break
    report = grasp.report()
    assert len(grasp.frames) == SESSION_S / 0.04
    # the live core windows the sEMG sample by sample: its references agree to PATH_RTOL,
    # and the hand fed the same references computes the same states (tests/portable.py)
    assert_close_across_paths(grasp.traces["reference_n"][:grasp.k],
                              offline.traces["reference_n"])
    k = steps_with_equal_inputs(grasp.traces["reference_n"][:grasp.k],
                                offline.traces["reference_n"])
    for key in ("grip_force_n", "tracked_reference_n", "object_height_m"):
        assert np.array_equal(grasp.traces[key][:k], offline.traces[key][:k]), key
    live, off = report["metrics"], offline.metrics
    assert set(live) == set(off)
    for key, value in off.items():
        if key not in ("estimation_rmse_n",):
            assert live[key] == value, key
    assert report["samples"] == {"received": int(round(SESSION_S * rec.fs_hz)) - 1,
                                 "expected": int(round(SESSION_S * rec.fs_hz)) - 1, "lost": 0}
    assert report["control_steps"] == int(round(SESSION_S / 0.01))
    assert report["ended"] == "duration" and report["gaps"] == []


def test_a_gap_holds_the_grip_on_the_wall_clock_and_control_resumes(files, calibration,
                                                                     offline) -> None:
    """Deterministic: arrival times and the wall clock are simulated."""
    rec = load_recording(files["grasp"])
    fs, now = rec.fs_hz, [0.0]
    events: list[tuple[float, str]] = []
    grasp = LiveGrasp(calibration, CAN, controller=CONTROLLER,
                      settings=SessionSettings(duration_s=SESSION_S), clock=lambda: now[0],
                      event=lambda t, marker: events.append((t, marker)))
    grasp.start()
    gap = (int(6.2 * fs), int(7.2 * fs))
    for i in range(rec.n_samples):
        for sub in (3, 2, 1):  # the wall clock ticks four times per sample period
            now[0] = (i - sub / 4) / fs
            grasp.tick(now[0])
        now[0] = i / fs
        if not gap[0] <= i < gap[1]:
            grasp.feed(rec.emg[i:i + 1], np.array([i / fs]), now[0])
        grasp.tick(now[0])
        if grasp.finished:
            break
    report = grasp.report()
    assert report["ended"] == "duration"
    assert report["gaps"] == [{"t_s": 6.2, "duration_s": 1.0}]
    assert report["samples"]["lost"] == gap[1] - gap[0]
    assert report["metrics"]["outcome"] == offline.metrics["outcome"] == "held"
    t, grip = grasp.traces["t_s"], grasp.traces["grip_force_n"]
    before = grip[np.flatnonzero(t < 6.2)[-1]]
    during = grip[(t >= 6.2) & (t < 7.2 + 0.4)]  # until the first window after the gap
    assert np.all(np.abs(during - before) <= 0.1 * before)
    ref = grasp.traces["reference_n"]
    held = ref[(t >= 6.45) & (t < 7.6)]
    assert np.ptp(held) == 0.0 and held[0] <= ref[np.flatnonzero(t < 6.2)[-1]]
    assert ref[t >= 7.65][0] != held[0]  # the estimate drives the hand again
    markers = [m for _, m in events]
    assert markers.index("gap_start") < markers.index("gap_end")
    assert report["deadline_misses"] == 0


def test_stored_states_render_to_a_gif_after_the_session(tmp_path) -> None:
    from PIL import Image

    from sim.hand.grasp_env import GraspEnv

    env = GraspEnv(CAN, 0.0)
    env.reset(seed=0)
    closed = env.data.qpos.copy()
    env.data.qpos[2] += 0.05  # something moves between the frames
    states = [(closed, False), (env.data.qpos.copy(), False), (closed, True)]
    env.close()
    path = render_states(CAN, states, tmp_path / "s.gif", size=(60, 80))
    with Image.open(path) as gif:
        frames = []
        for i in range(gif.n_frames):
            gif.seek(i)
            frames.append(np.asarray(gif.convert("RGB")))
    assert len(frames) == 3 and frames[0].shape == (60, 80, 3)
    assert not np.array_equal(frames[0], frames[1])
    assert not np.array_equal(frames[0], frames[2])  # the crushed object changes colour


def test_the_sample_guard_counts_replaces_and_clips() -> None:
    guard = SampleGuard(integer=True)
    x = guard.clean([["1", "abc", "3"], ["300", "-7", "nan"], ["4", "5", "6"]])
    assert x.dtype == np.int64 and x.tolist() == [[1, 0, 3], [127, -7, 0], [4, 5, 6]]
    assert (guard.non_numeric, guard.out_of_range) == (2, 1)
    y = guard.clean(np.array([[np.inf, 2.4, -500.0], [1.0, 2.0, 3.0]], dtype=np.float32))
    assert y.tolist() == [[0, 2, -128], [1, 2, 3]]
    assert (guard.non_numeric, guard.out_of_range) == (3, 2)
    wide = SampleGuard(integer=False).clean(np.array([[1.5, np.nan]]))
    assert wide.tolist() == [[1.5, 0.0]]


def test_the_cue_schedule_splits_inside_the_medium_squeeze() -> None:
    cues, duration = cue_schedule()
    assert duration == 28.0
    assert [c.label for c in cues] == ["rest", "squeeze small", "rest", "squeeze medium", "rest",
                                       "squeeze strong", "rest"]
    medium = cues[3]
    assert medium.t_s <= duration / 2 < medium.t_s + medium.duration_s
    levels = cue_levels(cues, np.array([0.0, 3.5, 12.0, 20.0, 27.9]))
    assert levels.tolist() == [0.0, 0.25, 0.5, 0.9, 0.0]


# ----------------------------------------------------------------------------- over LSL
@pytest.mark.slow
def test_live_over_loopback_matches_the_offline_episode(files, offline, tmp_path,
                                                        capsys) -> None:
    """Issue 21's acceptance: 8 s on loopback, samples, latency, deadlines, outcome."""
    off_json = tmp_path / "offline.json"
    assert main(["episode", "--recording", str(files["grasp"]), "--calibration",
                 str(files["cal"]), "--estimator", "ridge", "--controller", CONTROLLER,
                 "--object", "can", "--episode-s", str(SESSION_S), "--json",
                 str(off_json)]) == 0
    episode = json.loads(off_json.read_text())["metrics"]
    assert episode["outcome"] == offline.metrics["outcome"]
    name = _stream_name("accept")
    with Streamer(files["grasp"], name):
        report = _live(name, files, tmp_path / "live.json",
                       "--record", str(tmp_path / "received.npz"),
                       "--feedback", "force_vibration")
    print(capsys.readouterr().out)
    for key, kind in CONTRACT.items():
        assert isinstance(report[key], kind), key
    assert set(report["samples"]) == {"received", "expected", "lost"}
    assert set(report["latency_ms"]) == {"p50", "p99"}
    s = report["samples"]
    assert s["expected"] == int(round(SESSION_S * 200)) - 1
    assert s["received"] >= 0.99 * s["expected"]
    assert report["latency_ms"]["p99"] <= 5.0
    assert report["deadline_misses"] <= 0.01 * report["control_steps"]
    assert report["control_steps"] == 800 and report["ended"] == "duration"
    m = report["metrics"]
    assert m["outcome"] == episode["outcome"]
    assert m["peak_force_n"] == pytest.approx(episode["peak_force_n"], rel=0.10)
    assert report["gaps"] == [] and report["bad_samples"] == {"non_numeric": 0,
                                                              "out_of_range": 0}
    # the stimulator's intensity went out as griploop.feedback: the grip force's level
    assert "griploop.feedback" in report["outlets"] and report["feedback"] == "force_vibration"
    from sim.user.feedback import FeedbackDevice

    device = FeedbackDevice("force_vibration", force_range_n=30.0)
    tr = report["traces"]
    expected = [device.output(t, g, v) for t, g, v in
                zip(tr["t_s"], tr["grip_force_n"], tr["slip_speed_m_s"], strict=True)]
    np.testing.assert_allclose(tr["feedback"], expected)
    assert max(tr["feedback"]) > 0
    received = load_recording(tmp_path / "received.npz")
    sent = load_recording(files["grasp"])
    assert np.array_equal(received.emg, sent.emg[:received.n_samples])


@pytest.mark.slow
def test_stopping_the_stream_mid_hold_holds_the_grip(files, tmp_path, capsys) -> None:
    """A 7 s session: lift from 4.4 s, in the air from 5.0 s, no sample from 5.5 to 6.5 s.

    The gap starts half a second into the in-air hold, once the lift's load step has
    settled (right after the lift the MPC is still raising the grip to its sensed slip
    bound, which a gap must not stop).
    """
    name = _stream_name("gap")
    with Streamer(files["grasp"], name, "--dropout", "5.5:1.0"):
        report = _live(name, files, tmp_path / "gap.json", "--duration-s", "7")
    print(capsys.readouterr().out)
    assert len(report["gaps"]) == 1
    gap = report["gaps"][0]
    assert gap["t_s"] == pytest.approx(5.5, abs=0.01)
    assert gap["duration_s"] == pytest.approx(1.0, abs=0.1)
    assert report["metrics"]["outcome"] == "held" and not report["metrics"]["dropped"]
    t = np.array(report["traces"]["t_s"])
    grip = np.array(report["traces"]["grip_force_n"])
    before = grip[np.flatnonzero(t < gap["t_s"])[-1]]
    during = grip[(t >= gap["t_s"]) & (t < gap["t_s"] + gap["duration_s"])]
    assert during.size >= 90
    assert np.all(np.abs(during - before) <= 0.1 * before)
    assert report["ended"] == "duration" and report["control_steps"] == 700


@pytest.mark.slow
def test_calibrate_over_lsl_writes_a_file_evaluate_accepts(files, tmp_path, capsys) -> None:
    out = tmp_path / "cal_live.npz"
    name = _stream_name("cal")
    with Streamer(files["cal"], name, "--speed", "16", "--loop"):
        assert main(["calibrate", "--lsl", name, "--out", str(out),
                     "--resolve-timeout-s", "20"]) == 0
    text = capsys.readouterr().out
    assert "SQUEEZE SMALL" in text and "SQUEEZE STRONG" in text
    rec = load_recording(out)
    assert rec.n_samples == 28 * 200
    assert rec.metadata["force_source"] == f"lsl:{name}.force"
    sent = load_recording(files["cal"])
    assert np.array_equal(rec.emg, sent.emg[:rec.n_samples])
    # the force is interpolated at each sEMG time stamp: the two inlets' clock offsets differ
    # by microseconds, a fraction of a sample period at 16x
    force = sent.force_n[:rec.n_samples]
    assert np.max(np.abs(rec.force_n - force)) < 0.05 * np.max(force)
    assert main(["evaluate", "--recording", str(out), "--estimators", "ridge"]) == 0


# ----------------------------------------------------------------------------- bad input
def _outlet(name: str, n_channels: int, fs_hz: float, fmt: str = "int8"):
    from scenarios.live.lsl import pylsl_module

    lsl = pylsl_module()
    cf = {"int8": lsl.cf_int8, "string": lsl.cf_string}[fmt]
    return lsl.StreamOutlet(lsl.StreamInfo(name, "EMG", n_channels, fs_hz, cf, name))


@pytest.mark.parametrize(("n_channels", "fs_hz"), [(4, 200.0), (8, 100.0)])
def test_a_stream_unlike_the_calibration_is_refused_in_one_line(files, n_channels, fs_hz,
                                                                capsys) -> None:
    name = _stream_name(f"mismatch{n_channels}")
    outlet = _outlet(name, n_channels, fs_hz)
    status = main(["live", "--lsl", name, "--calibration", str(files["cal"]), "--controller",
                   CONTROLLER, "--object", "can", "--no-video"])
    line = _one_error_line(capsys)
    del outlet
    assert status == 2
    assert f"{n_channels} channels at {fs_hz:g} Hz" in line and "8 channels at 200 Hz" in line


def test_an_unresolved_name_lists_the_streams_seen(files, capsys) -> None:
    visible, missing = _stream_name("visible"), _stream_name("nosuch")
    outlet = _outlet(visible, 8, 200.0)
    status = main(["live", "--lsl", missing, "--calibration", str(files["cal"]),
                   "--controller", CONTROLLER, "--object", "can", "--no-video",
                   "--resolve-timeout-s", "1"])
    line = _one_error_line(capsys)
    del outlet
    assert status == 2
    assert missing in line and f"'{visible}' (EMG, 8 ch, 200 Hz" in line


@pytest.mark.slow
def test_bad_samples_are_counted_and_a_lost_stream_ends_the_session_cleanly(
        files, tmp_path, capsys) -> None:
    """A string stream with garbage and out-of-range counts, which then stops for good."""
    name = _stream_name("bad")
    outlet = _outlet(name, 8, 200.0, "string")
    rec = load_recording(files["grasp"])
    bad = {"non_numeric": 0, "out_of_range": 0}

    def play(outlet) -> None:
        from scenarios.live.lsl import pylsl_module

        lsl = pylsl_module()
        while not outlet.wait_for_consumers(0.1):
            pass
        t0 = lsl.local_clock()
        for i in range(int(2.0 * 200)):
            row = [str(int(v)) for v in rec.emg[i]]
            if i % 50 == 7:
                row[6] = "n/a"
                bad["non_numeric"] += 1
            if i % 50 == 19:
                row[2] = "400"
                bad["out_of_range"] += 1
            t = t0 + i / 200
            time.sleep(max(0.0, t - lsl.local_clock()))
            outlet.push_sample(row, t)

    player = threading.Thread(target=play, args=(outlet,), daemon=True)
    player.start()
    out = tmp_path / "bad.json"
    status = main(["live", "--lsl", name, "--calibration", str(files["cal"]),
                   "--controller", CONTROLLER, "--object", "can", "--duration-s", "4",
                   "--hold-s", "1", "--timeout-s", "0.5", "--json", str(out)])
    player.join(5)
    text = capsys.readouterr().out
    assert status == 0
    report = json.loads(out.read_text())
    assert report["ended"] == "timeout"
    assert report["bad_samples"] == bad
    assert report["samples"]["received"] == 400
    assert report["gaps"][-1]["duration_s"] >= 0.5
    assert "were replaced by 0 or clipped" in text
    assert out.with_suffix(".gif").stat().st_size > 0  # headless: a GIF beside the JSON


def test_without_liblsl_the_commands_say_so_in_one_line(files, monkeypatch, capsys) -> None:
    import scenarios.live.lsl as lsl

    monkeypatch.setitem(sys.modules, "pylsl", None)
    monkeypatch.setattr(lsl, "_configured", False)
    for argv in (["stream", str(files["grasp"])],
                 ["calibrate", "--lsl", "x", "--out", "x.npz"],
                 ["live", "--lsl", "x", "--calibration", str(files["cal"]), "--controller",
                  CONTROLLER, "--object", "can"]):
        assert main(argv) == 2
        line = _one_error_line(capsys)
        assert "liblsl could not be loaded" in line and "pip install pylsl" in line
        assert "glibc >= 2.35" in line and "system liblsl" in line
