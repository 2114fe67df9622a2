import control
import numpy as np
import pytest

from controllers import IdentificationError, identify_low_order

DT_S = 0.01


def _step_data(sys, n=120, n_pre=10, du=0.3):
    u = np.concatenate([np.zeros(n_pre), np.full(n - n_pre, du)])
    y = control.forced_response(sys, T=np.arange(n) * DT_S, U=u).outputs
    return u, np.asarray(y).ravel()


def test_recovers_second_order_plus_delay(plant):
    u, y = _step_data(plant * control.tf([1.0], [1.0, 0.0, 0.0], DT_S))
    ident = identify_low_order(u + 0.1, y + 5.0, DT_S, order=2)
    assert ident.gain_n == pytest.approx(100.0, rel=1e-4)
    assert ident.time_constants_s == pytest.approx((0.06, 0.02), rel=1e-3)
    assert ident.delay_samples == 2
    assert ident.fit_percent > 99.9
    assert (ident.u0, ident.y0) == (pytest.approx(0.1), pytest.approx(5.0))


def test_noisy_data_fit_is_measured(plant):
    u, y = _step_data(plant)
    rng = np.random.default_rng(7)
    y_noisy = y + rng.normal(0.0, 0.3, y.size)
    ident = identify_low_order(u, y_noisy, DT_S, order=2)
    assert ident.gain_n == pytest.approx(100.0, rel=0.02)
    resid = y_noisy - y_noisy[0] - np.asarray(control.forced_response(
        ident.model, T=np.arange(u.size) * DT_S, U=u - u[0]).outputs).ravel()
    assert ident.rms_error_n == pytest.approx(np.sqrt(np.mean(resid**2)), rel=1e-6)


def test_auto_order_prefers_first_order_for_a_first_order_system():
    s = control.tf("s")
    first = control.c2d(80.0 / (0.05 * s + 1), DT_S)
    u, y = _step_data(first)
    ident = identify_low_order(u, y, DT_S)
    assert len(ident.time_constants_s) == 1
    assert ident.time_constants_s[0] == pytest.approx(0.05, rel=1e-4)


@pytest.mark.parametrize(
    ("u", "y", "match"),
    [(np.ones(50), np.arange(50.0), "constant u"),
     (np.arange(10.0), np.arange(10.0), "at least 20"),
     (np.arange(50.0), np.arange(40.0), "equal length"),
     (np.r_[np.zeros(10), np.ones(40)], np.full(50, np.nan), "finite")],
)
def test_bad_data_rejected(u, y, match):
    with pytest.raises(IdentificationError, match=match):
        identify_low_order(u, y, DT_S)
