"""Open contractions in a person's calibration, and the velocity paradigm live and replayed.

``griploop calibrate --open`` cues open contractions after the paper's squeezes and
labels them ``open_intent`` (its LSL session is in ``tests/scenarios/test_live.py``, with
every LSL session of the suite). A calibration with open contractions fits an open/close
decoder (:func:`scenarios.live.recorded.fit_calibration`), and the persons of a replay and
of a live session decode the armband's own channels, so ``--paradigm velocity`` runs on
them; a calibration without open contractions (a real recording of squeezes only, any
lab's CSV) is refused in one line before any stream is opened or trial run.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli.main import main
from scenarios.live.arm import OrientationChannels, PitchArm, virtual_arm_poses
from scenarios.live.calibrate import (
    OPEN_LEVELS,
    cue_levels,
    cue_schedule,
    open_from_s,
    say_cue,
)
from scenarios.live.recorded import (
    ReplaySpec,
    episode_on_recording,
    fit_calibration,
    squeeze_part,
    with_open_contractions,
)
from scenarios.live.session import LiveGrasp, SessionSettings
from scenarios.runners.trial_loop import HandSettings
from sim.hand.objects import make_object
from sim.recording import Recording, load_recording
from sim.user.subjects import VirtualSubject

CAN = make_object("can")
VELOCITY = HandSettings("self_locking", "velocity")
REFUSAL = ("paradigm velocity needs open contractions, and this calibration has none "
           "(record one with griploop calibrate --open)")
#: Whether the recording contract has the open-intent label yet (sim/recording).
HAS_OPEN_INTENT = "open_intent" in {f.name for f in dataclasses.fields(Recording)}
needs_open_intent = pytest.mark.skipif(
    not HAS_OPEN_INTENT or not hasattr(VirtualSubject, "open_session"),
    reason="needs Recording.open_intent and VirtualSubject.open_session (sim/)")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A virtual subject's calibration of squeezes only and their grasp of the can."""
    out = tmp_path_factory.mktemp("live_open")
    assert main(["subjects", "--n", "1", "--out", str(out), "--grasp", "can",
                 "--grasp-s", "9"]) == 0
    cal = load_recording(out / "subject01.npz")
    csv = out / "lab.csv"  # a lab's CSV of the same squeezes: no open-intent column
    dataclasses.replace(cal, intent=None, intent_force_n=None).save_csv(csv)
    return {"cal": out / "subject01.npz", "grasp": out / "subject01_grasp.npz", "csv": csv,
            "dir": out}


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0] and "internal error" not in err[0]
    return err[0]


# ----------------------------------------------------------------------------- the cues
def test_open_cues_follow_the_squeezes_and_label_only_the_open_intent() -> None:
    squeezes, paper_s = cue_schedule()
    cues, duration = cue_schedule(open_levels=OPEN_LEVELS)
    assert cues[:len(squeezes)] == squeezes  # the paper's session unchanged, then the opens
    assert duration == paper_s + 3 * (4.0 + 4.0) == 52.0
    assert [c.label for c in cues[len(squeezes):]] == [
        "open small", "rest", "open medium", "rest", "open strong", "rest"]
    assert open_from_s(cues) == paper_s and open_from_s(squeezes) is None
    t = np.array([3.5, 20.0, 29.0, 33.0, 37.0, 41.0, 45.0, 49.0, 51.9])
    assert cue_levels(cues, t).tolist() == [0.25, 0.9] + [0.0] * 7
    assert cue_levels(cues, t, "open").tolist() == [0.0, 0.0, 0.3, 0.0, 0.6, 0.0, 1.0, 0.0,
                                                    0.0]
    line = say_cue(cues[len(squeezes)])
    assert line.startswith("[ 28.0 s] OPEN SMALL: open your hand") and "30 %" in line
    assert "hold it for 4 s" in line


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("which", ["cal", "csv"])
def test_velocity_on_a_calibration_of_squeezes_only_is_refused_before_any_stream(
        files, which, capsys) -> None:
    """No stream of that name exists: the refusal comes before the stream is looked for."""
    path = files[which]
    status = main(["live", "--lsl", "griploop.test.nostream", "--calibration", str(path),
                   "--controller", "pid", "--object", "can", "--paradigm", "velocity",
                   "--no-video", "--resolve-timeout-s", "0.5"])
    line = _one_error_line(capsys)
    assert status == 2
    assert line.endswith(f"--calibration {path}: {REFUSAL}"), line


def test_a_replay_with_velocity_on_squeezes_only_is_refused_in_one_line(files,
                                                                         capsys) -> None:
    for extra, needed_by in ((["--paradigm", "velocity"], "paradigm velocity"),
                             (["--paradigm", "velocity", "--decoder", "two_site"],
                              "paradigm velocity"),
                             (["--decoder", "two_site"], "decoder two_site")):
        status = main(["episode", "--recording", str(files["grasp"]), "--calibration",
                       str(files["cal"]), "--estimator", "ridge", "--controller", "pid",
                       "--object", "can", *extra])
        line = _one_error_line(capsys)
        assert status == 2
        assert line.endswith(f"--calibration {files['cal']}: {needed_by} needs open "
                             "contractions, and this calibration has none (record one with "
                             "griploop calibrate --open)"), line


def test_an_unknown_decoder_is_refused_naming_the_known_ones(files, capsys) -> None:
    status = main(["episode", "--recording", str(files["grasp"]), "--calibration",
                   str(files["cal"]), "--estimator", "ridge", "--controller", "pid",
                   "--object", "can", "--decoder", "nosuch"])
    line = _one_error_line(capsys)
    assert status == 2 and "--decoder" in line and "two_site" in line and "pattern" in line


# ------------------------------------------------------------------ with open contractions
@pytest.fixture(scope="module")
def opened(files, tmp_path_factory) -> dict:
    """The subject's squeezes then open contractions, as ``calibrate --open`` lays them out,
    and a grasp of the can that ends with an opening contraction."""
    if not HAS_OPEN_INTENT or not hasattr(VirtualSubject, "open_session"):
        pytest.skip("needs Recording.open_intent and VirtualSubject.open_session (sim/)")
    out = tmp_path_factory.mktemp("opened")
    subject = VirtualSubject.sample(0, 1)
    squeezes = load_recording(files["cal"])
    cal = with_open_contractions(squeezes, subject.open_session(11))
    cal_path = out / "cal_open.npz"
    cal.save(cal_path)
    grasp = load_recording(files["grasp"])
    let_go = _grasp_then_open(subject, grasp, open_at_s=6.0)
    grasp_path = out / "grasp_open.npz"
    let_go.save(grasp_path)
    return {"cal": cal_path, "grasp": grasp_path, "open_at_s": 6.0, "squeezes": squeezes}


def _grasp_then_open(subject: VirtualSubject, grasp: Recording, *, open_at_s: float
                     ) -> Recording:
    """The grasp recording's squeeze, then from ``open_at_s`` the subject relaxes and opens
    (an opening contraction at 80 % of their largest); the forearm stays at rest (the can
    stays on the table: the trial runs its whole duration)."""
    from sim.user.causal import CausalSession

    fs, n = grasp.fs_hz, grasp.n_samples
    t = np.arange(n) / fs
    close = np.where(t < open_at_s, grasp.intent, 0.0)
    opening = np.where(t >= open_at_s, 0.8, 0.0)
    session = CausalSession(subject, n, generator="noise", fs_hz=fs,
                            rng=np.random.default_rng(3))
    emg = session.advance(close, open_intent=opening)
    return Recording(emg=emg, fs_hz=fs, intent=close, open_intent=opening,
                     pitch_rad=np.zeros(n), metadata=dict(grasp.metadata),
                     source="grasp_then_open")


@needs_open_intent
def test_the_estimator_sees_the_squeezes_and_the_decoder_the_whole_calibration(
        files, opened) -> None:
    cal_rec = load_recording(opened["cal"])
    assert cal_rec.metadata["open_from_s"] == pytest.approx(opened["squeezes"].duration_s)
    assert squeeze_part(cal_rec).n_samples == opened["squeezes"].n_samples
    plain = fit_calibration(opened["squeezes"], "ridge")
    both = fit_calibration(cal_rec, "ridge", decoder="pattern")
    # the paper's fit, unchanged by the open contractions after it
    assert both.calibration.r2 == plain.calibration.r2
    assert both.calibration.mvc_cal_n == plain.calibration.mvc_cal_n
    assert plain.decoder is None and both.decoder.n_features_in_ == 8
    assert both.summary()["decoder"] == "pattern" and "decoder" not in plain.summary()


@needs_open_intent
def test_a_replay_with_velocity_opens_the_hand_after_the_recorded_opening(
        opened, tmp_path, capsys) -> None:
    out = tmp_path / "velocity.json"
    status = main(["episode", "--recording", str(opened["grasp"]), "--calibration",
                   str(opened["cal"]), "--estimator", "ridge", "--controller", "pid",
                   "--object", "can", "--paradigm", "velocity", "--drive", "self_locking",
                   "--episode-s", "8", "--json", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    assert "paradigm velocity (pattern decoder), self_locking drive" in text
    report = json.loads(out.read_text())
    assert (report["paradigm"], report["decoder"], report["drive"]) == (
        "velocity", "pattern", "self_locking")
    m = report["metrics"]  # every 125 ms from the first full 400 ms window
    assert m["decoder_windows"] == int((8.0 - 0.4) / 0.125) + 1
    assert isinstance(m["unrequested_opens"], int) and "unrequested_opens" in text
    t = np.asarray(report["traces"]["t_s"])
    grip = np.asarray(report["traces"]["grip_force_n"])
    command = np.asarray(report["traces"]["command"])
    before = (t > opened["open_at_s"] - 1.5) & (t < opened["open_at_s"])
    assert grip[before].min() > 1.0  # held by the close signal
    # within a second of the opening contraction the motor opens the hand and lets go
    after = t >= opened["open_at_s"] + 1.0
    assert command[(t >= opened["open_at_s"]) & ~after].min() < 0.0
    assert grip[after].max() < 0.5


@needs_open_intent
def test_the_live_core_runs_velocity_on_the_armbands_channels_as_the_replay_does(
        opened) -> None:
    rec = load_recording(opened["grasp"])
    cal = fit_calibration(load_recording(opened["cal"]), "ridge", decoder="pattern")
    spec = ReplaySpec(controller="pid", episode_s=8.0, hand=VELOCITY)
    replay = episode_on_recording(rec, cal, CAN, spec)
    arm = PitchArm(virtual_arm_poses(forearm_m=rec.metadata["forearm_m"]),
                   OrientationChannels("pitch", (0,)), imu_fs_hz=rec.fs_hz)
    grasp = LiveGrasp(cal, CAN, arm=arm, controller="pid",
                      settings=SessionSettings(duration_s=8.0, hand=VELOCITY))
    assert grasp.decoded is not None and grasp.decoded.open == 0.0
    grasp.start()
    for i in range(rec.n_samples):
        now, stamp = time.perf_counter(), np.array([i / rec.fs_hz])
        grasp.feed_imu(rec.pitch_rad[i:i + 1, None], stamp, now)
        grasp.feed(rec.emg[i:i + 1], stamp, now)
        if grasp.finished:
            break
    for key in ("reference_n", "grip_force_n", "command"):
        np.testing.assert_array_equal(grasp.traces[key], replay.traces[key], err_msg=key)
    report = grasp.report()
    assert report["decoder"] == "pattern"
    # the same windows decoded; only the replay of a virtual subject knows their open intent
    assert report["metrics"]["decoder_windows"] == replay.metrics["decoder_windows"] > 0
    assert report["metrics"]["unrequested_opens"] is None
    assert isinstance(replay.metrics["unrequested_opens"], int)
    # while the hand holds its grip through a fault the decoded signals are relaxed
    grasp.holding = True
    assert (grasp.decoded.close, grasp.decoded.open) == (0.0, 0.0)
