import control
import numpy as np
import pytest

from controllers import ContactGate, GateSpec, design_lead_lag, design_mpc, design_pid
from controllers.base import Observation

K_N = 80.0  # feedforward: N per unit command


def _ff(ref_n: float) -> float:
    return ref_n / K_N


def _obs(force, ref=8.0, thumb=None, finger=None, velocity=0.0):
    touching = force > 0
    return Observation(time_s=0.0, reference_n=ref, grip_force_n=force,
                       thumb_contact=touching if thumb is None else thumb,
                       finger_contact=touching if finger is None else finger,
                       finger_velocity=velocity)


class Spy:
    """A controller that records what it is asked and answers a fixed command."""

    name = "spy"
    dt_s = 0.01
    computation_delay_samples = 1

    def __init__(self):
        self.calls = []

    def reset(self, u0=0.0):
        self.calls.append(("reset", u0))

    def act(self, obs):
        self.calls.append(("act", obs.reference_n))
        return 0.123

    def track(self, obs, u):
        self.calls.append(("track", u))

    def handover(self, obs, u):
        self.calls.append(("handover", u, obs.reference_n))

    def loop(self, plant):
        return plant


@pytest.mark.parametrize("design", ["pid", "lead_lag", "mpc"])
def test_closing_approach_then_bumpless_hand_over(plant, design):
    make = {"pid": lambda p: design_pid(p, crossover_rad_s=20.0),
            "lead_lag": lambda p: design_lead_lag(p, crossover_rad_s=30.0),
            "mpc": design_mpc}[design]
    gate = ContactGate(make(plant), closing_command=0.2, feedforward=_ff)
    # no contact: the closing command, tracked by the controller (no wind-up)
    assert all(gate.act(_obs(0.0)) == 0.2 for _ in range(30))
    assert gate.phase == "closing"
    assert gate.controller.last_u == pytest.approx(0.2)
    # the thumb alone touches: the speed servo starts at the feedforward command
    u = gate.act(_obs(0.6, thumb=True, finger=False, velocity=0.15))
    assert gate.phase == "approach"
    assert u == pytest.approx(_ff(8.0))
    # stalled (speed 0): the command rises, bounded by the closing command
    stalled = [gate.act(_obs(0.6, thumb=True, finger=False, velocity=0.0)) for _ in range(60)]
    assert np.all(np.diff(stalled) >= 0) and stalled[-1] == pytest.approx(0.2)
    assert gate.controller.last_u == pytest.approx(0.2)  # tracked: no wind-up
    # both sides, but below half the reference: still approaching
    gate.act(_obs(3.0))
    assert not gate.in_contact
    # both sides at half the reference: force control from the feedforward, reference
    # ramped from the measured grip, so the first command is the feedforward itself
    u = gate.act(_obs(4.0))
    assert gate.in_contact and gate.phase == "force"
    # (one step of the reference ramp away from it: far from the 0.2 closing command)
    bound = gate.controller.du_max + 1e-9 if design == "mpc" else 0.01
    assert abs(u - _ff(8.0)) <= bound
    # release: reference to zero with no contact left opens the hand
    assert gate.act(_obs(0.0, ref=0.0)) == gate.opening_command
    assert not gate.in_contact


def test_reference_rises_at_the_force_rate_after_the_hand_over():
    spy = Spy()
    gate = ContactGate(spy, feedforward=_ff, dt_s=0.01, spec=GateSpec(force_rate_n_s=20.0))
    gate.act(_obs(5.0, ref=10.0))  # hand-over at 5 N
    assert spy.calls[-2][0] == "handover"
    assert spy.calls[-2][1] == pytest.approx(_ff(10.0))
    assert spy.calls[-2][2] == pytest.approx(5.0)  # the controller starts at the grip
    refs = [spy.calls[-1][1]]
    for _ in range(40):
        gate.act(_obs(5.0, ref=10.0))
        refs.append(spy.calls[-1][1])
    steps = np.diff(refs)
    assert np.all(steps <= 20.0 * 0.01 + 1e-12)
    assert refs[-1] == pytest.approx(10.0)
    # a falling reference passes at once
    gate.act(_obs(5.0, ref=3.0))
    assert spy.calls[-1][1] == pytest.approx(3.0)


def test_losing_both_sides_returns_to_the_approach():
    spy = Spy()
    gate = ContactGate(spy, feedforward=_ff, dt_s=0.01, spec=GateSpec(lost_contact_s=0.05))
    gate.act(_obs(5.0, ref=6.0))
    assert gate.in_contact
    for _ in range(4):
        gate.act(_obs(5.0, ref=6.0, thumb=True, finger=False))
    assert gate.in_contact  # a flicker shorter than lost_contact_s is ignored
    gate.act(_obs(5.0, ref=6.0, thumb=True, finger=False))
    assert not gate.in_contact and gate.phase == "approach"


def test_loop_is_the_wrapped_controllers(plant):
    pid = design_pid(plant, crossover_rad_s=20.0)
    gate = ContactGate(pid)
    w = np.array([1.0, 20.0])
    lhs = control.ss(gate.loop(plant))
    rhs = control.ss(pid.loop(plant))
    assert np.allclose(lhs(np.exp(1j * w * 0.01)), rhs(np.exp(1j * w * 0.01)))


@pytest.mark.parametrize("kwargs", [{"closing_command": 0.0}, {"force_rate_n_s": 0.0},
                                    {"handover_fraction": 1.5}, {"approach_gain": -1.0}])
def test_bad_parameters_say_expected_and_found(kwargs):
    closing = {k: v for k, v in kwargs.items() if k == "closing_command"}
    spec = GateSpec(**{k: v for k, v in kwargs.items() if k != "closing_command"})
    with pytest.raises(ValueError, match="expected"):
        ContactGate(Spy(), **closing, spec=spec)
