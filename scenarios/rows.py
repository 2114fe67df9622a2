"""Typed result rows: the fields of each built-in scenario kind's result, in one place.

A runner returns a flat row of scalars (``scenarios.runners.dispatch.ResultRow``);
the store keeps it as JSON, the export flattens it and the report reads it.
For the built-in kinds the fields are declared here once, as dataclasses:
the runners build their rows through them (so a row has exactly these fields,
none missing and none extra), the export orders its columns by them and the
report reads rows back through :func:`typed_row`. Rows stored before a field
existed read back with ``None`` in it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from sim.errors import GriploopError


class RowError(GriploopError, ValueError):
    """A runner built a row with fields its kind does not declare, or without some."""


@dataclass(frozen=True)
class _Row:
    kind: ClassVar[str] = ""

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """The row's fields, in declaration order."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def build(cls, **values: Any) -> _Row:
        """The row of ``values``: every field given, and nothing else.

        Raises
        ------
        RowError
            A field missing, or a name the kind does not declare.
        """
        names = cls.field_names()
        extra = sorted(set(values) - set(names))
        missing = [n for n in names if n not in values]
        if extra or missing:
            raise RowError(f"{cls.kind} row: undeclared fields {extra}, missing {missing} "
                           f"(declared in scenarios.rows.{cls.__name__})")
        return cls(**values)

    @classmethod
    def from_result(cls, result: Mapping[str, Any]) -> _Row:
        """A stored result as this row: fields it lacks are ``None``, others ignored."""
        return cls(**{n: result.get(n) for n in cls.field_names()})

    def as_dict(self) -> dict[str, Any]:
        """The row as the store's flat mapping, in field order."""
        return {n: getattr(self, n) for n in self.field_names()}


@dataclass(frozen=True)
class EpisodeRow(_Row):
    """One closed-loop grasp-lift-hold episode (kind ``episode``).

    Identity: subject, seed, object, controller, estimator and its mode, the
    user and feedback, their practice (lifts, and the belief it left: contraction
    gain and safety margin), the feature window and the hand (``paradigm``, ``drive``,
    ``auto_grip``: the drive actually used). The trial: ``attempts`` (lifts started),
    ``time_to_lift_s`` (first contact to a secure lift) and ``safety_margin_pct`` (held
    grip over the slip force, minus 1, in the hold), ``None`` without a lift or hold. Metrics
    (:func:`scenarios.runners.episode_metrics.episode_metrics`): tracking and
    estimation error, transient, slip, outcome (:data:`scenarios.outcomes.OUTCOMES`).
    Loop: margins at the held force and the worst over the forces visited
    (:func:`controllers.design.worst_case`, prefixed ``worst_``; ``None`` when no
    force was visited). Calibration and timings (s).
    """

    kind: ClassVar[str] = "episode"

    subject_id: int | None
    seed: int | None
    object_name: str | None
    object_mass_kg: float | None
    object_friction: float | None
    object_break_force_n: float | None
    controller: str | None
    estimator: str | None
    mode: str | None
    scheduled: bool | None
    user: str | None
    feedback: str | None
    practice: int | None
    belief_gain: float | None
    belief_margin_pct: float | None
    window_ms: float | None
    step_ms: float | None
    paradigm: str | None
    drive: str | None
    auto_grip: bool | None
    decoder: str | None
    decoder_windows: int | None
    unrequested_opens: int | None
    user_corrections: int | None
    first_correction_s: float | None
    contact_time_s: float | None
    tracking_rmse_n: float | None
    estimation_rmse_n: float | None
    hold_reference_n: float | None
    overshoot_pct: float | None
    settling_time_s: float | None
    peak_force_n: float | None
    reference_volatility_n_per_s: float | None
    intended_grip_n: float | None
    slip_events: int | None
    slip_distance_m: float | None
    lifted: bool | None
    dropped: bool | None
    crushed: bool | None
    outcome: str | None
    attempts: int | None
    time_to_lift_s: float | None
    safety_margin_pct: float | None
    contact_peak_ratio: float | None
    both_sides_time_s: float | None
    held_force_n: float | None
    visited_forces_n: str | None
    gain_margin_db: float | None
    phase_margin_deg: float | None
    delay_margin_s: float | None
    ms: float | None
    crossover_rad_s: float | None
    n_crossovers: int | None
    stable: bool | None
    bandwidth_rad_s: float | None
    worst_gain_margin_db: float | None
    worst_gain_margin_at_n: float | None
    worst_phase_margin_deg: float | None
    worst_phase_margin_at_n: float | None
    worst_delay_margin_s: float | None
    worst_delay_margin_at_n: float | None
    worst_ms: float | None
    worst_ms_at_n: float | None
    worst_all_stable: bool | None
    worst_n_points: int | None
    worst_n_failed: int | None
    loop_dt_s: float | None
    mpc_failures: int | None
    cal_r2: float | None
    cal_mvc_n: float | None
    fit_s: float | None
    t_semg_s: float | None
    t_features_s: float | None
    t_estimator_s: float | None
    t_operator_s: float | None
    t_controller_s: float | None
    t_physics_s: float | None
    simulated_s: float | None
    realtime_factor: float | None


#: The ``worst_`` fields of :class:`EpisodeRow` (``None`` when no force was visited).
WORST_FIELDS = tuple(n for n in EpisodeRow.field_names() if n.startswith("worst_"))


@dataclass(frozen=True)
class CalibrationRow(_Row):
    """An estimator fitted on a calibration session, scored on its rest (kind ``calibration``)."""

    kind: ClassVar[str] = "calibration"

    subject_id: int | None
    estimator: str | None
    mode: str | None
    r2: float | None
    mvc_cal_n: float | None
    fit_s: float | None


@dataclass(frozen=True)
class ReproductionRow(_Row):
    """One subject x estimator x mode of the paper's evaluation (kind ``reproduction``)."""

    kind: ClassVar[str] = "reproduction"

    subject_id: int | None
    estimator: str | None
    mode: str | None
    order: int | None
    r2: float | None
    nrmse: float | None
    rmse_n: float | None
    volatility_n_per_s: float | None
    train_ms: float | None
    step_us: float | None
    n_windows: int | None
    n_identification: int | None
    session_s: float | None


#: Row types of the built-in kinds, by kind.
ROW_TYPES: dict[str, type[_Row]] = {t.kind: t for t in (EpisodeRow, CalibrationRow,
                                                       ReproductionRow)}


def typed_row(kind: str, result: Mapping[str, Any]) -> _Row | None:
    """The stored ``result`` of a scenario of ``kind`` as its row type (None: no type)."""
    row_type = ROW_TYPES.get(kind)
    return None if row_type is None else row_type.from_result(result)
