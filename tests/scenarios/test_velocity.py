"""The clinical velocity paradigm in the one trial loop: a second muscle opens the hand."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from controllers.paradigms import DecoderMissingError
from scenarios.runners.calibration import CalibrationSettings
from scenarios.runners.decoding import (
    DecoderStudy,
    OpeningTest,
    opening_time_s,
    preferred_decoder,
    run_study,
    summarize,
)
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.runners.reference import grasp_task
from scenarios.runners.trial import TrialSetup, run_trial
from scenarios.runners.trial_loop import HandSettings
from sim.hand.objects import make_object
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject, make_population

VELOCITY = HandSettings("self_locking", "velocity")


@pytest.fixture(scope="module")
def can_design():
    can = make_object("can")
    return can, grasp_design(can, "pid", 0.01, None)


def _setup(subject: VirtualSubject, can_design, hand: HandSettings = VELOCITY) -> TrialSetup:
    can, design = can_design
    cal = CalibrationSettings("ss_kf", "free_run", decoder=hand.effective_decoder).fit(
        subject, np.random.SeedSequence(7))
    return TrialSetup(subject, can, cal, design, hand=hand)


@pytest.mark.parametrize("subject_id", [1, 5])
def test_a_full_effort_opening_opens_the_held_hand_within_a_second(subject_id, can_design
                                                                   ) -> None:
    subject = make_population(subject_id, 0)[-1]
    out = opening_time_s(_setup(subject, can_design), OpeningTest(open_level=1.0),
                         seed=subject_id)
    # the squeeze closed the hand on the can and the self-locking drive held it relaxed
    assert out["closed_travel_rad"] > 0.1 and out["held_grip_n"] > 5.0
    assert out["open_s"] is not None and out["open_s"] <= 1.0


def test_without_an_opening_the_self_locking_hand_keeps_its_grip(can_design) -> None:
    subject = make_population(2, 0)[-1]
    out = opening_time_s(_setup(subject, can_design), OpeningTest(open_level=0.0), seed=2)
    assert out["held_grip_n"] > 5.0 and out["open_s"] is None


def test_velocity_without_open_contractions_is_refused_in_one_line(can_design) -> None:
    subject = make_population(1, 0)[-1]
    setup = _setup(subject, can_design, HandSettings("self_locking", "force"))
    setup = TrialSetup(subject, setup.obj, setup.calibration, setup.design, hand=VELOCITY)
    assert setup.calibration.decoder is None
    with pytest.raises(DecoderMissingError) as err:
        run_trial(setup, make_operator("reacting"), grasp_task(setup.obj, hold_s=1.0),
                  tuple(np.random.SeedSequence(3).spawn(3)))
    assert "no open contractions" in str(err.value) and "\n" not in str(err.value)


def test_a_velocity_episode_names_its_decoder_and_counts_its_windows() -> None:
    subject = make_population(3, 0)[-1]
    row = run_episode(subject, make_object("can"), EpisodeSpec(
        estimator="ss_kf", seed=4, practice=0, hand=VELOCITY)).row
    assert row["paradigm"] == "velocity" and row["decoder"] == "pattern"
    assert row["decoder_windows"] > 20
    assert 0 <= row["unrequested_opens"] <= row["decoder_windows"]
    plain = run_episode(subject, make_object("can"), EpisodeSpec(
        estimator="ss_kf", seed=4, practice=0)).row
    assert plain["decoder"] is None and plain["unrequested_opens"] is None


def test_the_reacting_user_opens_a_velocity_hand_to_let_go(can_design) -> None:
    subject = make_population(4, 0)[-1]
    setup = _setup(subject, can_design)
    operator = make_operator("reacting")
    trial = run_trial(setup, operator, grasp_task(setup.obj, hold_s=0.5),
                      tuple(np.random.SeedSequence(11).spawn(3)))
    assert trial.referee.outcome == "held"
    assert [p for _, p in trial.phases][-2:] == ["release", "done"]
    assert operator.released and trial.referee.released


@pytest.mark.verdict
def test_the_default_decoder_is_the_one_with_fewer_unrequested_opens() -> None:
    from estimation.decoding import DEFAULT_DECODER

    rows = run_study(DecoderStudy(subjects=10))
    assert preferred_decoder(rows) == DEFAULT_DECODER
    s = summarize(rows)[DEFAULT_DECODER]
    assert s["failed"] == 0
    # every subject's rest is mostly read as rest and their openings are found
    assert s["worst_unrequested_closes_pct"] <= 5.0 and s["median_opens_found_pct"] >= 70.0


@pytest.mark.verdict
@pytest.mark.xfail(strict=True, reason="issue 36's <= 1 % of squeeze windows per subject is not "
                   "met: co-contraction varies from squeeze to squeeze and the crosstalk of the "
                   "ring blurs the two patterns (docs/results/person-in-the-loop.md, issue 36)")
def test_no_subject_sees_more_than_one_percent_unrequested_opens() -> None:
    rows = run_study(DecoderStudy(subjects=10))
    from estimation.decoding import DEFAULT_DECODER

    worst = summarize(rows)[DEFAULT_DECODER]["worst_unrequested_opens_pct"]
    assert worst <= 1.0
