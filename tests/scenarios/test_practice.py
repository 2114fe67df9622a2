"""Practice: deterministic, cached per subject and interface, rebuilt when stale or corrupt."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.runners import practice as P
from scenarios.runners.calibration import CalibrationSettings
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.runners.trial_outcome import TrialReferee
from sim.hand.objects import make_object
from sim.user.belief import ProsthesisBelief
from sim.user.operator import OperatorParams
from sim.user.subjects import VirtualSubject

SUBJECT = VirtualSubject.sample(0, 2)
SETTINGS = CalibrationSettings("oracle", "free_run")


def _interface(**kw) -> P.Interface:
    return P.Interface(SETTINGS, "pid", {}, make_object("can"), "reacting", "none",
                       OperatorParams(**kw), 0.01, 30.0)


def _belief(seed: int = 3, **kw) -> ProsthesisBelief:
    cal_seq, practice_seq = np.random.SeedSequence(seed).spawn(2)
    return P.practised_belief(SUBJECT, SETTINGS.fit(SUBJECT, cal_seq), _interface(**kw),
                              cal_seq=cal_seq, n_lifts=2, seed_seq=practice_seq, trial_s=15.0)


def test_an_unwritable_cache_warns_once_and_the_user_still_practises(tmp_path, monkeypatch):
    import warnings

    from sim.cache import CacheNotWritableWarning

    learnt = ProsthesisBelief.novice(OperatorParams())
    practised = []
    monkeypatch.setattr(P, "_practise", lambda *args: practised.append(args) or learnt)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(blocker))  # its "practice" cannot be made
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert _belief() is learnt and _belief(seed=4) is learnt
    said = [w for w in caught if issubclass(w.category, CacheNotWritableWarning)]
    assert len(said) == 1 and "practice" in str(said[0].message) and len(practised) == 2


def test_practice_is_deterministic_cached_and_rebuilt_when_corrupt(tmp_path, monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", "off")
    fresh = _belief()
    assert fresh == _belief() and fresh.lifts == 2
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    built = _belief()
    files = list((tmp_path / "practice").glob("*.json"))
    assert built == fresh and len(files) == 1
    stored = json.loads(files[0].read_text())
    assert ProsthesisBelief.from_dict(stored["belief"]) == fresh

    def refuse(*args, **kwargs):
        raise AssertionError("practised again although the cache holds it")

    with monkeypatch.context() as m:
        m.setattr(P, "_practise", refuse)
        assert _belief() == fresh  # read from the cache
    for bad in ("{not json", json.dumps({**stored, "key": "0" * 64}),
                json.dumps({**stored, "belief": {"gain": "nan", "uncertainty": 1, "lifts": 2}})):
        files[0].write_text(bad)
        assert _belief() == fresh  # stale or corrupt: rebuilt, never trusted
        assert json.loads(files[0].read_text())["key"] == stored["key"]
    _belief(seed=4)  # another session, and other parameters: practised and stored apart
    _belief(dwell_s=0.5)
    assert len(list((tmp_path / "practice").glob("*.json"))) == 3


def test_a_user_who_does_not_learn_and_practice_zero_are_the_novice() -> None:
    novice = run_episode(SUBJECT, make_object("can"), EpisodeSpec(estimator="oracle", seed=1,
                                                                  practice=0))
    assert novice.row["practice"] == 0 and novice.row["belief_gain"] == 1.0
    assert novice.row["belief_margin_pct"] == pytest.approx(100 * OperatorParams().novice_margin)
    scripted = run_episode(SUBJECT, make_object("can"), EpisodeSpec(estimator="oracle", seed=1,
                                                                    user="scripted"))
    assert scripted.row["practice"] == 0 and scripted.row["belief_gain"] is None


def _info(height: float, *, contact: bool = True, out: bool = False,
          crushed: bool = False, wrist: float = 0.0) -> dict:
    return {"object_height_m": height, "thumb_contact": contact, "finger_contact": contact,
            "object_out_of_hand": out, "crushed": crushed, "wrist_height_m": wrist}


def test_the_referee_judges_by_the_physics() -> None:
    ref = TrialReferee(0.08)
    for t, h in ((0.0, 0.06), (1.0, 0.061), (1.5, 0.09), (1.6, 0.10)):
        ref.update(t, _info(h))
    assert ref.secure_lift_s == 1.6 and ref.first_contact_s == 0.0
    assert ref.outcome == "held" and ref.time_to_lift_s == pytest.approx(1.6)
    ref.update(2.0, _info(0.06, contact=False, out=True))
    assert ref.over and ref.outcome == "dropped"
    behind = TrialReferee(0.08)  # the hand rises, the object stays: not a drop
    for t, h, out in ((0.0, 0.06, False), (1.0, 0.06, True), (2.0, 0.06, True)):
        behind.update(t, _info(h, contact=not out, out=out))
    assert behind.outcome == "not_lifted" and not behind.over
    crushed = TrialReferee(0.08)
    crushed.update(0.0, _info(0.06, crushed=True))
    assert crushed.over and crushed.outcome == "crushed" and crushed.ended_by == "crushed"


def test_the_referee_counts_each_rise_of_the_wrist_from_the_table_as_an_attempt() -> None:
    ref = TrialReferee(0.08)
    # up 1 cm and a tremor of 0.2 mm on the way (one attempt), down to the table, up again
    wrist = [0.0, 2e-4, 6e-4, 0.01, 0.0098, 0.01, 0.005, 2e-4, 0.0, 1e-3, 0.08, 0.08]
    for k, w in enumerate(wrist):
        ref.update(0.01 * k, _info(0.06, wrist=w))
    assert ref.attempts == 2 and not ref.released
    ref.update(0.2, _info(0.06, contact=False, wrist=0.0))
    assert ref.released  # the hand no longer grips the object at the last step
    table = TrialReferee(None)  # a force held on the table: no lift can be secure
    for k in range(5):
        table.update(0.01 * k, _info(0.06 + 0.01 * k))
    assert table.secure_lift_s is None and table.outcome == "not_lifted" and not table.over
