"""The open/close decoders (estimation.decoding): calibration, hysteresis, conflict rules,
streams, refusals, metrics and the C export, on seeded synthetic MAV windows."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from estimation.decoding import (
    CLOSE,
    OPEN,
    REST,
    DecoderCalibrationError,
    NoOpenContractionsError,
    PatternDecoder,
    TwoSiteDecoder,
    UnknownDecoderError,
    decoder_names,
    decoder_windows,
    make_decoder,
    unrequested_closes,
    unrequested_opens,
)
from estimation.feature_window import FeatureWindow
from sim.errors import GriploopError

FLEXORS, EXTENSORS = [5, 6, 7], [2, 3, 4]  # 0-based columns of channels 6-8 and 3-5
REST_LSB, FULL_LSB = 2.0, 30.0


def synthetic(rng: np.random.Generator, ratio: float, *, blocks: int = 5, block: int = 12,
              noise: float = 0.12) -> tuple[np.ndarray, np.ndarray]:
    """Time-ordered blocks of rest, close, rest, open windows.

    Close: flexors high, extensors co-contracting at ``flexor / extensor = ratio``; open:
    extensors high, flexors low. Multiplicative log-normal noise on every channel.
    """
    X, y = [], []
    for _ in range(blocks):
        for label in (REST, CLOSE, REST, OPEN):
            level = rng.uniform(0.5, 1.0)
            for _ in range(block):
                row = np.full(8, REST_LSB)
                if label == CLOSE:
                    row[FLEXORS] += FULL_LSB * level
                    row[EXTENSORS] += FULL_LSB * level / ratio
                    row[[0, 1]] += 8.0 * level
                elif label == OPEN:
                    row[EXTENSORS] += FULL_LSB * level
                    row[FLEXORS] += 4.0 * level
                    row[[0, 1]] += 12.0 * level
                X.append(row * rng.lognormal(0.0, noise, 8))
                y.append(label)
    return np.array(X), np.array(y)


def exact_calibration() -> tuple[np.ndarray, np.ndarray]:
    """Noise-free windows: rest 2 LSB everywhere, close flexors 32, open extensors 32
    (so a site's level is ``(site - 2) / 30``)."""
    rest = np.full(8, REST_LSB)
    close, open_ = rest.copy(), rest.copy()
    close[FLEXORS] += FULL_LSB
    open_[EXTENSORS] += FULL_LSB
    X = np.array([rest] * 10 + [close] * 10 + [open_] * 10)
    return X, np.repeat([REST, CLOSE, OPEN], 10)


def sites(a_flexor: float, a_extensor: float) -> np.ndarray:
    """A window whose flexor and extensor sites sit at the given levels."""
    row = np.full(8, REST_LSB)
    row[FLEXORS] += FULL_LSB * a_flexor
    row[EXTENSORS] += FULL_LSB * a_extensor
    return row


DECODERS = [("two_site", {}), ("two_site", {"conflict": "first"}), ("pattern", {})]


# ----------------------------------------------------------------------------- windows
def test_decoder_windows_label_each_window_by_its_last_sample_and_drop_the_ambiguous():
    fs = 200.0
    rng = np.random.default_rng(1)
    emg = rng.integers(-20, 21, size=(2000, 8)).astype(np.int8)
    t = np.arange(2000)
    close = np.where((t >= 400) & (t < 900), 0.6, 0.0)
    close[900:925] = 0.07  # a fall between off and on: ambiguous
    open_ = np.where(t >= 1300, 0.8, 0.0)
    X, y, kept = decoder_windows(emg, close, open_, fs_hz=fs)
    window = FeatureWindow(fs, range(8), features=("mav",))
    rows, ends = window.push(emg)
    assert kept.shape == (rows.shape[0],)
    np.testing.assert_array_equal(X, rows[kept])
    last = ends[kept]
    expected = np.where(open_[last] >= 0.1, OPEN, np.where(close[last] >= 0.1, CLOSE, REST))
    np.testing.assert_array_equal(y, expected)
    assert not kept[np.searchsorted(ends, 900)]  # the window ending in the fall is dropped
    assert set(np.unique(y)) == {REST, CLOSE, OPEN}
    _, y_squeezes, _ = decoder_windows(emg, close, None, fs_hz=fs)  # no open intent: no opens
    assert OPEN not in y_squeezes


# ------------------------------------------------------------------- fit, decode, predict
@pytest.mark.parametrize("name, params", DECODERS)
def test_decoders_read_squeezes_and_opens_with_moderate_co_contraction(name, params):
    X, y = synthetic(np.random.default_rng(0), ratio=2.5)
    X_test, y_test = synthetic(np.random.default_rng(1), ratio=2.5)
    decoder = make_decoder(name, **params).fit(X, y)
    decoded = decoder.decode(X_test)
    assert decoded.shape == (X_test.shape[0], 2)
    assert np.all((decoded >= 0.0) & (decoded <= 1.0))
    assert not np.any((decoded[:, 0] > 0) & (decoded[:, 1] > 0))  # at most one nonzero
    labels = decoder.predict(X_test)
    assert np.mean(labels == y_test) > 0.9
    assert unrequested_opens(decoded, y_test).count == 0
    assert unrequested_closes(decoded, y_test).count == 0
    assert decoder.score(X_test, y_test) == pytest.approx(np.mean(labels == y_test))


def test_pattern_reads_extensor_dominant_squeezes_where_two_sites_open():
    """ratio 0.36: the extensor channels exceed the flexors during squeezes (the paper's
    most extensor-dominant subject). The pattern still reads close; the extensor site of
    the two-site decoder reaches its open level and the difference rule opens."""
    X, y = synthetic(np.random.default_rng(2), ratio=0.36)
    X_test, y_test = synthetic(np.random.default_rng(3), ratio=0.36)
    squeezes = X_test[y_test == CLOSE]
    assert np.all(squeezes[:, EXTENSORS].mean(axis=1) > squeezes[:, FLEXORS].mean(axis=1))
    pattern = PatternDecoder().fit(X, y).decode(X_test)
    two_site = TwoSiteDecoder().fit(X, y).decode(X_test)
    assert unrequested_opens(pattern, y_test).fraction <= 0.01
    assert np.mean(pattern[y_test == CLOSE, 0] > 0) > 0.9
    assert np.mean(pattern[y_test == OPEN, 1] > 0) > 0.9
    assert unrequested_opens(two_site, y_test).fraction > 0.5


@pytest.mark.parametrize("name, params", DECODERS)
def test_the_stream_equals_decode_and_starts_again_at_rest(name, params):
    X, y = synthetic(np.random.default_rng(4), ratio=1.0)
    decoder = make_decoder(name, **params).fit(X, y)
    decoded = decoder.decode(X)
    stream = decoder.stream()
    for _ in range(2):  # the second pass after reset() repeats the first
        steps = np.array([stream.step(row) for row in X])
        np.testing.assert_allclose(steps, decoded, rtol=0, atol=1e-12)
        stream.reset()


# --------------------------------------------------------------- hysteresis and conflicts
def test_two_site_hysteresis_keeps_the_previous_state_between_off_and_on():
    decoder = TwoSiteDecoder().fit(*exact_calibration())
    np.testing.assert_allclose(decoder.rest_, [REST_LSB, REST_LSB])
    np.testing.assert_allclose(decoder.max_, [REST_LSB + FULL_LSB] * 2)
    between = 0.11  # off 0.08 < 0.11 < on 0.15
    X = np.array([sites(between, 0), sites(0.5, 0), sites(between, 0), sites(0.05, 0),
                  sites(between, 0)])
    decoded = decoder.decode(X)
    np.testing.assert_allclose(decoded[:, 0], [0.0, 0.5, between, 0.0, 0.0], atol=1e-12)
    assert not decoded[:, 1].any()


def test_pattern_hysteresis_keeps_the_previous_state_between_off_and_on():
    X, y = synthetic(np.random.default_rng(0), ratio=2.5)
    decoder = PatternDecoder().fit(X, y)
    squeeze = X[y == CLOSE].mean(axis=0)
    candidates = np.outer(np.linspace(0.2, 0.4, 41), squeeze)  # the squeeze's pattern, weaker
    cls, level = decoder.window_levels(candidates).T
    weak = candidates[(cls == CLOSE) & (level > 0.09) & (level < 0.14)][0]  # off < level < on
    strong, rest = squeeze, np.full(8, REST_LSB)
    decoded = decoder.decode(np.array([weak, strong, weak, rest, weak]))
    (_, weak_level), (_, strong_level) = decoder.window_levels(np.array([weak, strong]))
    np.testing.assert_allclose(decoded[:, 0], [0.0, strong_level, weak_level, 0.0, 0.0],
                               atol=1e-12)
    assert not decoded[:, 1].any()


def test_pattern_reversals_pass_through_rest():
    X, y = synthetic(np.random.default_rng(0), ratio=2.5)
    decoder = PatternDecoder().fit(X, y)
    squeeze, opening = X[y == CLOSE].mean(axis=0), X[y == OPEN].mean(axis=0)
    decoded = decoder.decode(np.array([squeeze, opening, opening, squeeze, squeeze]))
    (_, close_level), (_, open_level) = decoder.window_levels(np.array([squeeze, opening]))
    # one window of the other direction stops the hand; the next one turns it on
    np.testing.assert_allclose(decoded, [[close_level, 0.0], [0.0, 0.0], [0.0, open_level],
                                         [0.0, 0.0], [close_level, 0.0]], atol=1e-12)


def test_conflict_rules_differ_when_both_sites_are_on():
    """Flexors on first (0.6), then the extensors rise to 0.8 with them, then the flexors
    relax: the difference rule opens at 0.8 - 0.6 as soon as both are on; first come keeps
    closing at 0.6 until the flexors let go."""
    X = np.array([sites(0, 0), sites(0.6, 0), sites(0.6, 0.8), sites(0.6, 0.8), sites(0, 0.8),
                  sites(0.5, 0.5)])
    calibration = exact_calibration()
    difference = TwoSiteDecoder(conflict="difference").fit(*calibration).decode(X)
    first = TwoSiteDecoder(conflict="first").fit(*calibration).decode(X)
    np.testing.assert_allclose(difference, [[0, 0], [0.6, 0], [0, 0.2], [0, 0.2], [0, 0.8],
                                            [0, 0]], atol=1e-12)
    np.testing.assert_allclose(first, [[0, 0], [0.6, 0], [0.6, 0], [0.6, 0], [0, 0.8],
                                       [0, 0.5]], atol=1e-12)


# ------------------------------------------------------------------- refused calibrations
def test_a_site_that_never_rises_above_rest_is_refused_naming_its_channels():
    X, y = exact_calibration()
    X[y == OPEN] = np.full(8, REST_LSB) + np.where(np.isin(np.arange(8), [0, 1]), 20.0, 0.05)
    with pytest.raises(DecoderCalibrationError) as info:
        TwoSiteDecoder().fit(X, y)
    message = str(info.value)
    assert "extensor site (channels 3, 4, 5)" in message and "\n" not in message
    assert "never rises above its rest level" in message
    assert isinstance(info.value, GriploopError) and isinstance(info.value, ValueError)
    X2, y2 = exact_calibration()
    X2[y2 == CLOSE] = REST_LSB
    with pytest.raises(DecoderCalibrationError, match=r"flexor site \(channels 6, 7, 8\)"):
        TwoSiteDecoder().fit(X2, y2)
    with pytest.raises(DecoderCalibrationError, match="never rises above"):
        PatternDecoder().fit(X2, y2)


@pytest.mark.parametrize("name", ["two_site", "pattern"])
def test_a_calibration_without_open_contractions_is_refused(name):
    X, y = exact_calibration()
    keep = y != OPEN
    with pytest.raises(NoOpenContractionsError, match="no open contractions") as info:
        make_decoder(name).fit(X[keep], y[keep])
    assert isinstance(info.value, DecoderCalibrationError) and "\n" not in str(info.value)


# --------------------------------------------------------------- scikit-learn conventions
def test_decoders_follow_scikit_learn_conventions():
    decoder = TwoSiteDecoder(flexor_channels=(7, 8), on_fraction=0.2, conflict="first")
    assert decoder.get_params() == {"flexor_channels": (7, 8), "extensor_channels": (3, 4, 5),
                                    "on_fraction": 0.2, "off_fraction": 0.08,
                                    "conflict": "first"}
    copy = clone(decoder)
    assert copy is not decoder and copy.get_params() == decoder.get_params()
    assert PatternDecoder().set_params(shrinkage=0.1).shrinkage == 0.1
    with pytest.raises(NotFittedError):
        decoder.decode(np.ones((3, 8)))
    with pytest.raises(NotFittedError):
        PatternDecoder().stream()
    fitted = clone(PatternDecoder()).fit(*exact_calibration())
    assert fitted.n_features_in_ == 8 and fitted.coef_.shape == (3, 8)
    assert not hasattr(clone(fitted), "coef_")
    with pytest.raises(GriploopError, match="expecting 8 features"):
        fitted.decode(np.ones((3, 7)))


def test_the_registry_makes_decoders_by_name():
    assert decoder_names()[:2] == ("two_site", "pattern")
    assert make_decoder("two_site", conflict="first").conflict == "first"
    with pytest.raises(UnknownDecoderError, match="two_site, pattern"):
        make_decoder("three_site")


# ----------------------------------------------------------------------------- metrics
def test_unrequested_opens_and_closes_count_by_hand():
    decoded = np.array([[0.5, 0], [0, 0.3], [0, 0], [0, 0.2], [0.4, 0], [0, 0], [0.1, 0],
                        [0, 0.9]])
    y = np.array([CLOSE, CLOSE, CLOSE, CLOSE, REST, REST, REST, OPEN])
    assert tuple(unrequested_opens(decoded, y)) == (0.5, 2, 4)
    assert unrequested_closes(decoded, y) == pytest.approx((2 / 3, 2, 3))
    assert np.isnan(unrequested_opens(decoded[:0], y[:0]).fraction)


# ----------------------------------------------------------------------------- C export
def _compiled(decoder, name, tmp_path):
    from estimation.export_c.decoders import export_decoder
    from scenarios.deploy.build import CompilerMissingError, compile_shared
    from sim.c_source import TYPES_HEADER, types_header

    model = export_decoder(decoder, name)
    (tmp_path / TYPES_HEADER).write_text(types_header(digests=[model.digest]))
    for file, text in model.files.items():
        (tmp_path / file).write_text(text)
    lib_path = tmp_path / "libdecoder.so"
    try:
        warnings = compile_shared([tmp_path / "griploop_decoder.c"], lib_path,
                                  extra=[f"-I{tmp_path}"])
    except CompilerMissingError:
        pytest.skip("no C compiler")
    assert warnings.strip() == ""
    lib = ctypes.CDLL(str(lib_path))
    lib.griploop_decoder_reset.restype = None
    lib.griploop_decoder_step.restype = None
    lib.griploop_decoder_label.restype = ctypes.c_int32
    return model, lib


@pytest.mark.parametrize("name, params", DECODERS)
def test_the_compiled_decoder_equals_python(name, params, tmp_path):
    X, y = synthetic(np.random.default_rng(5), ratio=0.8)
    decoder = make_decoder(name, **params).fit(X, y)
    X_test, _ = synthetic(np.random.default_rng(6), ratio=0.8, noise=0.3)
    expected = decoder.decode(X_test)
    model, lib = _compiled(decoder, name, tmp_path)
    assert model.kind == "decoder" and model.summary["decoder"] == name
    close, open_ = ctypes.c_float(), ctypes.c_float()
    out, labels = np.zeros_like(expected), []
    stream = decoder.stream()
    for run in range(2):  # again after a reset
        lib.griploop_decoder_reset()
        for i, row in enumerate(X_test.astype(np.float32)):
            lib.griploop_decoder_step(row.ctypes.data_as(ctypes.c_void_p), ctypes.byref(close),
                                      ctypes.byref(open_))
            out[i] = close.value, open_.value
            if run == 0:
                stream.step(X_test[i])
                labels.append((lib.griploop_decoder_label(), stream.label()))
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-5)
    assert all(c == p for c, p in labels)
    assert 0 < np.mean(expected[:, 0] > 0) < 1 and 0 < np.mean(expected[:, 1] > 0) < 1
