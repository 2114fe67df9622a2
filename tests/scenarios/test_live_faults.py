"""Live sessions a lab can trust (issue 29): the stream the person chose, the same source for
the whole session, and the person's own arm deciding the lift.

Unit tests of the stream identity and of the arm, then the live core fed
deterministically (a stall of the IMU, a key). The same faults over LSL loopback (two
outlets of one name, an outlet that dies while another source takes over its name, a
1 s stall of the IMU stream) are in test_live.py, so that the suite's workers never run
two real-time sessions at once.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path

import numpy as np
import pytest

from controllers.bounds import slip_threshold_n
from scenarios.cli.main import main
from scenarios.live.arm import (
    DEAD_BAND,
    LIFT_HEIGHT_M,
    ArmPoses,
    KeyArm,
    LineKeys,
    OrientationChannels,
    PitchArm,
    forearm_pitch_rad,
    pitch_of_quaternion,
    virtual_arm_poses,
)
from scenarios.live.errors import (
    AmbiguousStreamError,
    ImuChannelError,
    RemoteStreamError,
    StreamNotFoundError,
)
from scenarios.live.hooks import SessionHooks
from scenarios.live.lsl import (
    StreamQuery,
    choose_stream,
    local_host,
    outlet_source_id,
)
from scenarios.live.player import quaternion_of_pitch
from scenarios.live.recorded import fit_calibration
from scenarios.live.session import LiveGrasp, SessionSettings
from sim.hand.objects import make_object
from sim.hand.wrist import min_jerk
from sim.recording import load_recording

CAN = make_object("can")
CONTROLLER = "mpc"


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A virtual subject's calibration (with arm poses) and grasp (with the forearm's pitch)."""
    out = tmp_path_factory.mktemp("live29")
    assert main(["subjects", "--n", "1", "--out", str(out), "--grasp", "can",
                 "--grasp-s", "9"]) == 0
    return {"cal": out / "subject01.npz", "grasp": out / "subject01_grasp.npz", "dir": out}


@pytest.fixture(scope="module")
def calibration(files):
    return fit_calibration(load_recording(files["cal"]), "ridge")


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


# ----------------------------------------------------------------------------- identity
@dataclasses.dataclass
class FakeInfo:
    """What :func:`choose_stream` reads of a pylsl.StreamInfo."""

    host: str
    sid: str
    stream: str = "myo"
    n: int = 8

    def name(self) -> str:
        return self.stream

    def hostname(self) -> str:
        return self.host

    def source_id(self) -> str:
        return self.sid

    def type(self) -> str:
        return "EMG"

    def channel_count(self) -> int:
        return self.n

    def nominal_srate(self) -> float:
        return 200.0

    def channel_format(self) -> int:
        return 6  # pylsl.cf_int8


def test_a_name_several_streams_share_is_refused_listing_each_one() -> None:
    streams = [FakeInfo("lab-pc", "griploop:myo@lab-pc:1.a.1"),
               FakeInfo("lab-pc", "armband-7f3a")]
    with pytest.raises(AmbiguousStreamError) as exc:
        choose_stream(streams, StreamQuery("myo"), here="lab-pc")
    line = str(exc.value)
    assert "\n" not in line and line.startswith("2 LSL streams match 'myo': ")
    for s in streams:
        assert f"host 'lab-pc', source_id {s.sid!r} (EMG, 8 ch, 200 Hz, int8)" in line
    # the host alone does not tell two streams of one host apart
    with pytest.raises(AmbiguousStreamError):
        choose_stream(streams, StreamQuery("myo", host="lab-pc"), here="lab-pc")
    assert choose_stream(streams, StreamQuery("myo", source_id="armband-7f3a"),
                         here="lab-pc") is streams[1]


def test_a_stream_from_another_host_is_refused_unless_allowed() -> None:
    streams = [FakeInfo("rig-2", "armband-7f3a")]
    with pytest.raises(RemoteStreamError, match="comes from another host than this one "
                       "\\('lab-pc'\\); LSL has no authentication"):
        choose_stream(streams, StreamQuery("myo"), here="lab-pc")
    allowed = StreamQuery.parse("myo@rig-2", allow_remote=True)
    assert choose_stream(streams, allowed, here="lab-pc") is streams[0]
    both = [FakeInfo("lab-pc", "a"), FakeInfo("rig-2", "b")]
    assert choose_stream(both, StreamQuery.parse("myo@lab-pc"), here="lab-pc") is both[0]
    with pytest.raises(StreamNotFoundError, match="no LSL stream 'myo' on host 'rig-3'; the "
                       "streams named 'myo' are: host 'lab-pc', source_id 'a'"):
        choose_stream(both, StreamQuery.parse("myo@rig-3"), here="lab-pc")


@pytest.mark.parametrize(("argv", "flag", "expected"), [
    (["--lsl", "myo@"], "--lsl", "expected NAME or NAME@HOST"),
    (["--lsl", "@lab-pc"], "--lsl", "expected NAME or NAME@HOST"),
    (["--lsl", "myo", "--lsl-source-id", "two words"], "--lsl-source-id",
     "expected a source_id of 1 to 255 printable characters without spaces or quotes"),
    (["--lsl", "myo", "--lsl-source-id", "it's"], "--lsl-source-id", "without spaces or quotes"),
    (["--lsl", "myo", "--imu-lsl", "myo.imu@"], "--imu-lsl", "expected NAME or NAME@HOST"),
])
def test_stream_names_and_source_ids_of_the_wrong_form_are_refused_in_one_line(
        files, argv, flag, expected, capsys) -> None:
    for command in (["live", "--calibration", str(files["cal"]), "--controller", CONTROLLER,
                     "--object", "can"], ["calibrate", "--out", "unused.npz"]):
        assert main([*command, *argv]) == 2
        line = _one_error_line(capsys)
        assert line.startswith(f"griploop: {flag}: ") or f" {flag}: " in line, line
        assert expected in line


def test_each_outlet_has_its_own_source_id_naming_host_and_process() -> None:
    a, b = outlet_source_id("myo"), outlet_source_id("myo")
    assert a != b
    for sid in (a, b):
        assert sid.startswith(f"griploop:myo@{local_host()}:{os.getpid()}.")


def test_live_with_an_imu_needs_arm_poses(files, tmp_path, capsys) -> None:
    bare = tmp_path / "cal_no_arm.npz"
    rec = load_recording(files["cal"])
    rec.metadata.pop("arm_poses")
    rec.save(bare)
    base = ["live", "--lsl", "x", "--imu-lsl", "x.imu", "--controller", CONTROLLER,
            "--object", "can"]
    assert main([*base, "--calibration", str(bare)]) == 2
    line = _one_error_line(capsys)
    assert "has no arm poses" in line and "--arm-poses REST_DEG:RAISED_DEG" in line
    assert main([*base, "--calibration", str(bare), "--arm-poses", "0:2"]) == 2
    assert "differs from the rest pose by 2.0 deg; expected at least 5 deg" in \
        _one_error_line(capsys)


# ----------------------------------------------------------------------------- the arm
def test_the_pitch_of_a_quaternion_is_its_rotation_about_y() -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(29)
    q = rng.normal(size=(200, 4)) * rng.uniform(0.5, 2e4, size=(200, 1))  # any scale
    # scipy's intrinsic z-y'-x'' angles, from its own quaternion (x, y, z, w) order
    expected = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_euler("ZYX")[:, 1]
    np.testing.assert_allclose(pitch_of_quaternion(q), expected, atol=1e-9)
    pitch = rng.uniform(-1.4, 1.4, 50)
    np.testing.assert_allclose(pitch_of_quaternion(quaternion_of_pitch(pitch)), pitch,
                               atol=1e-12)
    assert np.isnan(pitch_of_quaternion(np.zeros((1, 4))))[0]


def test_orientation_channels_are_found_by_label_or_refused_naming_the_channels() -> None:
    quat = OrientationChannels.find(["acc_x", "Quat_W", "quat_x", "quat_y", "quat_z"])
    assert quat.kind == "quaternion" and quat.index == (1, 2, 3, 4)
    x = np.c_[np.zeros(3), quaternion_of_pitch(np.array([0.1, 0.2, -0.3]))]
    np.testing.assert_allclose(quat.pitch_rad(x), [0.1, 0.2, -0.3], atol=1e-12)
    deg = OrientationChannels.find(["roll", "pitch", "yaw"], ["deg", "deg", "deg"])
    np.testing.assert_allclose(deg.pitch_rad(np.array([[5.0, 30.0, 0.0]])), [math.pi / 6])
    assert OrientationChannels.find(["Pitch_rad"]).rad_per_unit == 1.0
    strings = OrientationChannels.find(["pitch"]).pitch_rad(np.array([["0.5"], ["n/a"]]))
    assert strings[0] == 0.5 and np.isnan(strings[1])
    with pytest.raises(ImuChannelError) as exc:
        OrientationChannels.find(["acc_x", "acc_y", "acc_z", ""], stream="IMU stream 'myo.imu'")
    assert str(exc.value) == (
        "IMU stream 'myo.imu' has no orientation channel: expected a channel labelled pitch "
        "(rad, or deg by its unit) or four labelled qw, qx, qy, qz; found 4 channels: "
        "'acc_x', 'acc_y', 'acc_z', (unlabelled)")


def test_arm_poses_map_the_pitch_to_the_wrist_height() -> None:
    poses = ArmPoses(-0.1, 0.2)
    for pitch in (-0.3, -0.1, -0.1 + 0.3 * DEAD_BAND, 0.0, 0.05, 0.2, 0.5, 2.0):
        u = (pitch + 0.1) / 0.3  # the share of the way up, computed here
        expected = min(max(LIFT_HEIGHT_M * (u - DEAD_BAND) / (1 - DEAD_BAND), 0.0), 0.2)
        assert poses.height_m(pitch) == pytest.approx(expected, abs=1e-12), pitch
    assert ArmPoses(0.2, -0.1).height_m(-0.1) == pytest.approx(LIFT_HEIGHT_M)  # sign free
    assert poses.height_m(math.nan) == 0.0
    virtual = virtual_arm_poses()
    assert virtual.height_m(float(forearm_pitch_rad(LIFT_HEIGHT_M))) == pytest.approx(
        LIFT_HEIGHT_M)
    assert ArmPoses.from_metadata({}, "f") is None
    assert ArmPoses.from_metadata({"arm_poses": virtual.to_metadata()}, "f") == virtual


def test_line_keys_count_presses_without_blocking() -> None:
    r, w = os.pipe()
    keys = LineKeys(os.fdopen(r))
    assert keys.presses() == 0 and keys.closed is None  # nothing typed: no wait
    os.write(w, b"\n\n")
    deadline = time.monotonic() + 5
    got = 0
    while got < 2 and time.monotonic() < deadline:
        got += keys.presses()
        time.sleep(0.01)
    assert got == 2
    os.close(w)
    while keys.closed is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert keys.closed == "end of input" and keys.presses() == 0


# ----------------------------------------------------------------------------- the core
def _run_core(files, calibration, arm, *, duration_s=8.0, imu_skip=(math.inf, math.inf)):
    """Feed the grasp recording sample by sample (its pitch as 50 Hz quaternions, skipped
    in ``imu_skip``), the wall clock ticking four times a sample period."""
    rec = load_recording(files["grasp"])
    fs, now = rec.fs_hz, [0.0]
    q = quaternion_of_pitch(rec.pitch_rad).astype(np.float32)
    grasp = LiveGrasp(calibration, CAN, arm=arm, controller=CONTROLLER,
                      settings=SessionSettings(duration_s=duration_s),
                      hooks=SessionHooks(clock=lambda: now[0]))
    grasp.start()
    for i in range(rec.n_samples):
        for sub in (3, 2, 1):
            now[0] = (i - sub / 4) / fs
            grasp.tick(now[0])
        now[0] = i / fs
        if hasattr(arm, "feed") and i % 4 == 0 and not imu_skip[0] <= i / fs < imu_skip[1]:
            grasp.feed_imu(q[i:i + 1], np.array([i / fs]), now[0])
        grasp.feed(rec.emg[i:i + 1], np.array([i / fs]), now[0])
        grasp.tick(now[0])
        if grasp.finished:
            break
    return grasp, grasp.report(), rec


def _pitch_arm() -> PitchArm:
    return PitchArm(virtual_arm_poses(), OrientationChannels("quaternion", (0, 1, 2, 3)),
                    imu_fs_hz=50.0)


def test_the_wrist_follows_the_subjects_forearm(files, calibration) -> None:
    grasp, report, rec = _run_core(files, calibration, _pitch_arm())
    lift_s = rec.metadata["arm_lift_s"]
    t, wrist = grasp.traces["t_s"], grasp.traces["wrist_height_m"]
    # the arm, mapped here: 0 below the dead band, then the share of the way up
    arm = np.array([virtual_arm_poses().height_m(p) for p in rec.pitch_rad])
    assert np.all(wrist[t < lift_s] == 0.0)  # the noise at rest moves nothing
    first = report["arm"]["lift_start_s"]
    assert lift_s + 0.1 <= first <= lift_s + 0.25
    late = t > 6.5  # raised: the wrist at the arm's height, trembling less than the IMU
    held = arm[np.round(t[late] * rec.fs_hz).astype(int)]
    assert abs(np.mean(wrist[late]) - np.mean(held)) < 5e-4
    assert np.max(np.abs(wrist[late] - LIFT_HEIGHT_M)) < 0.002
    assert np.std(wrist[late]) < 0.5 * np.std(held)
    m = report["metrics"]
    assert m["outcome"] == "held" and m["slip_events"] <= 2
    assert report["arm"]["secure_lift_s"] is not None and m["hold_grip_n"] is not None
    assert [e["marker"] for e in report["events"]].count("lift") == 1


def test_an_imu_stall_holds_the_wrist_still_and_the_hand_its_grip(files, calibration) -> None:
    """No orientation from 5.75 s to 6.75 s, mid-lift: the wrist stops where the arm was
    last seen, the hand keeps its grip, the wrist rejoins the arm afterwards."""
    grasp, report, rec = _run_core(files, calibration, _pitch_arm(), imu_skip=(5.75, 6.75))
    t, wrist = grasp.traces["t_s"], grasp.traces["wrist_height_m"]
    (gap,) = report["arm"]["imu_gaps"]
    assert gap["t_s"] == pytest.approx(5.76, abs=1e-6)  # the first sample not sent
    assert gap["duration_s"] == pytest.approx(1.0, abs=0.01)
    markers = [e["marker"] for e in report["events"]]
    assert markers.index("imu_gap_start") < markers.index("imu_gap_end")
    still = (t >= 5.76 + 0.45) & (t < 6.75)  # once it has caught up with the last sample
    assert np.ptp(wrist[still]) < 5e-5
    seen = np.array([virtual_arm_poses().height_m(p) for p in rec.pitch_rad])
    last = int(round(5.74 * rec.fs_hz))  # where the arm was last seen, and 0.1 s before
    assert seen[last - 20] - 0.002 <= wrist[still][0] <= seen[last] + 0.002
    assert 0.01 < wrist[still][0] < LIFT_HEIGHT_M - 0.01  # stopped mid-lift
    # the grip is the person's and the controller's, untouched by the stall: it never
    # opens below where it was, nor below the can's slip force, and the can stays put
    grip = grasp.traces["grip_force_n"]
    before = grip[np.flatnonzero(t < 5.76)[-1]]
    assert grip[still].min() >= 0.9 * before > slip_threshold_n(CAN.mass_kg, CAN.friction)
    assert np.ptp(grasp.traces["object_height_m"][still]) < 0.001  # held still in the air
    assert report["metrics"]["outcome"] == "held" and report["ended"] == "duration"
    assert wrist[-1] == pytest.approx(LIFT_HEIGHT_M, abs=0.002)  # rejoined the arm


def test_a_key_lifts_the_wrist_and_puts_it_down(files, calibration) -> None:
    presses, at = [], iter((5.4, 7.0))
    nxt = [next(at)]
    clock_t = [0.0]

    def pressed() -> int:  # one press at 5.4 s and one at 7.0 s of session time
        if clock_t[0] >= nxt[0] - 1e-9:
            presses.append(clock_t[0])
            nxt[0] = next(at, math.inf)
            return 1
        return 0

    arm = KeyArm(pressed)
    command = arm.command

    def timed(t_s, setpoint_m):
        clock_t[0] = t_s
        return command(t_s, setpoint_m)

    arm.command = timed
    grasp, report, _ = _run_core(files, calibration, arm)
    t, wrist = grasp.traces["t_s"], grasp.traces["wrist_height_m"]
    up, down = presses
    # the set-point reported after each step: the scripted lift's path, computed here
    expected = np.where(t + 0.01 < down,
                        [LIFT_HEIGHT_M * min_jerk((x + 0.01 - up) / 0.6) for x in t],
                        [LIFT_HEIGHT_M * (1 - min_jerk((x + 0.01 - down) / 0.6)) for x in t])
    np.testing.assert_allclose(wrist, expected, atol=1e-12)
    markers = [e["marker"] for e in report["events"]]
    assert markers.index("key_lift") < markers.index("lift") < markers.index("key_lower")
    assert report["arm"]["presses"] == 2 and report["arm"]["lift_start_s"] == pytest.approx(up)
    assert report["metrics"]["outcome"] == "held"  # carried up and put down again


def test_a_session_the_referee_ends_holds_the_grip_and_says_why(files, calibration) -> None:
    """The can's grasp squeezes an egg (it breaks at 2.5 N): the referee ends the session at
    the break, the hand holds its grip from then on, and the report says why."""
    egg = make_object("egg")
    rec = load_recording(files["grasp"])
    grasp = LiveGrasp(calibration, egg, arm=_pitch_arm(), controller=CONTROLLER,
                      settings=SessionSettings(duration_s=8.0),
                      hooks=SessionHooks(clock=lambda: 0.0))
    grasp.start()
    q = quaternion_of_pitch(rec.pitch_rad).astype(np.float32)
    for i in range(rec.n_samples):
        grasp.feed_imu(q[i:i + 1], np.array([i / rec.fs_hz]), 0.0)
        grasp.feed(rec.emg[i:i + 1], np.array([i / rec.fs_hz]), 0.0)
        if grasp.finished:
            break
    report = grasp.report()
    assert report["ended"] == "crushed" and report["metrics"]["outcome"] == "crushed"
    assert report["control_steps"] < 800 and grasp.holding
    assert report["held_grip_n"] == grasp.hold_n <= max(report["traces"]["reference_n"])
    assert [e["marker"] for e in report["events"]][-2:] == ["crush", "session_end"]
