"""check_estimator: shipped estimators pass, and each fault is one line naming its check."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.base import ForceEstimator
from estimation.checks import ATOL_N, check_estimator, standard_data
from estimation.registry import UnknownEstimatorError, register_estimator, unregister_estimator


class Mean(ForceEstimator):
    """The mean calibration force, in both modes; ``fault`` picks what goes wrong."""

    def __init__(self, *, fault: str = "") -> None:
        self.fault = fault

    def fit(self, U: np.ndarray, y: np.ndarray) -> Mean:
        self.mean_ = float(np.mean(y))
        if self.fault == "unseeded":  # a fresh, unseeded draw at every fit
            self.mean_ += float(np.random.default_rng().normal())
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        self._mode(mode, y)
        out = np.full(np.asarray(U).shape[0], self.mean_)
        if self.fault == "nan":
            out[-1] = np.nan
        return out

    def streaming(self, mode: str = "free_run", *, scaling=None, **options) -> MeanStream:
        value = self.mean_ if scaling is None else float(
            scaling.inverse_y(np.array([self.mean_]))[0])
        return MeanStream(value, keeps_count=self.fault == "no_reset")


class MeanStream:
    """A constant stream; with ``keeps_count`` it shifts by 0.1 at every ``reset()``."""

    def __init__(self, value: float, *, keeps_count: bool) -> None:
        self.value, self.keeps_count, self.run = value, keeps_count, 0

    def reset(self) -> None:
        self.run += 1

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        return self.value + (0.1 * (self.run - 1) if self.keeps_count else 0.0)


FAULTS = {"toy_mean_ok": "", "toy_mean_nan": "nan", "toy_mean_no_reset": "no_reset",
          "toy_mean_unseeded": "unseeded"}


@pytest.fixture
def toys():
    for name, fault in FAULTS.items():
        register_estimator(name, lambda fault=fault, **params: Mean(fault=fault, **params))
    register_estimator("toy_failing_factory", lambda **params: 1 / 0)
    yield
    for name in (*FAULTS, "toy_failing_factory"):
        unregister_estimator(name)


def test_the_standard_data_is_seeded():
    U, y = standard_data()
    U2, y2 = standard_data()
    assert np.array_equal(U, U2) and np.array_equal(y, y2)
    assert not np.array_equal(standard_data(seed=1)[1], y)
    assert U.shape[0] == y.shape[0] and np.all(U > 0)


@pytest.mark.parametrize("name", ["ridge", "ss_kf", "persistence"])
def test_shipped_estimators_pass(name):
    assert [f.line() for f in check_estimator(name)] == []


def test_a_good_toy_passes(toys):
    assert check_estimator("toy_mean_ok") == []


@pytest.mark.parametrize("name, check", [
    ("toy_mean_nan", "finite_prediction"),
    ("toy_mean_no_reset", "stream_reset_reproduces"),
    ("toy_mean_unseeded", "refit_reproduces"),
    ("toy_failing_factory", "build"),
])
def test_each_fault_is_reported_in_one_line_naming_its_check(toys, name, check):
    failures = check_estimator(name)
    assert failures and {f.check for f in failures} == {check}, [f.line() for f in failures]
    for failure in failures:
        line = failure.line()
        assert line.startswith(f"estimator {name}: {check}: expected ") and "\n" not in line


def test_the_stream_check_states_its_tolerance_and_names_the_mode(toys):
    (failure, *_) = check_estimator("toy_mean_no_reset")
    assert failure.expected.startswith(("one_step:", "free_run:"))
    assert f"{ATOL_N:g} N" in failure.expected


def test_an_unknown_name_is_refused():
    with pytest.raises(UnknownEstimatorError):
        check_estimator("no_such_estimator")
