"""The slip reflex on the MuJoCo hand: a shaken can slips less, is not crushed, no early onset.

A 0.3 kg can (friction 0.5: it slips below m g / (2 mu) = 2.94 N) is held at a
constant 3.5 N reference (1.2 times its slip force), lifted gently (no slip on
the lift), then shaken vertically at 4 Hz with 10 mm amplitude (peak
acceleration 6.3 m/s^2: it needs about 4.8 N). The same PI force loop (the library's
design scheduled over force, 60 deg at 10 rad/s, behind its contact gate) runs
with and without the reflex; the can's user force limit is 9 N. The peak force
is checked after the lift, where the reflex acts.
"""

import numpy as np
import pytest

from controllers.base import observation_from_info
from controllers.design import design_for_object
from controllers.design_spec import DesignSpec
from sim.hand.grasp_env import GraspEnv, GraspTask, WristSchedule
from sim.hand.objects import make_object

REFERENCE_N = 3.5
BREAK_N = 9.0
MARGIN = 0.2
DT_S = 0.01
SCHEDULE = WristSchedule(lift_after_s=0.8, lift_duration_s=1.0, shake_amplitude_m=0.01,
                         shake_frequency_hz=4.0, shake_delay_s=0.2, shake_duration_s=1.0)
REFLEX = {"latency_s": 0.05, "gain": 0.5, "decay_s": 1.0, "max_boost": 1.0,
          "slip_speed_threshold_m_s": 0.02, "fragility_margin": MARGIN}


def shake_episode(with_reflex: bool, *, episode_s: float = 3.5) -> dict:
    """Run the shake scenario; returns slip, peak force, outcomes and the reflex counters."""
    obj = make_object("can", mass_kg=0.3, friction=0.5, break_force_n=BREAK_N)
    spec = DesignSpec(phase_margin_deg=60.0, crossover_rad_s=10.0, force_max_n=BREAK_N,
                      slip_reflex=REFLEX if with_reflex else None)
    design = design_for_object(obj, "pid", spec, control_dt_s=DT_S)
    ctl = design.controller
    env = GraspEnv(obj, REFERENCE_N, control_dt_s=DT_S, wrist=SCHEDULE,
                   task=GraspTask(episode_s=episode_s))
    ctl.reset()
    try:
        _, info = env.reset(seed=0)
        action = np.zeros(1, dtype=np.float32)
        pending = 0.0  # one control period of computation delay, as in an episode
        lift_start_s = None
        peak_n = {"before_lift": 0.0, "after_lift": 0.0}  # larger side's normal force, N
        while True:
            u = ctl.act(observation_from_info(info, REFERENCE_N))
            action[0] = pending
            _, _, terminated, truncated, info = env.step(action)
            pending = u
            if lift_start_s is None and info["lifted"]:
                lift_start_s = info["time_s"] - DT_S
            phase = "before_lift" if lift_start_s is None else "after_lift"
            peak_n[phase] = max(peak_n[phase], info["grip_force_n"], info["finger_force_n"])
            if terminated or truncated:
                break
    finally:
        env.close()
    out = {"slip_distance_m": info["slip_distance_m"],
           "peak_before_lift_n": peak_n["before_lift"], "peak_after_lift_n": peak_n["after_lift"],
           "crushed": info["crushed"], "dropped": info["dropped"], "lift_start_s": lift_start_s,
           "end_s": info["time_s"]}
    if with_reflex:
        out.update(ctl.counters(), final_boost=ctl.boost)
    return out


@pytest.fixture(scope="module")
def runs() -> dict:
    return {flag: shake_episode(flag) for flag in (False, True)}


def test_reflex_reduces_slip_under_shake(runs):
    off, on = runs[False], runs[True]
    assert on["end_s"] == pytest.approx(3.5) and not on["dropped"]  # held to the end
    # without the reflex the can slips by centimetres (on this hand it is shaken out)
    assert off["slip_distance_m"] > 0.03
    assert on["slip_distance_m"] < 0.4 * off["slip_distance_m"]


def test_reflex_does_not_crush_or_fire_at_contact(runs):
    on = runs[True]
    assert not on["crushed"]
    # the reflex changes nothing before the lift (same contact transient, bit for bit);
    # its reference stays below the ceiling, and the measured force (which also carries
    # the loop's overshoot and the shaken can's swings) below the break force
    assert on["peak_before_lift_n"] == runs[False]["peak_before_lift_n"] < BREAK_N
    assert on["peak_after_lift_n"] < BREAK_N
    assert on["reflex_onsets"] >= 1
    assert on["lift_start_s"] is not None
    assert on["reflex_first_onset_s"] > on["lift_start_s"]  # no onset at contact or before lift
    assert on["reflex_peak_reference_n"] <= (1.0 - MARGIN) * BREAK_N


def test_reflex_boost_decays_after_the_shake(runs):
    on = runs[True]
    assert on["final_boost"] < 0.5 * on["reflex_peak_boost"]


if __name__ == "__main__":  # the figures quoted in the reflex's report
    for flag in (False, True):
        print("reflex" if flag else "no reflex", shake_episode(flag))
