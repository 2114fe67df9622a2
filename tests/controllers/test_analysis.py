import control
import numpy as np
import pytest

from controllers.analysis import delay_margin, loop_margins, sweep_margins
from controllers.plant import delay, frequency_response


@pytest.fixture
def golden_loop():
    s = control.tf("s")
    return control.c2d(2 / (s**3 + 3 * s**2 + 2 * s), 0.05)


def test_golden_margins(golden_loop):
    m = loop_margins(golden_loop)
    assert 10 ** (m.gain_margin_db / 20) == pytest.approx(2.793, abs=5e-4)
    assert m.phase_margin_deg == pytest.approx(31.54, abs=5e-3)
    assert m.phase_crossover_rad_s == pytest.approx([1.364], abs=5e-4)
    assert m.crossover_rad_s == pytest.approx([0.749], abs=5e-4)
    assert m.stable


def test_golden_matches_sweep(golden_loop):
    m = loop_margins(golden_loop)
    sw = sweep_margins(golden_loop)
    assert sw.crossover_rad_s == pytest.approx(m.crossover_rad_s, rel=1e-5)
    assert sw.phase_margins_deg == pytest.approx(m.phase_margins_deg, abs=1e-3)
    assert sw.gain_margins_db == pytest.approx(m.gain_margins_db, abs=1e-3)
    assert sw.ms == pytest.approx(m.ms, rel=1e-3)


def test_delay_margin_in_whole_samples(golden_loop):
    m = loop_margins(golden_loop)
    dt = golden_loop.dt
    assert m.delay_margin_s == pytest.approx(np.deg2rad(m.phase_margin_deg) / 0.7493, rel=1e-3)
    k = m.delay_margin_samples
    assert k == int(np.floor(m.delay_margin_s / dt))
    assert loop_margins(golden_loop * delay(k, dt)).stable
    assert not loop_margins(golden_loop * delay(k + 1, dt)).stable


def test_delay_margin_uses_every_crossover():
    # pm 50 deg at 10 rad/s versus 20 deg at 40 rad/s: the second binds
    dm = delay_margin(np.array([50.0, 20.0]), np.array([10.0, 40.0]))
    assert dm == pytest.approx(np.deg2rad(20.0) / 40.0)
    # a negative phase margin means the lag to reach -1 wraps around 360 deg
    assert delay_margin(np.array([-10.0]), np.array([2.0])) == pytest.approx(
        np.deg2rad(350.0) / 2.0
    )


def test_all_crossovers_of_a_resonant_loop_found():
    # integrator + lightly damped resonance above crossover: |L| crosses 1 three times
    s = control.tf("s")
    wn, zeta = 20.0, 0.02
    loop_c = 2.0 / s * wn**2 / (s**2 + 2 * zeta * wn * s + wn**2)
    loop = control.c2d(loop_c, 0.005)
    m = loop_margins(loop)
    sw = sweep_margins(loop)
    assert len(m.crossover_rad_s) == 3
    assert sw.crossover_rad_s == pytest.approx(m.crossover_rad_s, rel=1e-4)
    assert sw.phase_margins_deg == pytest.approx(m.phase_margins_deg, abs=1e-2)
    assert len(m.phase_crossover_rad_s) == len(sw.phase_crossover_rad_s)


def test_closed_loop_poles_stability_and_bandwidth(golden_loop):
    m = loop_margins(golden_loop)
    expected = control.feedback(golden_loop, 1).poles()
    assert np.sort_complex(m.closed_loop_poles) == pytest.approx(np.sort_complex(expected))
    lval = frequency_response(golden_loop, np.array([1e-6, m.bandwidth_rad_s]))
    t_mag = np.abs(lval / (1 + lval))
    assert t_mag[1] == pytest.approx(t_mag[0] / np.sqrt(2), rel=1e-6)


def test_unstable_loop_reported():
    s = control.tf("s")
    loop = control.c2d(2 / (s**3 + 3 * s**2 + 2 * s), 0.05) * 4.0  # gain beyond gm 2.79
    m = loop_margins(loop)
    assert not m.stable
    assert m.gain_margin_db < 0


def test_to_dict_contract(golden_loop):
    d = loop_margins(golden_loop).to_dict()
    for key in ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_rad_s",
                "ms", "closed_loop_poles", "stable", "loop"):
        assert key in d
    loop = d["loop"]
    rebuilt = control.ss(loop["A"], loop["B"], loop["C"], loop["D"], loop["dt"])
    w = np.array([0.3, 1.0, 5.0])
    assert frequency_response(rebuilt, w) == pytest.approx(frequency_response(golden_loop, w))


def test_batched_frequency_response_equals_python_control():
    import control

    from controllers.plant import frequency_response

    rng = np.random.default_rng(3)
    for dt in (None, 0.01):
        for n in (1, 4, 12):
            sys = control.rss(n, 1, 1) if dt is None else control.drss(n, 1, 1, dt=dt)
            sys = control.ss(np.asarray(sys.A), np.asarray(sys.B), np.asarray(sys.C),
                             rng.normal(size=(1, 1)), sys.dt)
            w = np.geomspace(0.01, 300.0 if dt else 1e3, 200)
            pts = np.exp(1j * w * dt) if dt else 1j * w
            expected = np.asarray(sys(pts)).reshape(-1)
            assert np.allclose(frequency_response(sys, w), expected, rtol=1e-9, atol=1e-12)
