"""The intact hand (human speed, grip coupled to load) and the ideal interface it was split from.

``ideal_interface`` is the intact-hand reference of before issue 37 under its new name: its
golden trial was measured on the code before the change (``intact`` then) and must not move.
``intact`` is the human-speed hand: pre-shaped to the object, closing in the published time,
with the grip planned from the load the user expects (docs/OPERATOR.md, "The intact hand").
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from controllers.design_cache import grasp_design
from scenarios.cli import main
from scenarios.cli.feedback_tasks import reference_arms, with_intact
from scenarios.runners.episode import EpisodeSpec, run_episode, seed_sequences
from scenarios.runners.person import hand_for
from scenarios.runners.reference import grasp_task
from scenarios.runners.trial import Trial, TrialSetup, run_trial
from scenarios.runners.trial_loop import DEFAULT_HAND
from scenarios.runners.trial_outcome import (
    margin_over_grip_pct,
    relative_safety_margin_pct,
    safety_margin_pct,
)
from scenarios.schema.names import IDEAL_INTERFACE, INTACT, NO_ESTIMATOR
from sim.hand.grasp_env import GraspEnv
from sim.hand.human import CLOSING_S, PRESHAPE_APERTURE_M, human_hand, human_motor, human_task
from sim.hand.model import MotorSpec
from sim.hand.objects import make_object
from sim.user.grip_load import G_M_S2, LoadPlan, anticipated_grip_n, min_jerk_acceleration_m_s2
from sim.user.operator import MIN_GRIP_N
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

#: Reach-to-grasp closing time, s: the last ~30 % of the reach (Jeannerod 1984), 0.15-0.25 s.
PUBLISHED_CLOSING_S = (0.15, 0.25)
#: The grip-load correlation over the lift an intact hand must exceed (chosen before the run:
#: grip and load rise together, Johansson & Westling 1984).
COUPLED_CORRELATION = 0.7
#: At the lift decision the intact hand holds at most this share of the grip it lifts with
#: (the rest comes with the load); the ideal interface at least IDEAL_SHARE (set beforehand).
COUPLED_SHARE, IDEAL_SHARE = 0.5, 0.7

# An ideal_interface trial (subject 1, the can, seed 3, no practice, touch, 5 s) measured on
# the tree before issue 37's change, where it was called "intact" (commit c682a2d).
GOLDEN = {"n": 500, "grip_sum": 1608.1182454502105, "ref_sum": 2003.6322205250717,
          "h_max": 0.1409855472861615, "outcome": "held", "time_to_lift_s": 0.49,
          "safety_margin_pct": 46.128447864639966,
          "grip_at": {150: 0.0, 200: 1.8207322797741303, 250: 5.257437258327859,
                      300: 5.419598602003242, 350: 5.783631277766136, 400: 5.723329523726377,
                      450: 5.35205140419474}}


def _trial(reference: str, subject_id: int, seed: int, obj_name: str = "can") -> Trial:
    """One trial of ``reference`` by a novice who feels through touch (no practice)."""
    obj = make_object(obj_name)
    subject = VirtualSubject.sample(0, subject_id)
    cal_seq, episode_seq, env_seq, operator_seq, _ = seed_sequences(seed)
    cal = EpisodeSpec(estimator=reference, seed=seed).calibration_settings().fit(subject,
                                                                               cal_seq)
    setup = TrialSetup(subject, obj, cal, grasp_design(obj, "pid", 0.01, None))
    return run_trial(setup, make_operator("reacting", feedback="touch"),
                     grasp_task(obj, hold_s=1.0, limit_s=5.0),
                     (episode_seq, env_seq, operator_seq))


# ------------------------------------------------------------------ the rename
def test_the_ideal_interface_is_the_old_intact_reference_unchanged() -> None:
    res = run_episode(VirtualSubject.sample(0, 1), make_object("can"),
                      EpisodeSpec(estimator=IDEAL_INTERFACE, controller="pid", feedback="touch",
                                  seed=3, practice=0, episode_s=5.0))
    g, tr = res.traces["grip_force_n"], res.traces
    assert g.size == GOLDEN["n"]
    assert float(g.sum()) == pytest.approx(GOLDEN["grip_sum"], rel=1e-6)
    assert float(tr["reference_n"].sum()) == pytest.approx(GOLDEN["ref_sum"], rel=1e-6)
    assert float(tr["object_height_m"].max()) == pytest.approx(GOLDEN["h_max"], abs=1e-6)
    for k, v in GOLDEN["grip_at"].items():
        assert float(g[k]) == pytest.approx(v, abs=1e-5)
    assert res.row["outcome"] == GOLDEN["outcome"]
    assert res.row["time_to_lift_s"] == pytest.approx(GOLDEN["time_to_lift_s"], abs=1e-6)
    assert res.row["safety_margin_pct"] == pytest.approx(GOLDEN["safety_margin_pct"], rel=1e-6)


def test_both_references_are_names_without_an_estimator_and_run_on_their_hands() -> None:
    assert {INTACT, IDEAL_INTERFACE} <= set(NO_ESTIMATOR)
    assert hand_for(IDEAL_INTERFACE, DEFAULT_HAND) is DEFAULT_HAND
    human = hand_for(INTACT, replace(DEFAULT_HAND, drive="self_locking"))
    assert human.human and human.drive == "backdrivable"
    spec, task = human.env_specs(4.0)
    assert task.preshape_aperture_m == PRESHAPE_APERTURE_M and task.episode_s == 4.0
    assert spec.motor.no_load_speed_rad_s > MotorSpec().no_load_speed_rad_s


def test_intact_runs_both_references_on_the_same_subjects() -> None:
    settings = {"estimator.name": "mlp", "decoder": "pattern", "hand.drive": "self_locking",
                "auto_grip": True, "controller.kind": "pid"}
    arms = dict(reference_arms(settings, {"paradigm": ["force"]}))
    assert list(arms) == [INTACT, IDEAL_INTERFACE]
    intact, feedback, grid = arms[INTACT]
    assert intact == {"estimator.name": INTACT, "controller.kind": "pid",
                      "user.kind": "reacting"}
    assert feedback == ["touch"] and grid == {"paradigm": ["force"]}
    ideal = arms[IDEAL_INTERFACE][0]  # the prosthesis's hand keeps its drive, as before
    assert ideal["hand.drive"] == "self_locking" and ideal["auto_grip"] and "decoder" not in ideal
    rows = with_intact({"by_feedback": {"none": 1}, INTACT: {"by_feedback": {"touch": 2}},
                        IDEAL_INTERFACE: {"by_feedback": {"touch": 3}}})
    assert rows == {"none": 1, "intact (touch)": 2, "ideal_interface (touch)": 3}


def test_the_episode_command_takes_both_references(capsys) -> None:
    for reference in (INTACT, IDEAL_INTERFACE):
        assert main(["episode", "--controller", "pid", "--estimator", reference, "--object",
                     "can", "--practice", "0", "--episode-s", "3", "--feedback", "touch"]) == 0
    assert "ideal_interface" in capsys.readouterr().out


# ------------------------------------------------------------- the human-speed hand
def test_the_human_motor_closes_the_preshape_gap_in_the_published_time() -> None:
    # per side half the extra aperture, at the fingertip (0.1 m), at command 0.2, through the
    # tendon's 2 rad per rad of the coupled digit angle: 12.5 mm / 0.2 s / 0.1 m * 2 / 0.2
    expected = 0.0125 / CLOSING_S / 0.1 * 2.0 / 0.2 * MotorSpec().gear_ratio
    assert human_motor(0.2).no_load_speed_rad_s == pytest.approx(expected)
    assert expected == pytest.approx(1562.5)


def test_the_digits_start_preshaped_and_open_no_wider() -> None:
    env = GraspEnv("can", 0.0, hand=human_hand(0.2), task=human_task(2.0), wrist="commanded")
    _, info = env.reset(seed=0)
    angle = info["finger_position_rad"]
    # the aperture beyond the can's width, measured here with the digits' geometry
    scratch = mujoco.MjData(env.model)
    gap = env._preshape.aperture_m(scratch, angle)  # noqa: SLF001 (the env's own geometry)
    assert gap == pytest.approx(PRESHAPE_APERTURE_M, abs=5e-4)
    for _ in range(30):  # an opening command: held at the pre-shape by the opening stop
        _, _, _, _, info = env.step(np.array([-0.3]))
    assert info["finger_position_rad"] >= angle - 0.01
    plain = GraspEnv("can", 0.0, wrist="commanded")
    _, info = plain.reset(seed=0)
    assert info["finger_position_rad"] == 0.0  # the prosthesis starts straight, as before


def test_the_intact_hand_closes_on_a_can_within_the_published_time() -> None:
    def closing_s(trial: Trial) -> tuple[float, float]:
        """From the gate's closing command to the first touch (the gate leaves its closing
        command as a digit touches), and to both sides touching, s."""
        command, both, t = (trial.traces[k] for k in ("command", "both_sides", "t_s"))
        start = int(np.flatnonzero(command > 0.0)[0])
        closing = float(command[start])
        touch = start + int(np.flatnonzero(command[start:] < closing - 1e-9)[0])
        return float(t[touch] - t[start]), float(t[int(np.flatnonzero(both)[0])] - t[start])

    touch, both = closing_s(_trial(INTACT, 1, 0))
    assert PUBLISHED_CLOSING_S[0] <= touch <= PUBLISHED_CLOSING_S[1]
    assert both - touch <= 0.1  # the second side follows at the gate's approach speed
    assert closing_s(_trial(IDEAL_INTERFACE, 1, 0))[0] > 2 * PUBLISHED_CLOSING_S[1]


# ------------------------------------------------------------- grip coupled to load
def _lift_window(trial: Trial) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Grip and the object's load (m (g + z''), 0 while it rests on the table) from the
    user's lift decision to the top of the lift, and those two steps."""
    t, g = trial.traces["t_s"], trial.traces["grip_force_n"]
    h, w = trial.traces["object_height_m"], trial.traces["wrist_height_m"]
    mass = make_object("can").mass_kg
    decided = int(np.searchsorted(t, next(t0 for t0, ph in trial.phases if ph == "lift")))
    top = int(np.flatnonzero(w >= w.max() - 1e-4)[0])
    smooth = np.convolve(h, np.ones(5) / 5, mode="same")
    accel = np.gradient(np.gradient(smooth, t), t)
    load = np.where(h > h[0] + 5e-4, mass * (G_M_S2 + accel), 0.0)
    return g, load, decided, top


@pytest.mark.parametrize("subject_id, seed", [(1, 0), (2, 1)])
def test_the_intact_grip_rises_with_the_load_and_the_ideal_interface_grips_first(
        subject_id, seed) -> None:
    g, load, decided, top = _lift_window(_trial(INTACT, subject_id, seed))
    r = float(np.corrcoef(g[decided:top + 1], load[decided:top + 1])[0, 1])
    assert r > COUPLED_CORRELATION
    assert g[decided] / g[top] <= COUPLED_SHARE  # the grip comes with the load
    g, load, decided, top = _lift_window(_trial(IDEAL_INTERFACE, subject_id, seed))
    assert g[decided] / g[top] >= IDEAL_SHARE  # the grip was set before the load came


def test_the_load_a_user_expects_from_a_minimum_jerk_lift() -> None:
    h, T = 0.08, 0.6
    plan = LoadPlan(1.0, h, T, hold_s=0.5, place=True)
    peak_s = T * (0.5 - math.sqrt(3) / 6)  # a min-jerk move's largest acceleration
    a_peak = h / T ** 2 * 10 / math.sqrt(3)
    assert min_jerk_acceleration_m_s2(peak_s, h, T) == pytest.approx(a_peak)
    assert plan.load_factor(1.0 + peak_s) == pytest.approx(1 + a_peak / G_M_S2)
    assert plan.load_factor(0.99) == 0.0 and plan.load_factor(1.0 + T / 2) == pytest.approx(1.0)
    assert plan.load_factor(1.0 + T + 0.25) == 1.0  # held still
    assert plan.load_factor(1.0 + T + 0.5 + peak_s) == pytest.approx(1 - a_peak / G_M_S2)
    assert plan.load_factor(1.0 + 2 * T + 0.6) == 0.0  # put down
    mean = np.mean([plan.load_factor(1.0 + s) for s in np.linspace(0, T, 2001)])
    assert mean == pytest.approx(1.0, abs=1e-3)  # the arm starts and ends at rest


def test_the_planned_grip_is_the_preload_plus_the_margin_over_the_load() -> None:
    assert anticipated_grip_n(4.0, 0.25, 0.5, 1.2) == pytest.approx(0.5 + 1.25 * 4.0 * 1.2)
    assert anticipated_grip_n(0.2, 0.25, 0.5, 1.0) == MIN_GRIP_N  # every user's floor
    assert anticipated_grip_n(4.0, 0.25, 0.5, 1.0, break_n=4.0) == pytest.approx(0.7 * 4.0)


# ------------------------------------------------------------- the margin's definitions
def test_the_relative_margin_is_the_excess_over_the_slip_force_as_a_share_of_the_grip() -> None:
    can = make_object("can", mass_kg=0.4, friction=0.5)
    slip_n = 0.4 * 9.81 / (2 * 0.5)
    grip = np.full(50, 5.0)
    hold = np.zeros(50, dtype=bool)
    hold[10:40] = True
    assert safety_margin_pct(grip, hold, can) == pytest.approx(100 * (5.0 / slip_n - 1))
    assert relative_safety_margin_pct(grip, hold, can) == pytest.approx(
        100 * (5.0 - slip_n) / 5.0)
    assert relative_safety_margin_pct(grip, np.zeros(50, dtype=bool), can) is None
    for over_slip, over_grip in ((25.0, 20.0), (0.0, 0.0), (100.0, 50.0), (-50.0, -100.0)):
        assert margin_over_grip_pct(over_slip) == pytest.approx(over_grip)
