"""Pydantic models of a sweep file: the base scenario, and a grid or a seeded random design."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from scenarios.schema.models import DEFAULT_TIME_LIMIT_S, MAX_SEED, Scenario, StrictModel


class Uniform(StrictModel):
    """Uniform on ``[low, high)``."""

    dist: Literal["uniform"]
    low: float
    high: float

    @model_validator(mode="after")
    def _ordered(self) -> Uniform:
        _check_order(self.low, self.high)
        if not np.isfinite(self.high - self.low):
            raise ValueError(
                f"high - low must be a finite span (found low={self.low:g}, high={self.high:g})"
            )
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.uniform(self.low, self.high, n).tolist()


class LogUniform(StrictModel):
    """Log-uniform on ``[low, high)``, ``0 < low < high``."""

    dist: Literal["loguniform"]
    low: float = Field(gt=0.0)
    high: float = Field(gt=0.0)

    @model_validator(mode="after")
    def _ordered(self) -> LogUniform:
        _check_order(self.low, self.high)
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return np.exp(rng.uniform(np.log(self.low), np.log(self.high), n)).tolist()


class Normal(StrictModel):
    """Gaussian with mean ``mean`` and standard deviation ``sd``."""

    dist: Literal["normal"]
    mean: float = Field(ge=-1e300, le=1e300)
    sd: float = Field(gt=0.0, le=1e300)

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.normal(self.mean, self.sd, n).tolist()


class Integers(StrictModel):
    """Integers uniform on ``low..high`` inclusive."""

    dist: Literal["integers"]
    low: int = Field(ge=-(2**62), le=2**62)
    high: int = Field(ge=-(2**62), le=2**62)

    @model_validator(mode="after")
    def _ordered(self) -> Integers:
        if self.high < self.low:
            raise ValueError(f"high must be >= low (found low={self.low}, high={self.high})")
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return rng.integers(self.low, self.high, n, endpoint=True).tolist()


class Choice(StrictModel):
    """One of ``values`` with equal probability."""

    dist: Literal["choice"]
    values: list[Any] = Field(min_length=1)

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` draws."""
        return [self.values[int(i)] for i in rng.integers(0, len(self.values), n)]


Distribution = Annotated[
    Uniform | LogUniform | Normal | Integers | Choice, Field(discriminator="dist")
]


class RandomDesign(StrictModel):
    """A seeded random design: ``n`` scenarios with fields drawn independently.

    Attributes
    ----------
    n : int
        Number of scenarios.
    seed : int or None
        Seed of the draws; defaults to the sweep seed.
    params : dict of str to Distribution
        Dotted field path to its distribution.
    """

    n: int = Field(ge=1, le=1_000_000)
    seed: int | None = Field(None, ge=0, le=MAX_SEED)
    params: dict[str, Distribution] = Field(min_length=1)


class SweepConfig(StrictModel):
    """A sweep file: a base scenario expanded over a grid or a random design.

    Attributes
    ----------
    name : str or None
        Name of the sweep in the results store; defaults to the file stem.
    description : str
        Free text.
    seed : int
        Sweep seed: per-scenario seeds and random designs derive from it.
    replicates : int
        Copies of each design point; copies differ only by their derived seed.
    time_limit_s : float
        Wall-time limit of one scenario, s: a scenario still running after it
        is stopped and recorded as failed with a ``timeout`` error. Not part
        of the scenario's content hash.
    seed_by : list of str or None
        Dotted field paths (or sections, e.g. ``subject``) the derived seeds
        depend on. ``None``: the whole scenario, so every scenario draws
        independently. Listing e.g. ``[subject]`` gives every estimator,
        controller or object of one subject the same seed: common random
        numbers, for paired comparisons as in the paper.
    base : Scenario
        Values of every field the design does not set.
    grid : dict of str to list
        Dotted field path to the values it takes (cartesian product).
    random : RandomDesign or None
        Seeded random design.
    plugins : list of str
        Modules to import first, which register the controllers, estimators,
        objects or kinds the scenarios name (:mod:`scenarios.plugins`); loaded
        in the driver and in every worker.
    """

    name: str | None = Field(None, min_length=1, max_length=200, pattern=r"^[\w.\-]+$")
    description: str = ""
    plugins: list[Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z_][\w.]*$")]] = Field(
        default_factory=list)
    seed: int = Field(0, ge=0, le=MAX_SEED)
    replicates: int = Field(1, ge=1, le=10_000)
    time_limit_s: float = Field(DEFAULT_TIME_LIMIT_S, gt=0.0, le=86_400.0)
    seed_by: list[str] | None = Field(None, min_length=1)
    base: Scenario = Field(default_factory=Scenario)
    grid: dict[str, list[Any]] | None = None
    random: RandomDesign | None = None

    @model_validator(mode="after")
    def _one_design(self) -> SweepConfig:
        if self.grid is not None and self.random is not None:
            raise ValueError("give grid or random, not both (found both)")
        if self.grid is not None:
            for path, values in self.grid.items():
                if not values:
                    raise ValueError(f"grid path {path} needs at least one value (found [])")
        return self


def _check_order(low: float, high: float) -> None:
    if not high > low:
        raise ValueError(f"high must be > low (found low={low:g}, high={high:g})")
