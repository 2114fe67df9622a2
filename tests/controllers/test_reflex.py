"""The slip reflex: armed by an established grasp, multiplicative boost, decay, ceiling, release."""

import math

import control
import pytest

from controllers import SlipReflex
from controllers.base import Observation
from controllers.reflex import ReflexSpec, ReflexSpecError

DT = 0.01


class _Echo:
    """Returns the reference it is given, so the reflex's output is visible."""

    name = "echo"

    def __init__(self):
        self.resets = 0
        self.tracked = []

    def reset(self):
        self.resets += 1

    def act(self, obs):
        return obs.reference_n

    def track(self, obs, u):
        self.tracked.append((obs.reference_n, u))

    def loop(self, plant):
        return plant


def _obs(k, *, speed=0.0, ref=5.0, thumb=True, finger=True):
    return Observation(time_s=k * DT, reference_n=ref, grip_force_n=ref, slip_speed_m_s=speed,
                       thumb_contact=thumb, finger_contact=finger)


def _reflex(**kw):
    spec = {"latency_s": 0.03, "gain": 0.4, "slip_speed_threshold_m_s": 0.02,
            "arming_s": 0.2, "decay_s": 0.5, "max_boost": 1.0}
    spec.update(kw)
    max_force_n = spec.pop("max_force_n", math.inf)
    return SlipReflex(_Echo(), ReflexSpec(**spec), dt_s=DT, max_force_n=max_force_n)


def _arm(reflex, ref=5.0):
    """Hold both sides for the arming time; returns the next step index."""
    k = 0
    while not reflex.armed:
        assert reflex.act(_obs(k, ref=ref)) == ref
        k += 1
    return k


def test_no_trigger_before_both_sides_touch_for_the_arming_time():
    reflex = _reflex(latency_s=0.0)
    # closing: one side pushes the object across the table at a large slip speed
    for k in range(50):
        assert reflex.act(_obs(k, speed=0.5, finger=False)) == 5.0
    # both sides touch: still no trigger during the 0.2 s arming time (21st step arms)
    for k in range(50, 70):
        assert reflex.act(_obs(k, speed=0.5)) == 5.0
        assert not reflex.armed
    # the arming count restarts if one side lets go before arming
    reflex.act(_obs(70, speed=0.5, finger=False))
    for k in range(71, 91):
        assert reflex.act(_obs(k, speed=0.5)) == 5.0
    assert reflex.n_onsets == 0 and reflex.boost == 0.0 and reflex.first_onset_s is None
    assert reflex.act(_obs(91, speed=0.5)) == pytest.approx(5.0 * 1.4)  # armed: (21 - 1) dt = 0.2 s
    assert reflex.n_onsets == 1 and reflex.first_onset_s == pytest.approx(0.91)


def test_slip_below_threshold_does_not_trigger():
    reflex = _reflex(latency_s=0.0)
    k = _arm(reflex)
    for j in range(k, k + 50):
        assert reflex.act(_obs(j, speed=0.0199)) == 5.0
    assert reflex.n_triggers == 0


def test_onset_boost_is_gain_times_reference_after_the_latency():
    reflex = _reflex()
    assert reflex.latency_samples == 3
    k = _arm(reflex, ref=4.0)
    refs = [reflex.act(_obs(k, speed=0.1, ref=4.0))]  # one slipping sample
    refs += [reflex.act(_obs(k + j, ref=4.0)) for j in range(1, 4)]
    assert refs[:3] == [4.0, 4.0, 4.0]
    assert refs[3] - 4.0 == pytest.approx(0.4 * 4.0, abs=1e-12)  # gain * reference
    assert reflex.n_onsets == 1 and reflex.n_triggers == 1
    assert reflex.first_onset_s == pytest.approx(k * DT)  # detection time, before the latency


def test_boost_decays_exponentially_in_closed_form():
    reflex = _reflex(latency_s=0.0, gain=0.6, decay_s=0.37)
    k = _arm(reflex)
    reflex.act(_obs(k, speed=0.1))
    b0 = reflex.boost
    assert b0 == pytest.approx(0.6)
    for n in range(1, 301):
        out = reflex.act(_obs(k + n))
        expected = b0 * math.exp(-n * DT / 0.37)
        assert abs(reflex.boost - expected) < 1e-9
        assert abs(out - 5.0 * (1.0 + expected)) < 1e-9
    assert reflex.peak_boost == pytest.approx(0.6)


def test_continuing_slip_adds_boost_per_metre_and_is_capped():
    reflex = _reflex(latency_s=0.0, gain=0.2, distance_gain_per_m=50.0, max_boost=0.5)
    k = _arm(reflex)
    reflex.act(_obs(k, speed=0.1))  # onset: 0.2 + 50 * 0.1 * 0.01 = 0.25
    assert reflex.boost == pytest.approx(0.25)
    reflex.act(_obs(k + 1, speed=0.1))  # continuing slip: + 0.05, no new onset
    assert reflex.boost == pytest.approx(0.30) and reflex.n_onsets == 1
    for j in range(2, 40):
        reflex.act(_obs(k + j, speed=0.1))
    assert reflex.boost == 0.5 and reflex.n_triggers == 40  # capped by max_boost


def test_each_slip_event_is_one_onset():
    reflex = _reflex(latency_s=0.02, gain=0.5, decay_s=math.inf)
    k = _arm(reflex, ref=4.0)
    slipping = [False, True, True, True, False, False, True, False, False, False]
    refs = [reflex.act(_obs(k + j, speed=0.1 if s else 0.0, ref=4.0))
            for j, s in enumerate(slipping)]
    # two onsets, each acting two samples (20 ms) late, each adds half of the 4 N reference
    assert refs == pytest.approx([4.0, 4.0, 4.0, 6.0, 6.0, 6.0, 6.0, 6.0, 8.0, 8.0])
    assert reflex.n_onsets == 2 and reflex.n_triggers == 4


@pytest.mark.parametrize("ref", [1.0, 3.0, 5.0, 7.0, 7.9, 8.0])
def test_output_never_exceeds_the_ceiling(ref):
    reflex = _reflex(latency_s=0.0, gain=0.8, max_boost=3.0, max_force_n=10.0,
                     fragility_margin=0.2)
    assert reflex.ceiling_n == pytest.approx(8.0)
    k = _arm(reflex, ref=ref)
    outs = [reflex.act(_obs(k + j, speed=0.1 if j % 3 else 0.0, ref=ref)) for j in range(60)]
    assert max(outs) <= 8.0 + 1e-12
    assert min(outs) >= ref
    assert reflex.peak_reference_n <= 8.0 + 1e-12
    # no wind-up above the ceiling: the boost is what the ceiling lets through
    assert reflex.boost <= 8.0 / ref - 1.0 + 1e-12


def test_user_reference_above_the_ceiling_passes_unchanged():
    reflex = _reflex(latency_s=0.0, max_force_n=10.0, fragility_margin=0.2)
    k = _arm(reflex, ref=9.0)
    for j in range(20):
        assert reflex.act(_obs(k + j, speed=0.2, ref=9.0)) == 9.0  # never lowered, nothing added
    assert reflex.boost == 0.0


def test_release_and_contact_loss_clear_the_boost():
    reflex = _reflex(latency_s=0.0, decay_s=math.inf)
    k = _arm(reflex)
    assert reflex.act(_obs(k, speed=0.1)) == pytest.approx(7.0)
    # one side lost while armed (contact flickers under slip): boost kept
    assert reflex.act(_obs(k + 1, finger=False)) == pytest.approx(7.0)
    assert reflex.act(_obs(k + 2, ref=0.3)) == 0.3  # the user opens the hand
    assert reflex.boost == 0.0 and not reflex.armed
    k = _arm(reflex)
    assert reflex.act(_obs(k, speed=0.1)) == pytest.approx(7.0)
    assert reflex.act(_obs(k + 1, thumb=False, finger=False)) == 5.0  # contact lost
    assert reflex.boost == 0.0 and not reflex.armed
    assert reflex.act(_obs(k + 2, speed=0.1)) == 5.0  # re-touching needs arming again
    assert reflex.n_onsets == 2


def test_pending_slip_in_the_latency_line_is_dropped_on_release():
    reflex = _reflex(latency_s=0.05)
    k = _arm(reflex)
    reflex.act(_obs(k, speed=0.1))
    reflex.act(_obs(k + 1, ref=0.2))
    k = _arm(reflex)
    outs = [reflex.act(_obs(k + j)) for j in range(10)]
    assert outs == [5.0] * 10 and reflex.n_onsets == 0


def test_reset_counters_interface_and_loop():
    inner = _Echo()
    reflex = SlipReflex(inner, ReflexSpec(latency_s=0.0), dt_s=DT)
    assert reflex.name == "echo+reflex"
    k = _arm(reflex)
    reflex.act(_obs(k, speed=0.1))
    row = reflex.counters()
    assert row["reflex_onsets"] == 1 and row["reflex_triggers"] == 1
    assert row["reflex_peak_boost"] == pytest.approx(0.3)
    assert row["reflex_peak_reference_n"] == pytest.approx(6.5)
    assert row["reflex_first_onset_s"] == pytest.approx(k * DT)
    reflex.track(_obs(k + 1), 0.25)  # passes the boosted reference through
    assert inner.tracked[-1][1] == 0.25 and inner.tracked[-1][0] > 5.0
    plant = control.tf([1.0], [1.0, -0.5], DT)
    assert reflex.loop(plant) is plant
    reflex.reset()
    assert (reflex.boost, reflex.n_onsets, reflex.n_triggers, reflex.peak_boost) == (0, 0, 0, 0)
    assert reflex.first_onset_s is None and inner.resets == 2


def test_act_accepts_a_mapping():
    reflex = SlipReflex(_Echo(), ReflexSpec(arming_s=0.0, latency_s=0.0), dt_s=DT)
    obs = {"time_s": 0.0, "reference_n": 2.0, "grip_force_n": 2.0, "slip_speed_m_s": 0.5,
           "thumb_contact": True, "finger_contact": True}
    assert reflex.act(obs) == pytest.approx(2.6)


@pytest.mark.parametrize(("kw", "message"), [
    ({"dt_s": 0.0}, r"expected dt_s > 0 s, found 0.0"),
    ({"latency_s": -0.01}, r"expected latency_s >= 0 s, found -0.01"),
    ({"gain": -1.0}, r"expected gain >= 0, found -1.0"),
    ({"gain": float("nan")}, r"expected gain >= 0, found nan"),
    ({"slip_speed_threshold_m_s": 0.0}, r"expected slip_speed_threshold_m_s > 0 m/s, found 0.0"),
    ({"arming_s": -1}, r"expected arming_s >= 0 s, found -1"),
    ({"decay_s": 0.0}, r"expected decay_s > 0 s, found 0.0"),
    ({"max_boost": -0.1}, r"expected max_boost >= 0, found -0.1"),
    ({"distance_gain_per_m": -2.0}, r"expected distance_gain_per_m >= 0 per m, found -2.0"),
    ({"max_force_n": 0.0}, r"expected max_force_n > 0 N \(inf for no limit\), found 0.0"),
    ({"fragility_margin": 1.0}, r"expected fragility_margin in \[0, 1\), found 1.0"),
    ({"release_below_n": -0.5}, r"expected release_below_n >= 0 N, found -0.5"),
])
def test_invalid_parameters_say_expected_and_found(kw, message):
    context = {"dt_s": DT, "max_force_n": math.inf}
    settings = {k: v for k, v in kw.items() if k not in context}
    context.update({k: v for k, v in kw.items() if k in context})
    with pytest.raises(ReflexSpecError, match=message):
        SlipReflex(_Echo(), ReflexSpec(**settings), **context)
    assert issubclass(ReflexSpecError, ValueError)
