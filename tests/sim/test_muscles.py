"""Muscle table, activation dynamics, electromechanical delay and drive fluctuations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.user.muscles import (
    MUSCLE_ROLES,
    MUSCLES,
    MuscleParams,
    MuscleParamsError,
    activation_dynamics,
    fractional_delay,
    muscle_force,
    slow_fluctuation,
)
from sim.user.subjects import make_population

FS = 200.0


def test_muscle_table_follows_the_paper():
    assert MUSCLES[0] == "pronator_teres" and MUSCLES[3] == "extensor_digitorum_communis"
    assert MUSCLES[5:] == ("flexor_carpi_ulnaris", "palmaris_longus", "flexor_carpi_radialis")
    assert [i for i, r in enumerate(MUSCLE_ROLES) if r == "flexor"] == [5, 6, 7]


def test_step_response_is_critically_damped_with_the_corner_time_constant():
    tau = 1.0 / (2 * np.pi * 3.0)
    x = np.zeros((400, 1))
    x[1:] = 1.0
    y = activation_dynamics(x, FS, 3.0)[:, 0]
    assert np.all(np.diff(y) >= -1e-15) and y.max() <= 1.0 + 1e-12  # no overshoot
    # continuous critically damped step: 1 - (1 + t/tau) e^{-t/tau} = 0.5 at t = 1.6783 tau
    t50 = (np.argmax(y >= 0.5)) / FS
    assert abs(t50 - 1.6783 * tau) <= 1.5 / FS
    assert y[-1] == pytest.approx(1.0, abs=1e-9)


def test_activation_starts_at_rest_at_the_first_value_and_has_unit_dc_gain():
    x = np.full((300, 3), 0.4)
    y = activation_dynamics(x, FS, np.array([2.5, 3.0, 3.5]))
    np.testing.assert_allclose(y, 0.4, atol=1e-12)


def test_fractional_delay_of_a_ramp_is_exact():
    x = np.arange(100.0)[:, None] * np.ones((1, 2))
    y = fractional_delay(x, np.array([0.05, 0.0625]), FS)  # 10 and 12.5 samples
    np.testing.assert_allclose(y[20:, 0], x[20:, 0] - 10.0)
    np.testing.assert_allclose(y[20:, 1], x[20:, 1] - 12.5)
    assert y[0, 0] == 0.0 and y[5, 1] == 0.0  # first value held


def test_muscle_force_lags_drive_by_the_emd():
    x = np.zeros((400, 2))
    x[50:] = 1.0
    y = muscle_force(x, FS, 3.0, np.array([0.04, 0.14]))
    onset = [int(np.argmax(y[:, j] > 1e-3)) for j in range(2)]
    assert onset[0] - 50 == pytest.approx(0.04 * FS, abs=2)
    assert onset[1] - 50 == pytest.approx(0.14 * FS, abs=2)


def test_slow_fluctuation_is_an_ou_process_with_the_given_std_and_time():
    rng = np.random.default_rng(3)
    z = slow_fluctuation(200_000, FS, np.array([0.1, 0.3]), 0.5, rng)
    np.testing.assert_allclose(z.std(axis=0), [0.1, 0.3], rtol=0.05)
    lag1 = np.corrcoef(z[1:, 0], z[:-1, 0])[0, 1]
    assert lag1 == pytest.approx(np.exp(-1.0 / (0.5 * FS)), abs=2e-3)


def test_params_validate_length_and_sign():
    good = make_population(1, 0)[0].muscles
    with pytest.raises(MuscleParamsError, match="expected 8 values, found 3"):
        dataclasses.replace(good, synergy=(0.5, 0.5, 0.5))
    with pytest.raises(ValueError, match="non-negative"):
        dataclasses.replace(good, emd_s=(-0.1,) + good.emd_s[1:])
    assert isinstance(good, MuscleParams)
    assert good.to_dict()["synergy"] == list(good.synergy)
