"""``griploop published``: the board's rules on closed forms, and a smoke board that is well
formed (it asserts the board's shape, never an outcome)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.published.arms import BoardConfig, subject_seed
from scenarios.published.board import ROW_KEYS, board_row
from scenarios.published.findings import FINDING_IDS, FINDINGS
from scenarios.published.rules import (
    AGREES,
    DISAGREES,
    INCONCLUSIVE,
    VERDICTS,
    Band,
    Direction,
    Range,
    bootstrap_interval,
    combine,
    paired_differences,
)
from scenarios.runners.trial_outcome import margin_over_grip_pct

ISSUE_ORDER = ("bbt_intact", "bbt_prosthesis", "bbt_ratio", "bbt_feedback_with_vision",
               "dark_transfers_feedback", "slip_opening_discrete", "eggs_break_force",
               "force_matching_feedback", "rigid_held", "intact_margin")


# ------------------------------------------------------------------ rules
@pytest.mark.parametrize(("figure", "ci", "expected"), [
    (80.0, (60.0, 100.0), AGREES),         # in the range, whatever the interval
    (60.0, (50.0, 69.9), DISAGREES),       # the whole interval below
    (99.0, (95.1, 103.0), DISAGREES),      # the whole interval above
    (60.0, (50.0, 75.0), INCONCLUSIVE),    # outside, the interval reaching in
    (60.0, None, INCONCLUSIVE),            # one subject: no interval
    (None, None, INCONCLUSIVE),
])
def test_a_range_finding_follows_its_rule(figure, ci, expected) -> None:
    assert Range(70.0, 95.0).verdict(figure, ci) == expected


@pytest.mark.parametrize(("sign", "ci", "expected"), [
    (-1, (-2.0, -0.1), AGREES), (-1, (0.1, 2.0), DISAGREES), (-1, (-1.0, 1.0), INCONCLUSIVE),
    (+1, (0.2, 0.4), AGREES), (+1, (-0.4, -0.2), DISAGREES), (+1, None, INCONCLUSIVE),
])
def test_a_direction_is_the_interval_against_zero(sign, ci, expected) -> None:
    assert Direction(sign).verdict(ci) == expected


@pytest.mark.parametrize(("ci", "expected"), [
    ((-3.0, 6.0), AGREES), ((7.0, 9.0), DISAGREES), ((-12.0, -7.0), DISAGREES),
    ((2.0, 8.0), INCONCLUSIVE),
])
def test_a_band_holds_the_interval_within_the_noise(ci, expected) -> None:
    assert Band(6.5).verdict(ci) == expected


def test_parts_combine_strictly() -> None:
    assert combine([AGREES, AGREES]) == AGREES
    assert combine([AGREES, INCONCLUSIVE]) == INCONCLUSIVE
    assert combine([AGREES, DISAGREES, INCONCLUSIVE]) == DISAGREES
    assert combine([]) == INCONCLUSIVE


def test_pairs_are_made_by_subject_and_skip_missing_values() -> None:
    a = {1: 5.0, 2: 7.0, 3: None, 4: 1.0}
    b = {1: 4.0, 2: 9.0, 3: 2.0}
    assert paired_differences(a, b) == [1.0, -2.0]


def test_the_bootstrap_interval_is_seeded_and_covers_the_mean() -> None:
    data = np.arange(1.0, 21.0)
    one = bootstrap_interval(np.mean, data, np.random.default_rng(3))
    two = bootstrap_interval(np.mean, data, np.random.default_rng(3))
    assert one == two
    assert one[0] < 10.5 < one[1]
    # the standard error of the mean of 1..20 is 1.29: a 95 % interval about +-2.5 wide
    assert 1.5 < (one[1] - one[0]) / 2 < 3.5
    assert bootstrap_interval(np.mean, data[:1], np.random.default_rng(3)) is None


def test_the_relative_margin_is_westling_and_johanssons() -> None:
    # grip 1.25 x the slip force: 25 % above it, i.e. 20 % of the grip
    assert math.isclose(margin_over_grip_pct(25.0), 20.0)
    assert math.isclose(margin_over_grip_pct(0.0), 0.0)
    assert math.isclose(margin_over_grip_pct(100.0), 50.0)


# ------------------------------------------------------------------ the board
def test_the_board_has_the_issues_rows_in_order_each_with_source_and_rule() -> None:
    assert FINDING_IDS == ISSUE_ORDER
    for f in FINDINGS:
        assert f.source and f.rule and f.published and f.finding
        lo, hi = f.published_range
        assert lo <= hi


def test_every_arm_of_a_subject_shares_its_seed() -> None:
    config = BoardConfig(subjects=2, seed=5, smoke=True)
    seeds = {}
    for f in FINDINGS:
        for arm in f.arms(config).values():
            for subject, data in arm.scenarios(config.subjects, config.seed):
                if not arm.seed_per_variant:
                    seeds.setdefault(subject, set()).add(data["seed"])
    assert seeds == {1: {subject_seed(5, 1)}, 2: {subject_seed(5, 2)}}


def test_a_finding_without_results_is_failed_with_its_reason() -> None:
    config = BoardConfig(subjects=1, smoke=True)
    row = board_row(FINDINGS[0], config, {"intact": ["h1"]},
                    {"h1": {"status": "failed", "error": "PhysicsDivergedError: NaN\nmore"}},
                    None, np.random.default_rng(0))
    assert row["verdict"] == "failed"
    assert row["error"] == "intact: every scenario failed (PhysicsDivergedError: NaN)"
    assert row["source"] and row["rule"]
    row = board_row(FINDINGS[0], config, None, {}, "ScenarioError: bad field", None)
    assert row["verdict"] == "failed" and row["error"] == "ScenarioError: bad field"


@pytest.mark.slow
def test_a_smoke_board_is_well_formed(tmp_path, capsys) -> None:
    """The smoke board (1 subject, shortened protocols): its shape only, no outcome."""
    out = tmp_path / "board.json"
    plot = tmp_path / "board.png"
    db = tmp_path / "board.sqlite"
    code = main(["published", "--smoke", "--no-progress", "--json", str(out),
                 "--plot", str(plot), "--db", str(db)])
    assert code == 0
    board = json.loads(out.read_text())
    assert set(board) >= {"rows", "agree", "total", "subjects", "seed"}
    assert board["subjects"] == 1 and board["total"] == len(ISSUE_ORDER)
    assert [r["id"] for r in board["rows"]] == list(ISSUE_ORDER)
    for row in board["rows"]:
        assert set(row) >= set(ROW_KEYS)
        assert row["source"] and row["rule"] and row["published"]
        assert row["verdict"] in VERDICTS
        assert isinstance(row["condition"], dict)
        if row["verdict"] == "failed":
            assert row["error"] and "\n" not in row["error"]
        if row["ci95"] is not None:
            assert len(row["ci95"]) == 2
    assert board["agree"] == sum(r["verdict"] == "agrees" for r in board["rows"])
    assert plot.stat().st_size > 0
    printed = capsys.readouterr().out
    assert all(i in printed for i in ISSUE_ORDER)
    # the report judges the stored board again, by the same rules: the same verdicts
    assert main(["report", str(db), "--out", str(tmp_path / "report")]) == 0
    html = (tmp_path / "report" / "index.html").read_text()
    assert "Published findings" in html
    for row in board["rows"]:
        assert f">{row['id']}</td>" in html


@pytest.mark.parametrize(("argv", "flag"), [
    (["--subjects", "0"], "--subjects"), (["--paradigm", "nope"], "--paradigm"),
    (["--estimator", "nope"], "--estimator"), (["--workers", "0"], "--workers"),
])
def test_bad_options_are_refused_in_one_line(argv, flag, capsys) -> None:
    assert main(["published", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert flag in err and "\n" not in err
