"""Typed result rows: the runners produce exactly the declared fields, the export follows them."""

from __future__ import annotations

import csv

import pytest

from scenarios.execution.sweep import SweepExecution, plan, run_sweep
from scenarios.export import export_store
from scenarios.outcomes import OUTCOMES
from scenarios.rows import (
    ROW_TYPES,
    WORST_FIELDS,
    CalibrationRow,
    EpisodeRow,
    ReproductionRow,
    RowError,
    typed_row,
)
from scenarios.runners.calibration import run_calibration_scenario
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.runners.reproduction import run_reproduction_scenario
from scenarios.schema import expand_sweep, parse_scenario, parse_sweep
from scenarios.store import ResultStore
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject


def test_a_row_with_a_missing_or_undeclared_field_is_refused_in_one_line():
    values = dict.fromkeys(CalibrationRow.field_names(), 1.0)
    assert CalibrationRow.build(**values).as_dict() == values
    with pytest.raises(RowError) as info:
        CalibrationRow.build(**{**values, "r3": 0.5})
    assert str(info.value) == ("calibration row: undeclared fields ['r3'], missing [] "
                               "(declared in scenarios.rows.CalibrationRow)")
    del values["r2"]
    with pytest.raises(RowError, match=r"missing \['r2'\]"):
        CalibrationRow.build(**values)


def test_a_row_stored_before_a_field_existed_reads_back_with_none():
    old = {"subject_id": 3, "outcome": "held", "cal_r2": 0.9, "retired_field": 1}
    row = typed_row("episode", old)
    assert isinstance(row, EpisodeRow)
    assert (row.subject_id, row.outcome, row.cal_r2, row.user) == (3, "held", 0.9, None)
    assert typed_row("toy_kind", old) is None
    assert set(ROW_TYPES) == {"episode", "calibration", "reproduction"}


def test_an_episode_row_has_exactly_the_declared_fields():
    result = run_episode(VirtualSubject.sample(0, 0), make_object("can"),
                         EpisodeSpec(estimator="oracle", controller="pid", seed=3, episode_s=4.0,
                         hold_s=1.0))
    assert tuple(result.row) == EpisodeRow.field_names()
    assert result.row["outcome"] in OUTCOMES
    assert all(result.row[f] is not None for f in WORST_FIELDS)  # forces were visited


@pytest.mark.parametrize("kind, runner, row_type", [
    ("calibration", run_calibration_scenario, CalibrationRow),
    ("reproduction", run_reproduction_scenario, ReproductionRow),
])
def test_calibration_and_reproduction_rows_have_exactly_the_declared_fields(kind, runner,
                                                                            row_type):
    protocol = {"name": "paper_calibration"}
    scenario = parse_scenario({"kind": kind, "seed": 2, "protocol": protocol,
                               "estimator": {"name": "ridge", "mode": "free_run"}})
    row = runner(scenario)
    assert tuple(k for k in row if k != "traces") == row_type.field_names()
    assert row["estimator"] == "ridge" and row["r2"] is not None


def test_the_export_orders_result_columns_by_the_row_type(tmp_path):
    spec = parse_sweep({"base": {"kind": "calibration", "protocol": {"name": "paper_calibration"},
                                 "estimator": {"name": "ridge"}},
                        "grid": {"subject.subject_id": [1, 2]}})
    with ResultStore(tmp_path / "r.sqlite") as store:
        run_sweep(plan(expand_sweep(spec)), store, SweepExecution(workers=1), progress=False)
        (path,) = export_store(store, tmp_path / "table", ["csv"])
    with path.open() as f:
        header = next(csv.reader(f))
    results = [h.removeprefix("result.") for h in header if h.startswith("result.")]
    declared = CalibrationRow.field_names()
    assert tuple(results[:len(declared)]) == declared  # then what the dispatcher adds
    assert results[len(declared):] == ["kind"]
