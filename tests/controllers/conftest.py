"""A representative grip plant: motor + gearbox + finger + contact stiffness.

Around a steady grasp the command-to-force response is close to
``K / ((tau1 s + 1)(tau2 s + 1))`` with K ~ 100 N per unit command and time
constants of tens of ms; it is sampled at the 10 ms control period.
"""

import control
import pytest

GAIN_N = 100.0
TAU1_S = 0.06
TAU2_S = 0.02
DT_S = 0.01


@pytest.fixture
def plant_continuous() -> control.TransferFunction:
    s = control.tf("s")
    return GAIN_N / ((TAU1_S * s + 1) * (TAU2_S * s + 1))


@pytest.fixture
def plant(plant_continuous) -> control.TransferFunction:
    return control.c2d(plant_continuous, DT_S, method="zoh")
