"""The user in the loop: the live path equals the batch path for a scripted user; reactions.

The two paths compute the sEMG in other chunks, so their references agree to
``PATH_RTOL``; the hand fed the same references computes the same states, so its traces
are compared exactly up to the first step whose reference differs (``tests/portable.py``).
"""

from __future__ import annotations

import numpy as np
import pytest
from portable import assert_close_across_paths, steps_with_equal_inputs

from controllers.design_cache import grasp_design
from scenarios.runners import episode as E
from scenarios.runners import reference as R
from scenarios.runners.calibration import calibrate
from scenarios.runners.dispatch import UnsupportedScenarioError
from sim.hand.objects import make_object
from sim.user.operators import make_operator
from sim.user.scripted import ScriptedOperator
from sim.user.subjects import VirtualSubject

DT = 0.01
TIMING = ("t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s", "t_controller_s",
          "t_physics_s")


def _both_paths(subject, obj, estimator, mode, seed):
    """The batch reference and the live one of a scripted user, each closed on the hand."""
    cal_seq, ep_seq, env_seq, op_seq = np.random.SeedSequence(seed).spawn(4)
    cal = calibrate(subject, estimator, mode, rng=np.random.default_rng(cal_seq))
    design = grasp_design(obj, "pid", DT, None)
    goal = R.intended_grip_n(obj, 1.5)
    timings = dict.fromkeys(TIMING, 0.0)
    batch = R.scripted_reference(subject, cal, goal, np.random.default_rng(ep_seq),
                                generator="noise", episode_s=6.0, control_dt_s=DT,
                                hand_force_at_mvc_n=30.0, timings=timings)
    tr_b, _, info_b = E._closed_loop(obj, design, batch.reference_n.copy(), batch.t_s, DT, 6.0,
                                     3.4, env_seq, timings, False)
    person, start_s = R.live_user(subject, cal, ScriptedOperator(), goal,
                                  np.random.default_rng(ep_seq), np.random.default_rng(op_seq),
                                  generator="noise", episode_s=6.0, control_dt_s=DT,
                                  hand_force_at_mvc_n=30.0)
    reference = np.zeros(batch.t_s.size)
    tr_l, _, info_l = E._closed_loop(obj, design, reference, batch.t_s, DT, 6.0, 3.4, env_seq,
                                     timings, False, user=person)
    live = R.live_stream(person, start_s, batch.t_s, reference, 6.0, timings)
    return batch, live, tr_b, tr_l, info_b, info_l


@pytest.mark.parametrize("estimator, mode, subject_id, mass_kg", [
    ("latent_kf", "free_run", 1, 0.386),   # the can slips out at the lift: ends early
    ("ss_kf", "one_step", 2, 0.3),
    ("oracle", "free_run", 2, 0.3),
])
@pytest.mark.portable
def test_live_path_of_a_scripted_user_equals_the_batch_path(estimator, mode, subject_id,
                                                            mass_kg) -> None:
    obj = make_object("can", mass_kg=mass_kg)
    batch, live, tr_b, tr_l, info_b, info_l = _both_paths(
        VirtualSubject.sample(0, subject_id), obj, estimator, mode, seed=1 if mass_kg > 0.38
        else 3)
    for name in ("reference_n", "oracle_n", "window_values_n", "t_s"):
        assert_close_across_paths(getattr(live, name), getattr(batch, name), err_msg=name)
    assert live.start_s == batch.start_s and live.window_dt_s == batch.window_dt_s
    k = steps_with_equal_inputs(live.reference_n, batch.reference_n)
    if k == batch.reference_n.size:  # the same references: the same episode, as long
        assert tr_l["grip_force_n"].size == tr_b["grip_force_n"].size
    for name in ("grip_force_n", "object_height_m", "command"):
        np.testing.assert_array_equal(tr_l[name][:k], tr_b[name][:k])
    assert info_l["dropped"] == info_b["dropped"]


def test_the_issue_episode_the_practised_user_holds_the_can_the_others_lose() -> None:
    """Issue 20's episode (pid, latent_kf, free run, can, subject 1, seed 1).

    The scripted user lifts at a set time and the can stays behind. The novice who paces
    the lift takes the can up at the first attempt but loses it in the hold, their
    squeezes reaching the hand 0.35-0.5 s late. After five practice lifts the user
    contracts harder for this prosthesis and holds it (issue 27).
    """
    subject, can = VirtualSubject.sample(0, 1), make_object("can")
    runs = {name: E.run_episode(subject, can, estimator="latent_kf", controller="pid", seed=1,
                                **kw).row
            for name, kw in (("scripted", {"user": "scripted"}), ("novice", {"practice": 0}),
                             ("practised", {}))}
    assert runs["scripted"]["outcome"] == "not_lifted" and runs["scripted"]["attempts"] is None
    novice, practised = runs["novice"], runs["practised"]
    assert novice["outcome"] == "dropped" and novice["user_corrections"] >= 1
    assert practised["outcome"] == "held" and practised["practice"] == 5
    assert practised["belief_gain"] > novice["belief_gain"] == 1.0
    assert practised["safety_margin_pct"] > 50.0


def test_a_reacting_user_saves_a_block_the_scripted_user_drops() -> None:
    subject, block = VirtualSubject.sample(0, 3), make_object("block")
    scripted = E.run_episode(subject, block, estimator="latent_kf", controller="pid", seed=0,
                             user="scripted")
    reacting = E.run_episode(subject, block, estimator="latent_kf", controller="pid", seed=0,
                             practice=0)
    assert scripted.row["outcome"] == "dropped"
    assert reacting.row["outcome"] == "held" and reacting.row["attempts"] >= 1


def test_a_reacting_user_needs_a_causal_generator() -> None:
    with pytest.raises(UnsupportedScenarioError, match="reacting: .*motor_units.*scripted"):
        E.run_episode(VirtualSubject.sample(0, 1), make_object("ball"), estimator="oracle",
                      generator="motor_units", episode_s=4.0, hold_s=1.0)


def test_feedback_for_a_scripted_user_is_refused() -> None:
    from sim.user.operator import OperatorError

    with pytest.raises(OperatorError, match="takes feedback none only"):
        E.run_episode(VirtualSubject.sample(0, 1), make_object("ball"), estimator="oracle",
                      user="scripted", feedback="force_vibration")


def test_operators_are_made_by_name() -> None:
    assert isinstance(make_operator("scripted"), ScriptedOperator)


# ------------------------------------------------------------------ extending
MADE: list = []


class HalfHearted:
    """Toy user kind: the script at half strength; takes a feedback mode and ignores it."""

    name = "half_hearted"

    def __init__(self, params=None, feedback=None) -> None:
        self.feedback_name = getattr(feedback, "name", feedback)
        self.corrections, self.correction_times = 0, []
        self.script = ScriptedOperator()
        MADE.append(self)

    def start(self, plan, *, control_dt_s, rng) -> None:
        self.plan = plan
        self.script.start(plan, control_dt_s=control_dt_s, rng=rng)

    def perceive(self, scene) -> None:
        pass

    def intent(self, n_samples: int) -> np.ndarray:
        return 0.5 * self.script.intent(n_samples)

    def finish(self):
        return self.script.finish()


class Beep:
    """Toy feedback mode: feels nothing, like vision only."""

    name = "beep"
    codes_force = False

    def __init__(self, params=None) -> None:
        self.params = params


@pytest.fixture
def toys():
    from sim.user.operators import (
        register_feedback,
        register_operator,
        unregister_feedback,
        unregister_operator,
    )

    register_operator("half_hearted", HalfHearted)
    register_feedback("beep", Beep)
    yield
    unregister_operator("half_hearted")
    unregister_feedback("beep")


def test_a_registered_user_kind_and_feedback_mode_reach_schema_cli_and_episode(toys) -> None:
    from scenarios.cli.main import build_parser
    from scenarios.schema import parse_scenario

    scenario = parse_scenario({"kind": "episode", "user": {"kind": "half_hearted",
                                                           "feedback": "beep"}}, source="t")
    assert (scenario.user.kind, scenario.user.feedback) == ("half_hearted", "beep")
    episode = build_parser("episode")._subparsers._group_actions[0].choices["episode"]
    assert "half_hearted" in episode.format_help() and "beep" in episode.format_help()
    result = E.run_episode(VirtualSubject.sample(0, 2), make_object("ball"), estimator="oracle",
                           user="half_hearted", feedback="beep", episode_s=4.0, hold_s=1.0)
    assert result.row["user"] == "half_hearted" and result.row["feedback"] == "beep"
    toy = MADE[-1]
    assert toy.feedback_name == "beep"
    assert np.max(result.traces["user_intent"]) == pytest.approx(0.5 * toy.plan.hold_level)
