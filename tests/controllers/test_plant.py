import control
import numpy as np
import pytest

from controllers import PlantError, check_plant, loop_plant
from controllers.plant import frequency_response, truncate_slow_modes

DT_S = 0.01


def test_stable_plant_report(plant):
    rep = check_plant(plant)
    assert rep.dc_gain == pytest.approx(100.0)
    assert rep.n_integrators == 0
    assert rep.dt == DT_S
    expected = np.exp(-DT_S / np.array([0.06, 0.02]))
    assert np.sort(rep.poles.real) == pytest.approx(np.sort(expected))


def test_integrator_accepted():
    rep = check_plant(control.tf([0.5], [1.0, -1.0], DT_S))
    assert rep.n_integrators == 1
    assert rep.dc_gain == np.inf


def test_pole_zero_cancellation_rejected():
    tf = control.tf([1.0, -0.5], [1.0, -1.3, 0.4], DT_S)  # (z - 0.5) / ((z - 0.5)(z - 0.8))
    with pytest.raises(PlantError, match="minimal realization"):
        check_plant(tf)


def test_unobservable_mode_rejected():
    a = np.diag([0.5, 0.8])
    with pytest.raises(PlantError, match="unobservable"):
        check_plant(control.ss(a, [[1.0], [1.0]], [[1.0, 0.0]], [[0.0]], DT_S))


def test_uncontrollable_mode_rejected():
    a = np.diag([0.5, 0.8])
    with pytest.raises(PlantError, match="uncontrollable"):
        check_plant(control.ss(a, [[1.0], [0.0]], [[1.0, 1.0]], [[0.0]], DT_S))


def test_mimo_rejected():
    with pytest.raises(PlantError, match="SISO"):
        check_plant(control.ss(np.eye(2) * 0.5, np.eye(2), np.eye(2), np.zeros((2, 2)), DT_S))


def test_loop_plant_sample_and_hold_and_delay(plant_continuous, plant):
    lp = loop_plant(plant_continuous, DT_S, computation_delay_samples=2)
    w = np.array([1.0, 10.0, 100.0])
    expected = frequency_response(plant, w) * np.exp(-2j * w * DT_S)
    assert frequency_response(lp, w) == pytest.approx(expected, rel=1e-9)
    with pytest.raises(PlantError, match="dt_s"):
        loop_plant(plant_continuous)
    with pytest.raises(PlantError, match="equal to the plant's dt"):
        loop_plant(plant, 0.02)


def test_truncate_slow_modes_keeps_the_control_band(plant):
    # add a 50 s creep mode with a nearly cancelling zero
    creep = control.tf([1.0, -0.99975], [1.0, -0.9998], DT_S)
    full = plant * creep
    reduced, removed = truncate_slow_modes(full, 0.1)
    assert removed == pytest.approx([0.9998])
    assert reduced.nstates == 2
    w = np.array([5.0, 20.0, 100.0])
    assert np.abs(frequency_response(reduced, w)) == pytest.approx(
        np.abs(frequency_response(full, w)), rel=2e-3)
