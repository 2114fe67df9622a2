import control
import numpy as np
import pytest

from controllers import ContactGate, design_lead_lag, design_mpc, design_pid
from controllers.base import Observation


def _obs(force, ref=8.0):
    return Observation(time_s=0.0, reference_n=ref, grip_force_n=force)


@pytest.mark.parametrize("design", ["pid", "lead_lag", "mpc"])
def test_closing_then_bumpless_hand_over(plant, design):
    make = {"pid": lambda p: design_pid(p, crossover_rad_s=20.0),
            "lead_lag": lambda p: design_lead_lag(p, crossover_rad_s=30.0),
            "mpc": design_mpc}[design]
    gate = ContactGate(make(plant), closing_command=0.2, contact_force_n=0.5)
    ungated = make(plant)
    for _ in range(50):
        ungated.act(_obs(0.0))
    u_ungated = ungated.act(_obs(0.6))
    # no contact for 50 steps: the closing command is applied and the controller tracks it
    assert all(gate.act(_obs(0.0)) == 0.2 for _ in range(50))
    assert gate.controller.last_u == pytest.approx(0.2)
    # contact: the first force-controlled command starts from the closing command
    u = gate.act(_obs(0.6))
    assert gate.in_contact
    # a loop left running during the approach has wound up by contact; the MPC's
    # first move is bounded by its rate limit, counted from the closing command
    bound = gate.controller.du_max + 1e-9 if design == "mpc" else 0.15
    assert abs(u - 0.2) <= bound
    if design != "mpc":
        assert abs(u_ungated - 0.2) > 2 * abs(u - 0.2)
    # release: reference to zero with no force left opens the hand
    assert gate.act(_obs(0.0, ref=0.0)) == gate.opening_command
    assert not gate.in_contact


def test_loop_is_the_wrapped_controllers(plant):
    pid = design_pid(plant, crossover_rad_s=20.0)
    gate = ContactGate(pid)
    w = np.array([1.0, 20.0])
    lhs = control.ss(gate.loop(plant))
    rhs = control.ss(pid.loop(plant))
    assert np.allclose(lhs(np.exp(1j * w * 0.01)), rhs(np.exp(1j * w * 0.01)))


def test_hand_over_restarts_from_the_feedforward_command(plant):
    pid = design_pid(plant, crossover_rad_s=20.0)
    k_n = 80.0
    gate = ContactGate(pid, closing_command=0.2, contact_force_n=0.5, force_per_command_n=k_n)
    for _ in range(30):
        gate.act(_obs(0.0, ref=4.0))
    assert pid.last_u == pytest.approx(0.2)
    u = gate.act(_obs(0.6, ref=4.0))
    # a fresh controller tracking ref / K, then one PI step on the 3.4 N error
    fresh = design_pid(plant, crossover_rad_s=20.0)
    fresh.track(_obs(0.6, ref=4.0), 4.0 / k_n)
    assert u == pytest.approx(fresh.act(_obs(0.6, ref=4.0)))
    assert u < 0.2
    # a heavy reference never starts above the closing command
    heavy = ContactGate(design_pid(plant, crossover_rad_s=20.0), closing_command=0.2,
                        force_per_command_n=k_n)
    heavy.act(_obs(0.0, ref=50.0))
    u_heavy = heavy.act(_obs(0.6, ref=50.0))
    clamped = design_pid(plant, crossover_rad_s=20.0)
    clamped.track(_obs(0.6, ref=50.0), 0.2)  # min(closing 0.2, 50 / 80)
    assert u_heavy == pytest.approx(clamped.act(_obs(0.6, ref=50.0)))
    with pytest.raises(ValueError, match="force_per_command_n"):
        ContactGate(pid, force_per_command_n=0.0)
