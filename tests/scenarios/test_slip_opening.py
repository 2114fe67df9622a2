"""Slip recovery by an involuntary opening (Aboseria et al. 2018): the hook, the hand that
really opens, the unannounced seeded onset, the row and JSON, and bad input."""

from __future__ import annotations

import math
import textwrap
from types import SimpleNamespace

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from controllers.paradigms import Decoded
from scenarios.cli import main
from scenarios.feedback_summary import aggregate
from scenarios.runners.dispatch import run_scenario
from scenarios.runners.feedback_tasks import TaskSetup, slip_trials
from scenarios.runners.slip_perturbations import (
    LOAD_DELAY_S,
    RECOVERY_WINDOW_S,
    Opening,
    RisingLoad,
    perturbation_for,
)
from scenarios.runners.trial_loop import HandSettings, TrialHooks, TrialLoop, TrialTiming
from scenarios.schema import Scenario, ScenarioError, load_sweep, parse_scenario
from sim.hand.objects import make_object
from sim.hand.wrist import LIFT_HEIGHT_M
from sim.user.operator import WristMove

DT = 0.01
CAN = make_object("can")


def _info(t_s: float, *, wrist_m: float = LIFT_HEIGHT_M, touching: bool = True,
          slip: float = 0.0, dropped: bool = False) -> dict:
    return {"thumb_contact": touching, "finger_contact": touching, "wrist_height_m": wrist_m,
            "object_out_of_hand": dropped, "slip_speed_m_s": slip, "dropped": dropped,
            "grip_force_n": 10.0, "time_s": t_s}


# ------------------------------------------------------------------ the hook
def test_the_opening_drops_the_command_by_its_fraction_until_the_person_squeezes() -> None:
    """Closed form: before the start the reference passes; at the start the drop is
    ``fraction x`` the reference then; after it the reference is ``max(r - drop, 0)``, so a
    person who raises their command by the drop gets their grip back."""
    opening = Opening(LIFT_HEIGHT_M, 0.4, delay_s=0.5)
    assert opening.command(0.0, _info(0.0, wrist_m=0.0), 12.0) == 12.0  # not lifted yet
    assert opening.command(1.0, _info(1.0), 12.0) == 12.0  # the top: the delay runs
    assert opening.command(1.49, _info(1.49), 12.0) == 12.0 and not opening.started
    assert opening.command(1.5, _info(1.5), 12.0) == pytest.approx(12.0 - 0.4 * 12.0)
    assert opening.started and opening.start_s == 1.5
    assert opening.drop_n == pytest.approx(4.8)
    for r in (12.0, 9.0, 4.0, 0.0):  # stays dropped while the person holds or relaxes
        assert opening.command(1.6, _info(1.6), r) == pytest.approx(max(r - 4.8, 0.0))
    # squeezing harder by the drop undoes it
    assert opening.command(1.7, _info(1.7), 12.0 + 4.8) == pytest.approx(12.0)
    assert opening.onset_s is None and not opening.done(3.4, _info(3.4))
    assert opening.done(1.5 + RECOVERY_WINDOW_S, _info(3.5))  # no slip: the trial's answer
    opening.command(1.8, _info(1.8, slip=0.01), 12.0)
    assert opening.onset_s == 1.8 and not opening.done(3.7, _info(3.7))
    assert opening.done(1.8 + RECOVERY_WINDOW_S, _info(3.8))


def test_the_opening_reads_the_object_out_of_the_hand_not_an_earlier_attempts_drop() -> None:
    """The environment's ``dropped`` latches after a lift that left the object behind; the
    opening's slip onset and recovery read the object out of the hand now."""
    opening = Opening(LIFT_HEIGHT_M, 0.5, delay_s=0.0)
    stale = {**_info(1.0), "dropped": True}  # an earlier attempt; the can is in the hand now
    opening.command(1.0, stale, 10.0)
    opening.command(1.01, stale, 10.0)
    assert opening.started and opening.onset_s is None and opening.recovered(stale)
    assert not opening.done(1.01, stale)
    out = {**stale, "object_out_of_hand": True}
    opening.command(1.02, out, 10.0)
    assert opening.onset_s == 1.02 and opening.done(1.02, out) and not opening.recovered(out)


def test_the_rising_load_keeps_its_shape() -> None:
    load = RisingLoad(LIFT_HEIGHT_M, 2.0)
    assert load(1.0, _info(1.0)) == 0.0 and load(1.5, _info(1.5)) == 0.0  # top, start
    assert load(2.0, _info(2.0)) == pytest.approx(1.0)
    assert load(2.5, _info(2.5, slip=0.01)) == pytest.approx(1.0)  # the onset: it stays
    assert load.onset_s == 2.5 and load(3.0, _info(3.0)) == pytest.approx(1.0)
    assert not load.done(4.0, _info(4.0)) and load.done(4.5, _info(4.5))


class HoldAndRelax:
    """A person on the velocity paradigm: closes at ``close`` for ``grip_n`` N, lifts, then
    relaxes (the motor stops; a self-locking drive holds)."""

    wrist_tremor_m = 0.0
    done = False

    def __init__(self, grip_n: float, relax_s: float, lift_step: int = 100) -> None:
        self.grip_n, self.relax_s, self.lift_step = grip_n, relax_s, lift_step
        self.decoded = Decoded()

    def act(self, k, scene, setpoint_m):
        self.decoded = (Decoded(close=0.6, grip_n=self.grip_n) if scene.t_s < self.relax_s
                        else Decoded())
        return 0.0, WristMove(LIFT_HEIGHT_M, 0.6) if k == self.lift_step else None


def _held_can(hooks: TrialHooks) -> dict:
    loop = TrialLoop(CAN, grasp_design(CAN, "pid", DT, None), HoldAndRelax(15.0, 2.0),
                     TrialTiming(4.0, DT), lift_height_m=LIFT_HEIGHT_M, seed=0, hooks=hooks,
                     hand=HandSettings("self_locking", "velocity"))
    loop.run()
    return loop.traces()


@pytest.fixture(scope="module")
def held_runs() -> dict:
    opening = Opening(LIFT_HEIGHT_M, 0.5, delay_s=1.0)  # the top at 1.6 s: opens at 2.6 s
    return {"plain": _held_can(TrialHooks()),
            "same": _held_can(TrialHooks(command=lambda t, info, r: r)),
            "opened": _held_can(TrialHooks(command=opening.command)), "opening": opening}


def test_without_an_opening_the_relaxed_velocity_hand_holds_and_the_hook_changes_nothing(
        held_runs) -> None:
    plain = held_runs["plain"]
    t = plain["t_s"]
    held = plain["grip_force_n"][(t >= 2.3) & (t <= 4.0)]
    assert held.min() > 10.0 and held.max() - held.min() < 1.0  # the worm holds it
    for name, trace in held_runs["same"].items():  # a hook that leaves it alone
        np.testing.assert_array_equal(trace, plain[name])


def test_under_velocity_and_self_locking_the_grip_really_falls_at_the_opening(
        held_runs) -> None:
    opened, opening = held_runs["opened"], held_runs["opening"]
    t = opened["t_s"]
    assert opening.start_s == pytest.approx(2.6, abs=0.03)
    after = t >= opening.start_s
    # the reference after the opening: the held 15 N minus half of it, exactly
    np.testing.assert_allclose(opened["reference_n"][after], 7.5, atol=1e-12)
    before = float(opened["grip_force_n"][~after][-1])
    settled = opened["grip_force_n"][t >= opening.start_s + 0.3]
    assert before > 10.0
    assert settled.max() < before - 0.5 * opening.drop_n  # the hand opened
    assert settled.max() - settled.min() < 1.0  # and the relaxed hand holds it there


# ------------------------------------------------------------------ the onset
def _trial_seeds(seed: int, trials: int) -> list[list[np.random.SeedSequence]]:
    """The trial seeds exactly as TaskSetup makes them."""
    _, trial_seq, _ = np.random.SeedSequence(seed).spawn(3)
    return [s.spawn(3) for s in trial_seq.spawn(trials)]


def test_the_onset_is_drawn_from_the_trials_own_seeded_stream() -> None:
    protocol = SimpleNamespace(perturbation="opening", opening=0.5, opening_window_s=2.0)
    delays = [perturbation_for(protocol, LIFT_HEIGHT_M, s)[0].delay_s
              for s in _trial_seeds(11, 4)]
    again = [perturbation_for(protocol, LIFT_HEIGHT_M, s)[0].delay_s
             for s in _trial_seeds(11, 4)]
    other = [perturbation_for(protocol, LIFT_HEIGHT_M, s)[0].delay_s
             for s in _trial_seeds(12, 4)]
    assert delays == again and delays != other
    assert len(set(delays)) == 4  # unannounced: a different time in every trial
    assert all(LOAD_DELAY_S <= d <= LOAD_DELAY_S + 2.0 for d in delays)
    # independently: the fourth child of each trial's seed, uniform over the window
    _, trial_seq, _ = np.random.SeedSequence(11).spawn(3)
    expected = [LOAD_DELAY_S + np.random.default_rng(s.spawn(4)[3]).uniform(0.0, 2.0)
                for s in trial_seq.spawn(4)]
    np.testing.assert_allclose(delays, expected, rtol=0, atol=1e-15)
    # drawing it moves no other stream of the trial
    seeds = _trial_seeds(11, 1)[0]
    states = [s.generate_state(2).tolist() for s in seeds]
    perturbation, hooks = perturbation_for(protocol, LIFT_HEIGHT_M, seeds)
    assert [s.generate_state(2).tolist() for s in seeds] == states
    assert [s.n_children_spawned for s in seeds] == [0, 0, 0]
    assert hooks.command == perturbation.command and hooks.load is None


# ------------------------------------------------------------------ a real trial
def _opening_scenario(**protocol) -> Scenario:
    return parse_scenario({
        "kind": "slip_recovery", "seed": 3, "subject": {"subject_id": 1},
        "protocol": {"name": "slip_recovery", "episode_s": 14.0, "hold_s": 11.0, "trials": 1,
                     "perturbation": "opening", **protocol},
        "object": {"name": "can"}, "estimator": {"name": "ss_kf", "mode": "free_run"},
        "controller": {"kind": "pid"}, "user": {"kind": "reacting", "feedback": "none"},
        "paradigm": "velocity", "hand": {"drive": "self_locking"}, "decoder": "pattern"},
        source="test")


def test_a_subjects_opening_under_velocity_opens_the_hand_and_is_counted() -> None:
    scenario = _opening_scenario()
    setup = TaskSetup(scenario)
    [(trial, opening)] = list(slip_trials(setup, scenario))
    assert opening.started
    t, grip = trial.traces["t_s"], trial.traces["grip_force_n"]
    k = int(np.searchsorted(t, opening.start_s))
    window = grip[k:k + int(round(0.3 / DT))]
    assert window.min() < grip[k - 1] - 0.5 * opening.drop_n  # the grip fell
    # half the command lost: the hand's reference at the start is the other half
    assert t[k] == opening.start_s
    assert trial.traces["reference_n"][k] == pytest.approx(opening.drop_n, rel=1e-12)
    row = run_scenario(scenario)
    assert row["perturbation"] == "opening" and row["opening"] == 0.5
    assert row["n"] + row["no_slip"] + row["not_lifted"] == 1
    assert row["paradigm"] == "velocity" and row["drive"] == "self_locking"
    if row["n"]:
        assert row["recovered_rate"] in (0.0, 1.0)
    else:
        assert row["recovered_rate"] is None


def test_the_json_has_the_rate_n_no_slip_and_reaction_per_mode() -> None:
    rows = [{"feedback": "slip_vibration", "n": 2, "recovered": 2, "no_slip": 1,
             "not_lifted": 0, "reaction_s": r} for r in (0.2, 0.4)]
    mode = aggregate("slip_recovery", rows)["by_feedback"]["slip_vibration"]
    assert mode["n"] == 4 and mode["recovered_rate"] == 1.0 and mode["no_slip"] == 2
    assert mode["reaction_s"] == pytest.approx(0.3)
    half = 12.706204736174707 * np.std([0.2, 0.4], ddof=1) / math.sqrt(2)  # t(0.975, 1)
    assert mode["reaction_ci95"] == pytest.approx([0.3 - half, 0.3 + half], rel=1e-6)


# ------------------------------------------------------------------ bad input
def test_defaults_stay_out_of_the_canonical_scenario() -> None:
    plain = Scenario.model_validate({"kind": "slip_recovery",
                                     "protocol": {"name": "slip_recovery"}})
    assert not {"perturbation", "opening", "opening_window_s"} & set(
        plain.canonical_dict()["protocol"])
    opened = _opening_scenario(opening=0.7)
    assert opened.canonical_dict()["protocol"]["perturbation"] == "opening"
    assert opened.canonical_dict()["protocol"]["opening"] == 0.7


@pytest.mark.parametrize("line, expected", [
    ("opening: 0", "base.protocol.opening:"),
    ("opening: 1.5", "base.protocol.opening:"),
    ("opening_window_s: 0", "base.protocol.opening_window_s:"),
    ("perturbation: squeeze", "base.protocol.perturbation:"),
])
def test_the_schema_refuses_bad_openings_in_one_line_with_the_file_line(
        tmp_path, line, expected) -> None:
    path = tmp_path / "slip.yaml"
    path.write_text(textwrap.dedent(f"""\
        name: x
        base:
          kind: slip_recovery
          protocol:
            name: slip_recovery
            {line}
        """))
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}:6: {expected}")


@pytest.mark.parametrize("extra, expected", [
    (["--perturbation", "opening", "--opening", "2"],
     "--opening: expected a fraction in (0, 1], found 2"),
    (["--perturbation", "opening", "--opening", "0"], "--opening: expected a fraction"),
    (["--opening", "0.5"], "--opening: applies to --perturbation opening"),
    (["--perturbation", "squeeze"], "--perturbation: expected one of"),
])
def test_the_cli_refuses_bad_openings_in_one_line(capsys, extra, expected) -> None:
    assert main(["slip-recovery", "--controller", "pid", "--estimator", "oracle",
                 *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]
