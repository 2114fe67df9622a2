"""A recording replayed in a trial: its sEMG drives the hand and its recorded forearm moves it.

The replay (``griploop episode --recording``, the deploy check) runs the one trial loop
with a :class:`~scenarios.live.recorded.RecordedPerson`: the wrist follows the
recording's ``pitch_rad`` through the live session's arm mapping, and only a recording
without a pitch lifts on the scripted user's schedule. The live session of the same
file, over LSL, is in ``tests/scenarios/test_live.py``.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli.main import main
from scenarios.live.arm import ArmPoses
from scenarios.live.errors import ArmPosesError
from scenarios.live.recorded import (
    GraspScript,
    ReplaySpec,
    episode_on_recording,
    fit_calibration,
    grasp_session,
)
from sim.hand.objects import make_object
from sim.recording import load_recording
from sim.user.subjects import VirtualSubject

CAN = make_object("can")
SPEC = ReplaySpec(controller="pid", episode_s=8.0)
#: The person lifts the empty hand first (the can stays on the table), puts it down,
#: squeezes from about 2.5 s and lifts again at 5 s.
TWO_LIFTS = GraspScript(rest_s=2.5, arm_moves=((0.8, 0.08), (1.7, 0.0), (5.0, 0.08)))


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("replay")
    assert main(["subjects", "--n", "1", "--out", str(out)]) == 0
    cal = load_recording(out / "subject01.npz")
    two = grasp_session(VirtualSubject.sample(0, 1), CAN, mvc_cal_n=float(cal.force_n.max()),
                        duration_s=8.0, rng=5, script=TWO_LIFTS)
    one = grasp_session(VirtualSubject.sample(0, 1), CAN, mvc_cal_n=float(cal.force_n.max()),
                        duration_s=8.0, rng=5)
    paths = {"cal": out / "subject01.npz", "two": out / "two_lifts.npz",
             "one": out / "one_lift.npz", "dir": out}
    two.save(paths["two"])
    one.save(paths["one"])
    return paths


@pytest.fixture(scope="module")
def calibration(files):
    return fit_calibration(load_recording(files["cal"]), "ridge")


def test_a_lift_that_leaves_the_can_behind_is_an_attempt_and_the_replay_goes_on(
        files, calibration) -> None:
    result = episode_on_recording(load_recording(files["two"]), calibration, CAN, SPEC)
    m, t = result.metrics, result.traces["t_s"]
    assert m["outcome"] == "held" and m["attempts"] == 2
    assert t.size == 800  # the first lift did not end the trial
    wrist = result.traces["wrist_height_m"]
    assert wrist[t < 0.8].max() == 0.0 and wrist[(t > 1.5) & (t < 1.7)].min() > 0.07
    assert result.referee.secure_lift_s > 5.0  # the second lift carried the can


def test_the_wrist_follows_the_recorded_forearm_not_a_clock(files, calibration) -> None:
    rec = load_recording(files["one"])
    lift_s = rec.metadata["arm_lift_s"]
    result = episode_on_recording(rec, calibration, CAN, SPEC)
    t, wrist = result.traces["t_s"], result.traces["wrist_height_m"]
    first = float(t[np.flatnonzero(wrist > 0.0)[0]])
    # the forearm rises past the arm mapping's dead band (5 % of the way) 0.14 s into its
    # 0.6 s lift; the low-pass and the wrist's follow add a few tens of ms
    assert lift_s + 0.1 <= first <= lift_s + 0.3
    assert result.metrics["outcome"] == "held" and result.metrics["attempts"] == 1
    # the same recording without its pitch: the scripted lift, at 8 - 2 - 0.6 s
    bare = episode_on_recording(dataclasses.replace(rec, pitch_rad=None), calibration, CAN,
                                SPEC)
    t, wrist = bare.traces["t_s"], bare.traces["wrist_height_m"]
    assert float(t[np.flatnonzero(wrist > 0.0)[0]]) == pytest.approx(5.4)


def test_a_pitch_without_poses_to_map_it_is_refused_naming_the_column(files,
                                                                      calibration) -> None:
    rec = load_recording(files["one"])
    bare_meta = dataclasses.replace(rec, metadata={"protocol": "grasp_lift_hold"})
    with pytest.raises(ArmPosesError, match="column pitch_rad has no arm poses"):
        episode_on_recording(bare_meta, calibration, CAN, SPEC)
    given = episode_on_recording(bare_meta, calibration, CAN, SPEC,
                                 poses=ArmPoses.from_text("0:17.2"))
    assert given.metrics["attempts"] == 1


@pytest.mark.parametrize("bad, expected", [
    ("nan", "column 'pitch_rad' has NaN or inf at data row 200"),
    ("9.0", "pitch_rad: expected |values| <= 3.14159")])
def test_a_malformed_pitch_is_refused_in_one_line_naming_the_column(files, tmp_path, capsys,
                                                                    bad, expected) -> None:
    rec = load_recording(files["one"])
    path = tmp_path / "bad.csv"
    rec.save_csv(path)
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    column = head.index("pitch_rad")
    row = lines[200].split(",")
    row[column] = bad
    lines[200] = ",".join(row)
    path.write_text("\n".join(lines) + "\n")
    status = main(["episode", "--recording", str(path), "--calibration", str(files["cal"]),
                   "--estimator", "ridge", "--controller", "pid", "--object", "can"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and expected in err[0], err


def test_episode_on_a_recording_reports_the_trials_metrics(files, tmp_path, capsys) -> None:
    out = tmp_path / "episode.json"
    assert main(["episode", "--recording", str(files["two"]), "--calibration",
                 str(files["cal"]), "--estimator", "ridge", "--controller", "pid", "--object",
                 "can", "--episode-s", "8", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "the wrist follows the recorded forearm's pitch" in text
    report = json.loads(out.read_text())
    assert report["arm"] == "pitch"
    for key in ("outcome", "attempts", "time_to_lift_s", "safety_margin_pct", "released"):
        assert key in report["metrics"], key
    assert (report["metrics"]["outcome"], report["metrics"]["attempts"]) == ("held", 2)


def test_arm_poses_for_a_replay_are_checked_in_one_line(files, capsys) -> None:
    status = main(["episode", "--recording", str(files["one"]), "--calibration",
                   str(files["cal"]), "--estimator", "ridge", "--controller", "pid",
                   "--object", "can", "--arm-poses", "0:1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "--arm-poses" in err[0] and "5 deg" in err[0]
    assert main(["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
                 "--arm-poses", "0:17"]) == 2
    assert "expected with --recording" in capsys.readouterr().err
