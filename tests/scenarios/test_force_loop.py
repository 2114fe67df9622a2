"""Closed-loop episodes on the MuJoCo hand: clean contact, steps, outcomes, sensed MPC bound.

These run the whole loop (gate, scheduled controller, hand) with references the
test writes, and every library object with the oracle reference.
"""

import numpy as np
import pytest

from controllers.bounds import slip_threshold_n
from controllers.design_cache import grasp_design
from scenarios.outcomes import outcome_of
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.runners.episode_metrics import contact_peak_ratio
from scenarios.runners.trial_loop import given_reference_trial
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject

DT = 0.01
LIBRARY = ([("ball", {}), ("cup", {}), ("block", {}), ("egg", {})]
           + [("can", {"mass_kg": m, "friction": f}) for m in (0.2, 0.4, 1.0)
              for f in (0.3, 0.5, 1.0)])

# the library tests design every object for every controller: started first on a parallel run
pytestmark = pytest.mark.slow


def _run(obj, kind, reference, episode_s, spec=None, *, loop=False):
    """The controller's own trial on ``reference``, lifting at 3.4 s once the grip holds."""
    design = grasp_design(obj, kind, DT, spec or {})
    trial = given_reference_trial(obj, design, reference[:int(round(episode_s / DT))],
                                  control_dt_s=DT, lift_at_s=3.4)
    assert trial.failure is None
    return (trial.traces(), trial.info) + ((trial,) if loop else ())


def test_contact_peak_ratio_and_outcome_closed_forms():
    t = np.arange(10) * 0.1
    ref = np.full(10, 2.0)
    grip = np.array([0, 0, 1.0, 2.6, 2.2, 2.0, 2.0, 2.0, 2.0, 9.0])
    both = np.array([0, 0, 1, 1, 1, 1, 1, 1, 1, 1], bool)
    ratio, t0 = contact_peak_ratio(t, ref, grip, both, window_s=0.5)
    assert t0 == pytest.approx(0.2) and ratio == pytest.approx(1.3)  # 9 N is after the window
    assert contact_peak_ratio(t, ref, grip, np.zeros(10, bool)) == (None, None)
    assert outcome_of(lifted=False, dropped=False, crushed=False) == "not_lifted"
    assert outcome_of(lifted=True, dropped=True, crushed=False) == "dropped"
    assert outcome_of(lifted=False, dropped=False, crushed=True) == "crushed"
    assert outcome_of(lifted=True, dropped=False, crushed=False) == "held"


@pytest.mark.verdict
@pytest.mark.parametrize("kind", ["pid", "lead_lag", "mpc"])
def test_library_with_the_oracle_is_held_without_a_slam(kind):
    subject = VirtualSubject.sample(0, 1)
    bad = []
    for name, overrides in LIBRARY:
        row = run_episode(subject, make_object(name, **overrides),
                          EpisodeSpec(estimator="oracle", controller=kind, seed=0)).row
        if row["outcome"] != "held" or not row["contact_peak_ratio"] <= 1.3:
            bad.append((name, overrides, row["outcome"], row["contact_peak_ratio"]))
    assert not bad


@pytest.mark.parametrize("kind", ["pid", "lead_lag"])
def test_a_5_to_6_n_step_in_the_air_overshoots_little(kind):
    obj = make_object("can", mass_kg=0.2, friction=1.0)
    t = np.arange(650) * DT
    ref = np.where(t > 1.0, 5.0, 0.0)
    ref[t >= 5.0] = 6.0
    traces, info = _run(obj, kind, ref, 6.5)
    assert info["object_height_m"] > 0.1  # in the air
    g, tt = traces["grip_force_n"], traces["t_s"]
    before = g[(tt > 4.5) & (tt < 5.0)].mean()
    overshoot = (g[tt >= 5.0].max() - 6.0) / (6.0 - before)
    assert before == pytest.approx(5.0, abs=0.05)
    assert overshoot <= 0.15


def test_mpc_sensed_bound_holds_what_pi_drops():
    # the user asks 10 % less than the slip threshold m g / (2 mu) of a 0.3 kg can at
    # friction 0.5; the PI follows and the can slides out during the lift, while the
    # MPC raises its lower bound from the weight it feels and the slip it senses
    obj = make_object("can", mass_kg=0.3, friction=0.5)
    t = np.arange(600) * DT
    ref = np.where(t > 1.0, 0.9 * slip_threshold_n(0.3, 0.5), 0.0)
    _, pid = _run(obj, "pid", ref, 6.0)
    _, mpc = _run(obj, "mpc", ref, 6.0)
    assert pid["dropped"]
    assert not mpc["dropped"] and mpc["object_height_m"] > 0.1


def test_a_hand_that_never_closes_is_not_lifted_and_not_ok():
    # an estimate that never rises above the release level: the hand stays open
    obj = make_object("can")
    traces, info, trial = _run(obj, "pid", np.full(400, 0.05), 4.0, loop=True)
    assert traces["grip_force_n"].max() == 0.0
    assert trial.referee.secure_lift_s is None and not info["dropped"]
    assert trial.referee.attempts == 0  # the scripted arm lifts only a grip that formed
    assert trial.referee.outcome == "not_lifted" and trial.ended == "duration"
