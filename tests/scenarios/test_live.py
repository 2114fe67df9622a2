"""Live sessions: incremental windows, the real-time core, and sessions over LSL loopback.

The loopback tests stream a virtual subject's recordings with ``griploop stream`` in a
separate process and run ``griploop live`` / ``griploop calibrate`` in this one, in
real time (8 s sessions): they are the acceptance tests of issue 21, and with the
subject's arm on the IMU stream, of issue 29, with its faults on loopback (two outlets of
one name, a source taking over the name, a stall of the IMU stream; the unit and
deterministic tests of issue 29 are in test_live_faults.py). Every LSL session of the
suite is in this file, so that the suite's workers never run two at once.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from lsl_players import Streamer

from controllers.bounds import slip_threshold_n
from scenarios.cli.main import main
from scenarios.live.arm import LIFT_HEIGHT_M, OrientationChannels, PitchArm, virtual_arm_poses
from scenarios.live.calibrate import cue_levels, cue_schedule
from scenarios.live.display import render_states
from scenarios.live.hooks import SessionHooks
from scenarios.live.lsl import StreamQuery, local_host
from scenarios.live.recorded import ReplaySpec, episode_on_recording, fit_calibration
from scenarios.live.samples import SampleGuard
from scenarios.live.session import LiveGrasp, SessionSettings
from sim.hand.objects import make_object
from sim.recording import load_recording
from sim.user.operator import WristMove

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
                                ReplaySpec(controller=CONTROLLER, episode_s=SESSION_S))


class ScheduleArm:
    """A test arm that lifts as the scripted user's arm does.

    At the first control step at or after ``lift_after_s`` where both sides touch and
    the grip reaches 1 N, a 0.6 s minimum-jerk move to the lift height. Not a thing
    ``griploop live`` offers: a person's lift is their own.
    """

    source = "schedule"
    tremor_m = 0.0

    def __init__(self, lift_after_s: float) -> None:
        self.lift_after_s = lift_after_s
        self.grasp = None
        self.lifted = False

    def reset(self) -> None:
        self.lifted = False

    def bind(self, emit, notify) -> None:
        pass

    def tick(self, now: float, t_s: float) -> None:
        pass

    def summary(self) -> dict:
        return {"source": self.source}

    def command(self, t_s: float, setpoint_m: float):
        info = self.grasp.info
        if (not self.lifted and t_s >= self.lift_after_s - 1e-9 and info["thumb_contact"]
                and info["finger_contact"] and info["grip_force_n"] >= 1.0):
            self.lifted = True
            return WristMove(LIFT_HEIGHT_M, 0.6)
        return None


def scripted_grasp(calibration, **kwargs) -> LiveGrasp:
    """A live core whose wrist lifts at the offline episode's time (5.4 s of 8)."""
    arm = ScheduleArm(SESSION_S - 2.0 - 0.6)
    grasp = LiveGrasp(calibration, CAN, arm=arm, controller=CONTROLLER, **kwargs)
    arm.grasp = grasp
    return grasp


def _stream_name(what: str) -> str:
    return f"griploop.test.{RUN_ID}.{what}"


def _live(name: str, files: dict[str, Path], json_path: Path, *extra: str) -> dict:
    """``griploop live`` on the stream ``name`` with its arm on ``name.imu``."""
    status = main(["live", "--lsl", name, "--imu-lsl", name + ".imu", "--calibration",
                   str(files["cal"]), "--controller", CONTROLLER, "--object", "can", "--json",
                   str(json_path), "--no-video", "--resolve-timeout-s", "20", *extra])
    assert status == 0
    return json.loads(json_path.read_text())


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def _feed_sample_by_sample(grasp: LiveGrasp, rec) -> None:
    """Start ``grasp`` and feed it each orientation sample, then each sEMG sample, of ``rec``."""
    grasp.start()
    for i in range(rec.n_samples):
        now, stamp = time.perf_counter(), np.array([i / rec.fs_hz])
        grasp.feed_imu(rec.pitch_rad[i:i + 1, None], stamp, now)
        grasp.feed(rec.emg[i:i + 1], stamp, now)
        if grasp.finished:
            break


# ----------------------------------------------------------------------------- the core
def test_the_live_core_fed_sample_by_sample_is_the_replay_of_its_recording(
        files, calibration, offline) -> None:
    """The same samples, the same forearm: the same trial loop gives the same trial.

    The live core receives each orientation sample (the recorded pitch) and then each
    sEMG sample, one at a time; the replay reads the recording as its clock reaches it.
    Both window integer counts and run the same code: every trace is equal.
    """
    rec = load_recording(files["grasp"])
    arm = PitchArm(virtual_arm_poses(forearm_m=rec.metadata["forearm_m"]),
                   OrientationChannels("pitch", (0,)), imu_fs_hz=rec.fs_hz)
    grasp = LiveGrasp(calibration, CAN, arm=arm, controller=CONTROLLER,
                      settings=SessionSettings(duration_s=SESSION_S, frame_dt_s=0.04))
    _feed_sample_by_sample(grasp, rec)
    report = grasp.report()
    assert len(grasp.frames) == SESSION_S / 0.04
    for key in ("reference_n", "grip_force_n", "tracked_reference_n", "object_height_m",
                "wrist_height_m", "command"):
        np.testing.assert_array_equal(grasp.traces[key], offline.traces[key], err_msg=key)
    live, off = report["metrics"], dict(offline.metrics)
    # the same trial, judged by the same referee; only the replay of a virtual subject's
    # recording knows their true force (the estimation error)
    assert off.pop("estimation_rmse_n") > 0 and live.pop("estimation_rmse_n") is None
    assert live == off
    assert live["outcome"] == "held" and live["attempts"] == 1
    assert live["time_to_lift_s"] > 0 and live["safety_margin_pct"] is not None
    # the subject's arm lifts at 5.4 s; the wrist leaves the table once the forearm has
    # risen past the arm mapping's dead band
    assert 5.4 < report["arm"]["lift_start_s"] < 5.7
    assert report["samples"] == {"received": int(round(SESSION_S * rec.fs_hz)) - 1,
                                 "expected": int(round(SESSION_S * rec.fs_hz)) - 1, "lost": 0}
    assert report["control_steps"] == int(round(SESSION_S / 0.01))
    assert report["ended"] == "duration" and report["gaps"] == []
    markers = [e["marker"] for e in report["events"]]
    assert markers[0] == "session_start" and markers[-1] == "session_end"
    assert markers.count("lift") == 1


def test_the_live_core_runs_the_hands_settings_as_the_replay_does(files, calibration,
                                                                   offline) -> None:
    """force_hold on the self-locking drive with auto-grip, around the MPC: live and replay
    run the same settings and give the same trial; the settings change the trial."""
    from scenarios.runners.trial_loop import HandSettings

    hand = HandSettings("self_locking", "force_hold", True)
    rec = load_recording(files["grasp"])
    replay = episode_on_recording(rec, calibration, CAN, ReplaySpec(
        controller=CONTROLLER, episode_s=SESSION_S, hand=hand))
    arm = PitchArm(virtual_arm_poses(forearm_m=rec.metadata["forearm_m"]),
                   OrientationChannels("pitch", (0,)), imu_fs_hz=rec.fs_hz)
    grasp = LiveGrasp(calibration, CAN, arm=arm, controller=CONTROLLER,
                      settings=SessionSettings(duration_s=SESSION_S, hand=hand))
    # the MPC's own sensed slip bound and the hand's slip reflex wrapped around it
    assert type(grasp.design.controller).__name__ == "SlipReflex"
    _feed_sample_by_sample(grasp, rec)
    report = grasp.report()
    assert {k: report[k] for k in ("paradigm", "drive", "auto_grip")} == hand.fields()
    for key in ("reference_n", "grip_force_n", "tracked_reference_n", "command"):
        np.testing.assert_array_equal(grasp.traces[key], replay.traces[key], err_msg=key)
    ref, held = np.asarray(replay.traces["reference_n"]), offline.traces["reference_n"]
    assert not np.array_equal(ref, held)
    # force_hold: the reference never falls while it is above 0 (the gate closed)
    on = np.flatnonzero((ref[1:] > 0) & (ref[:-1] > 0)) + 1
    assert on.size and np.all(ref[on] >= ref[on - 1])


def test_a_gap_holds_the_grip_on_the_wall_clock_and_control_resumes(files, calibration,
                                                                     offline) -> None:
    """Deterministic: arrival times and the wall clock are simulated."""
    rec = load_recording(files["grasp"])
    fs, now = rec.fs_hz, [0.0]
    events: list[tuple[float, str]] = []
    grasp = scripted_grasp(calibration, settings=SessionSettings(duration_s=SESSION_S),
                           hooks=SessionHooks(clock=lambda: now[0],
                                              event=lambda t, marker: events.append((t, marker))))
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
    with Streamer(files["grasp"], name) as player:
        report = _live(name, files, tmp_path / "live.json",
                       "--record", str(tmp_path / "received.npz"),
                       "--feedback", "force_vibration")
    print(capsys.readouterr().out)
    # the session pinned the player's streams, each by its own source_id
    assert f"source_id {report['stream']['source_id']!r}" in player.output
    assert f"source_id {report['imu_stream']['source_id']!r}" in player.output
    assert report["stream"]["source_id"] != report["imu_stream"]["source_id"]
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
    # the subject's own arm lifted: when their forearm rose past the dead band (5 % of the
    # way, 0.14 s into its 0.6 s lift), plus the smoothing and the wrist's follow lag
    arm = report["arm"]
    lift_s = load_recording(files["grasp"]).metadata["arm_lift_s"]
    assert arm["source"] == "imu" and arm["imu_gaps"] == []
    assert lift_s + 0.1 <= arm["lift_start_s"] <= lift_s + 0.3
    assert arm["imu_samples"] >= 0.99 * SESSION_S * 50
    assert max(report["traces"]["wrist_height_m"]) == pytest.approx(LIFT_HEIGHT_M, abs=0.002)
    assert "lift" in [e["marker"] for e in report["events"]]
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
    """An 8 s session: the arm lifts from 5.4 s, the can is in the air from about 6.1 s,
    and the armband's link drops from 6.6 to 7.6 s (no sEMG, no orientation).

    The gap starts half a second into the in-air hold, once the lift's load step has
    settled (right after the lift the MPC is still raising the grip to its sensed slip
    bound, which a gap must not stop).
    """
    name = _stream_name("gap")
    with Streamer(files["grasp"], name, "--dropout", "6.6:1.0"):
        report = _live(name, files, tmp_path / "gap.json")
    print(capsys.readouterr().out)
    assert len(report["gaps"]) == 1
    gap = report["gaps"][0]
    assert gap["t_s"] == pytest.approx(6.6, abs=0.01)
    assert gap["duration_s"] == pytest.approx(1.0, abs=0.1)
    assert report["metrics"]["outcome"] == "held" and not report["metrics"]["dropped"]
    t = np.array(report["traces"]["t_s"])
    grip = np.array(report["traces"]["grip_force_n"])
    before = grip[np.flatnonzero(t < gap["t_s"])[-1]]
    during = grip[(t >= gap["t_s"]) & (t < gap["t_s"] + gap["duration_s"])]
    assert during.size >= 90
    assert np.all(np.abs(during - before) <= 0.1 * before)
    # the link carries the arm too: the wrist held still through the same silence
    (stall,) = report["arm"]["imu_gaps"]
    assert stall["t_s"] == pytest.approx(6.6, abs=0.021)
    wrist = np.array(report["traces"]["wrist_height_m"])
    assert np.ptp(wrist[(t >= 6.6 + 0.45) & (t < 7.6)]) < 5e-5  # once at the last sample
    assert report["ended"] == "duration" and report["control_steps"] == 800


@pytest.mark.slow
def test_calibrate_over_lsl_writes_a_file_evaluate_accepts(files, tmp_path, capsys) -> None:
    """With the armband's IMU: the pitch beside the sEMG, and the two arm poses after it."""
    import dataclasses

    sent = load_recording(files["cal"])
    t = sent.t_s  # the subject rests the forearm, then raises it by 0.3 rad when asked,
    pitch = np.where(t < 31.0, 0.0, 0.3) + 0.01 * np.sin(2 * np.pi * 0.5 * t)  # swaying
    with_arm = tmp_path / "cal_arm.npz"
    dataclasses.replace(sent, pitch_rad=pitch).save(with_arm)
    out = tmp_path / "cal_live.npz"
    name = _stream_name("cal")
    with Streamer(with_arm, name, "--speed", "16", "--loop"):
        assert main(["calibrate", "--lsl", name, "--out", str(out),
                     "--resolve-timeout-s", "20"]) == 0
    text = capsys.readouterr().out
    assert "SQUEEZE SMALL" in text and "SQUEEZE STRONG" in text
    assert "ARM AT REST" in text and "ARM RAISED" in text
    rec = load_recording(out)
    assert rec.n_samples + rec.metadata["lost_samples"] == 28 * 200, rec.metadata
    assert rec.metadata["force_source"] == f"lsl:{name}.force"
    assert np.array_equal(rec.emg, sent.emg[:rec.n_samples])
    # the pitch went out as a 50 Hz float32 quaternion and came back interpolated at each
    # sEMG stamp (the two inlets' clock offsets differ by microseconds)
    assert rec.metadata["imu_stream"] == f"{name}.imu"
    np.testing.assert_allclose(rec.pitch_rad, pitch[:rec.n_samples], atol=1e-4)
    poses = rec.metadata["arm_poses"]
    # medians of the last 2 s of each pose (29-31 s at rest, 32-34 s raised)
    assert poses["rest_pitch_rad"] == pytest.approx(np.median(pitch[(t >= 29) & (t < 31)]),
                                                    abs=0.002)
    assert poses["raised_pitch_rad"] == pytest.approx(
        np.median(pitch[(t >= 32) & (t < 34)]), abs=0.002)
    # the force is interpolated at each sEMG time stamp: the two inlets' clock offsets differ
    # by microseconds, a fraction of a sample period at 16x
    force = sent.force_n[:rec.n_samples]
    assert np.max(np.abs(rec.force_n - force)) < 0.05 * np.max(force)
    assert main(["evaluate", "--recording", str(out), "--estimators", "ridge"]) == 0


@pytest.mark.slow
def test_calibrate_open_over_lsl_labels_the_open_cues(files, tmp_path, capsys) -> None:
    """``--open`` (issue 36): three open cues follow the paper's squeezes, printed as they
    are, and the recording's ``open_intent`` is each open cue's level; the force label
    (the cues', without a force stream) stays the squeezes'. Without ``--open`` nothing
    changes (the test above)."""
    out = tmp_path / "cal_open.npz"
    name = _stream_name("calopen")
    with Streamer(files["cal"], name, "--speed", "16", "--loop", "--no-imu"):
        assert main(["calibrate", "--lsl", name, "--out", str(out), "--open", "--force-lsl",
                     "none", "--resolve-timeout-s", "20"]) == 0
    text = capsys.readouterr().out
    for cue in ("SQUEEZE SMALL", "SQUEEZE STRONG", "OPEN SMALL", "OPEN MEDIUM", "OPEN STRONG"):
        assert cue in text, cue
    assert text.index("SQUEEZE STRONG") < text.index("OPEN SMALL") < text.index("OPEN STRONG")
    assert "--paradigm velocity" in text
    rec = load_recording(out)
    meta = rec.metadata
    assert rec.n_samples + meta["lost_samples"] == 52 * 200, meta
    assert meta["open_from_s"] == 28.0 and meta["open_intent_source"] == "cues"
    assert meta["levels"] == [0.25, 0.5, 0.9] and meta["open_levels"] == [0.3, 0.6, 1.0]
    t = rec.t_s  # sample times: stream times less the few samples lost, if any
    middle = {(4.0, 6.0): (0.25, 0.0), (21.0, 23.0): (0.9, 0.0), (25.0, 27.0): (0.0, 0.0),
              (29.0, 31.0): (0.0, 0.3), (33.0, 35.0): (0.0, 0.0), (37.0, 39.0): (0.0, 0.6),
              (45.0, 47.0): (0.0, 1.0), (49.0, 51.0): (0.0, 0.0)}
    for (t0, t1), (squeeze, opening) in middle.items():
        inside = (t >= t0) & (t < t1)
        assert np.all(rec.force_n[inside] == squeeze * 40.0), (t0, t1)
        assert np.all(rec.open_intent[inside] == opening), (t0, t1)
    n = 28 * 200 - meta["lost_samples"]  # the squeezes (the player loops the file after)
    assert np.array_equal(rec.emg[:n], load_recording(files["cal"]).emg[:n])


# ----------------------------------------------------------------------------- faults (issue 29)
def _live_status(name: str, files: dict[str, Path], *extra: str) -> int:
    return main(["live", "--lsl", name, "--calibration", str(files["cal"]), "--controller",
                 CONTROLLER, "--object", "can", "--no-video", "--resolve-timeout-s", "20",
                 *extra])


def _source_id(player: Streamer, stream: str) -> str:
    """The source_id a player printed for ``stream``."""
    text = "".join(player.lines)
    start = text.index(f"'{stream}' (") if f"'{stream}' (" in text else text.index(stream)
    tail = text[start:]
    return tail[tail.index("source_id '") + 11:].split("'")[0]


@pytest.mark.slow
def test_two_outlets_of_one_name_are_refused_and_one_is_pinned_by_its_source_id(
        files, tmp_path, capsys) -> None:
    name = _stream_name("dup")
    with Streamer(files["grasp"], name) as a, Streamer(files["cal"], name) as b:
        a.wait_for("waiting for a consumer")
        b.wait_for("waiting for a consumer")
        sid_a, sid_b = _source_id(a, name), _source_id(b, name)
        assert sid_a != sid_b
        assert _live_status(name, files, "--imu-lsl", name + ".imu") == 2
        line = _one_error_line(capsys)
        assert f"2 LSL streams match {name!r}" in line
        for sid in (sid_a, sid_b):
            assert (f"host {local_host()!r}, source_id {sid!r} (EMG, 8 ch, 200 Hz, int8)"
                    in line)
        assert line.endswith(f"(--lsl {name}@HOST or --lsl-source-id ID)")
        out = tmp_path / "pinned.json"
        assert _live_status(name, files, "--lsl-source-id", sid_a, "--imu-lsl", name + ".imu",
                     "--duration-s", "1.5", "--json", str(out), "--record",
                     str(tmp_path / "pinned.npz")) == 0
    report = json.loads(out.read_text())
    assert report["stream"]["source_id"] == sid_a and report["ended"] == "duration"
    received = load_recording(tmp_path / "pinned.npz")
    assert np.array_equal(received.emg, load_recording(files["grasp"]).emg[:received.n_samples])


class Markers(threading.Thread):
    """Reads a session's ``PREFIX.events`` outlet until ``session_end``."""

    def __init__(self, name: str) -> None:
        super().__init__(daemon=True)
        self.name_, self.markers = name, []

    def run(self) -> None:
        from scenarios.live.lsl import pylsl_module

        lsl = pylsl_module()
        found = lsl.resolve_byprop("name", self.name_, 1, 30.0)
        if not found:
            return
        inlet = lsl.StreamInlet(found[0])
        deadline = time.monotonic() + 40
        while time.monotonic() < deadline and "session_end" not in self.markers:
            sample, _ = inlet.pull_sample(timeout=0.2)
            if sample is not None:
                self.markers.append(sample[0])


@pytest.mark.slow
def test_a_source_taking_over_the_name_ends_the_session_with_the_grip_held(
        files, tmp_path, capsys) -> None:
    """The player stops after 3.5 s; another player of the same name (a different
    recording, its own source_id) is already on the network."""
    name, prefix = _stream_name("takeover"), _stream_name("out")
    events = Markers(prefix + ".events")
    events.start()
    other: list[Streamer] = []
    try:
        with Streamer(files["grasp"], name, "--stop-after-s", "3.5") as a:

            def start_other() -> None:  # once the session has pinned the first player
                a.wait_for("a consumer connected")
                other.append(Streamer(files["cal"], name, "--no-wait", "--loop"))

            starter = threading.Thread(target=start_other, daemon=True)
            starter.start()
            out = tmp_path / "takeover.json"
            status = _live_status(name, files, "--imu-lsl", name + ".imu", "--outlet-prefix",
                           prefix, "--json", str(out), "--record",
                           str(tmp_path / "takeover.npz"), "--timeout-s", "8")
            starter.join(10)
            other[0].wait_for("streaming")
            sid_a, sid_b = _source_id(a, name), _source_id(other[0], name)
    finally:
        for b in other:
            b.__exit__()
    events.join(10)
    text = capsys.readouterr().out
    assert status == 0
    report = json.loads(out.read_text())
    assert report["ended"] == "source_changed"
    (change,) = report["source_changes"]
    assert change["stream"] == "emg"
    assert change["pinned"]["source_id"] == sid_a and change["found"]["source_id"] == sid_b
    assert change["found"]["host"] == local_host()
    # one line for the person, the event in the JSON, the recording and the outlet
    said = [ln for ln in text.splitlines() if "source_changed at" in ln]
    assert len(said) == 1 and sid_b in said[0] and "the hand holds its grip" in said[0]
    markers = [e["marker"] for e in report["events"]]
    assert markers.index("gap_start") < markers.index("source_changed") < \
        markers.index("session_end")
    assert "source_changed" in events.markers
    rec = load_recording(tmp_path / "takeover.npz")
    assert "source_changed" in [m for _, m in rec.metadata["events"]]
    # nothing of the other player's recording was used
    assert rec.n_samples <= 3.5 * 200
    assert np.array_equal(rec.emg, load_recording(files["grasp"]).emg[:rec.n_samples])
    t = np.array(report["traces"]["t_s"])
    grip = np.array(report["traces"]["grip_force_n"])
    gap_s = report["gaps"][0]["t_s"]
    assert gap_s == pytest.approx(3.5, abs=0.01)
    before = grip[np.flatnonzero(t < gap_s)[-1]]
    assert before > 1.0 and np.all(np.abs(grip[t >= gap_s] - before) <= 0.1 * before)
    assert report["session_s"] < gap_s + 4.0  # ended by the change, not by the timeout


@pytest.mark.slow
def test_a_one_second_imu_stall_over_loopback_holds_the_wrist_still(files, tmp_path,
                                                                     capsys) -> None:
    """The subject's arm lifts 2 s earlier than in their recording (at 3.4 s, the grip
    formed), and the IMU stream stalls for 1 s from 3.75 s, mid-lift."""
    rec = load_recording(files["grasp"])
    early = tmp_path / "early_lift.npz"
    dataclasses.replace(rec, pitch_rad=np.interp(rec.t_s + 2.0, rec.t_s, rec.pitch_rad)).save(
        early)
    name = _stream_name("stall")
    out = tmp_path / "stall.json"
    with Streamer(early, name, "--imu-dropout", "3.75:1.0"):
        assert _live_status(name, files, "--imu-lsl", name + ".imu", "--duration-s", "5.5",
                     "--json", str(out)) == 0
    text = capsys.readouterr().out
    report = json.loads(out.read_text())
    (gap,) = report["arm"]["imu_gaps"]
    assert gap["t_s"] == pytest.approx(3.76, abs=0.011)
    assert gap["duration_s"] == pytest.approx(1.0, abs=0.1)
    assert len([ln for ln in text.splitlines() if "IMU stream stalled" in ln]) == 1
    t = np.array(report["traces"]["t_s"])
    wrist = np.array(report["traces"]["wrist_height_m"])
    still = (t >= gap["t_s"] + 0.45) & (t < gap["t_s"] + gap["duration_s"] - 0.05)
    assert np.ptp(wrist[still]) < 1e-4 and 0.01 < wrist[still][0] < LIFT_HEIGHT_M - 0.01
    # the grip follows the person's sEMG, never below the can's slip force, and the can
    # stays where the stalled wrist holds it
    grip = np.array(report["traces"]["grip_force_n"])
    assert grip[still].min() > slip_threshold_n(CAN.mass_kg, CAN.friction)
    assert np.ptp(np.array(report["traces"]["object_height_m"])[still]) < 0.001
    assert report["metrics"]["outcome"] == "held" and report["ended"] == "duration"
    assert report["samples"]["lost"] == 0 and report["latency_ms"]["p99"] <= 5.0
    assert wrist[-1] == pytest.approx(LIFT_HEIGHT_M, abs=0.003)


@pytest.mark.slow
def test_live_and_the_replay_judge_a_lift_that_left_the_can_behind_alike(files, calibration,
                                                                          tmp_path) -> None:
    """Issue 33's acceptance: the person lifts the empty hand before squeezing (the can
    stays on the table), puts it down, squeezes and lifts again. ``griploop live`` goes
    on after the first lift and reports the can held after two attempts, in its JSON and
    in the ``--record`` metadata; ``griploop episode --recording`` of the same file, through
    the same trial loop, reports the same outcome and attempts."""
    from scenarios.live.recorded import GraspScript, grasp_session
    from sim.user.subjects import VirtualSubject

    cal = load_recording(files["cal"])
    two = grasp_session(VirtualSubject.sample(0, 1), CAN, mvc_cal_n=float(cal.force_n.max()),
                        duration_s=SESSION_S, rng=5, script=GraspScript(
                            rest_s=2.5, arm_moves=((0.8, 0.08), (1.7, 0.0), (5.0, 0.08))))
    path = tmp_path / "two_lifts.npz"
    two.save(path)
    name = _stream_name("two_lifts")
    with Streamer(path, name):
        report = _live(name, files, tmp_path / "live.json", "--record",
                       str(tmp_path / "received.npz"))
    m = report["metrics"]
    assert report["ended"] == "duration" and report["control_steps"] == 800
    assert (m["outcome"], m["attempts"]) == ("held", 2)
    assert m["time_to_lift_s"] > 0 and m["safety_margin_pct"] is not None
    received = load_recording(tmp_path / "received.npz")
    assert received.metadata["metrics"]["attempts"] == 2
    assert received.metadata["metrics"]["outcome"] == "held"
    off_json = tmp_path / "offline.json"
    assert main(["episode", "--recording", str(path), "--calibration", str(files["cal"]),
                 "--estimator", "ridge", "--controller", CONTROLLER, "--object", "can",
                 "--episode-s", str(SESSION_S), "--json", str(off_json)]) == 0
    offline = json.loads(off_json.read_text())["metrics"]
    assert (offline["outcome"], offline["attempts"]) == (m["outcome"], m["attempts"])


def test_an_imu_stream_without_orientation_is_refused_naming_its_channels(files,
                                                                         capsys) -> None:
    from scenarios.live.lsl import pylsl_module

    lsl = pylsl_module()
    name = _stream_name("noorient")
    emg = lsl.StreamOutlet(lsl.StreamInfo(name, "EMG", 8, 200.0, lsl.cf_int8, name))
    info = lsl.StreamInfo(name + ".imu", "IMU", 3, 50.0, lsl.cf_float32, name + ".imu")
    channels = info.desc().append_child("channels")
    for label in ("acc_x", "acc_y", "acc_z"):
        channels.append_child("channel").append_child_value("label", label)
    imu = lsl.StreamOutlet(info)
    status = _live_status(name, files, "--imu-lsl", name + ".imu", "--resolve-timeout-s", "5")
    line = _one_error_line(capsys)
    del emg, imu
    assert status == 2
    assert f"IMU stream '{name}.imu' has no orientation channel" in line
    assert "found 3 channels: 'acc_x', 'acc_y', 'acc_z'" in line


@pytest.mark.slow
def test_a_watch_tells_a_replaced_source_from_a_restarted_one() -> None:
    """By source_id when the stream has one (a streamer restarted on the same device is
    the same source), by uid when it has none (any other outlet is another source)."""
    from scenarios.live.lsl import SourceWatch, pylsl_module, resolve_stream

    lsl = pylsl_module()

    def outlet(name: str, sid: str):
        return lsl.StreamOutlet(lsl.StreamInfo(name, "EMG", 8, 200.0, lsl.cf_int8, sid))

    def wait_for(watch, replaced: bool, timeout_s: float = 6.0):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            found = watch.replacement(time.monotonic())
            if (found is not None) == replaced:
                return found
            time.sleep(0.1)
        raise AssertionError(f"replacement never {'found' if replaced else 'absent'}")

    for sid in ("armband-1", ""):
        name = _stream_name(f"watch{len(sid)}")
        first = outlet(name, sid)
        watch = SourceWatch(resolve_stream(StreamQuery(name), 10.0))
        assert wait_for(watch, False, 1.0) is None  # the pinned source is there
        del first
        again = outlet(name, sid)  # same source_id (or none) from a new outlet
        found = wait_for(watch, bool(not sid))
        if sid:
            time.sleep(1.6)  # the old outlet forgotten (1.5 s): still not replaced
            assert watch.replacement(time.monotonic() + 1) is None
        else:
            assert found.uid() != watch.uid
        watch.close()
        del again


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
                   "--timeout-s", "0.5", "--json", str(out)])
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
