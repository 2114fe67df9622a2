import control
import pytest

from controllers import SlipReflex, SpecificationError, force_bounds, slip_threshold_n
from controllers.base import Observation


def test_slip_threshold_matches_calibration():
    # CALIBRATION.md: 0.2 kg box, mu = 1, two-sided pinch -> 0.98 N
    assert slip_threshold_n(0.2, 1.0) == pytest.approx(0.2 * 9.81 / 2.0)
    assert slip_threshold_n(0.2, 1.0) == pytest.approx(0.98, abs=0.01)


def test_force_bounds_and_infeasible_object():
    b = force_bounds(0.4, 0.5, fragility_limit_n=30.0, safety_factor=1.5)
    assert b.min_n == pytest.approx(1.5 * 0.4 * 9.81 / 1.0)
    assert b.max_n == 30.0
    with pytest.raises(SpecificationError, match=r"needs at least 5.89 N .* breaks at 4 N"):
        force_bounds(0.4, 0.5, fragility_limit_n=4.0)


class _Echo:
    """Returns the reference it is given, so the reflex's output is visible."""

    name = "echo"

    def reset(self):
        self.resets = getattr(self, "resets", 0) + 1

    def act(self, obs):
        return obs.reference_n

    def loop(self, plant):
        return plant


def _obs(k, slip=False, ref=5.0, speed=0.0):
    return Observation(time_s=k * 0.01, reference_n=ref, grip_force_n=ref,
                       slip_detected=slip, slip_speed_m_s=speed)


def test_reflex_latency_gain_and_release():
    reflex = SlipReflex(_Echo(), dt_s=0.01, latency_s=0.03, step_n=0.5,
                        speed_gain_n_s_per_m=100.0, max_boost_n=2.0)
    assert reflex.latency_samples == 3
    refs = [reflex.act(_obs(0, slip=True, speed=0.002))]
    refs += [reflex.act(_obs(k)) for k in range(1, 6)]
    # the single slip sample acts 3 periods later: +0.5 + 100 * 0.002 N, then held
    assert refs == pytest.approx([5.0, 5.0, 5.0, 5.7, 5.7, 5.7])
    for k in range(6, 20):
        reflex.act(_obs(k, slip=True))
    assert reflex.boost_n == 2.0  # capped
    assert reflex.act(_obs(20, ref=0.1)) == pytest.approx(0.1)  # opening the hand clears it
    assert reflex.boost_n == 0.0


def test_reflex_respects_fragility_and_delegates_loop():
    inner = _Echo()
    reflex = SlipReflex(inner, dt_s=0.01, latency_s=0.0, step_n=5.0, max_reference_n=8.0)
    assert reflex.act(_obs(0, slip=True)) == 8.0
    plant = control.tf([1.0], [1.0, -0.5], 0.01)
    assert reflex.loop(plant) is plant
    reflex.reset()
    assert reflex.boost_n == 0.0 and inner.resets == 2


def test_reflex_onset_fraction_boosts_once_per_slip_event():
    class Echo:
        def reset(self):
            pass

        def act(self, obs):
            return obs.reference_n

    reflex = SlipReflex(Echo(), dt_s=0.01, latency_s=0.02, step_n=0.0, onset_fraction=0.5)
    slipping = [False, True, True, True, False, False, True, False, False, False]
    refs = [reflex.act(Observation(0.01 * k, 4.0, 4.0, slip_detected=s))
            for k, s in enumerate(slipping)]
    # two onsets, each seen two samples (20 ms) late, each adds half of the 4 N reference
    assert refs == [4.0, 4.0, 4.0, 6.0, 6.0, 6.0, 6.0, 6.0, 8.0, 8.0]
    assert reflex.n_onsets == 2
