"""The Box and Blocks Test as published: its 25 mm cube, its scoring, the command's contract.

The published rules (Mathiowetz et al. 1985): 2.5 cm wooden cubes, a 15.2 cm partition,
60 s; a block counts once carried over the partition and let go, or dropped beyond it.
The scoring is tested on synthetic outcomes (no physics), the cube's mass against its
closed form, and one short real run of the cube against the count.
"""

from __future__ import annotations

import json
import math
import textwrap

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.feedback_summary import aggregate
from scenarios.runners.dispatch import run_scenario
from scenarios.runners.transfers import (
    COUNT_KEYS,
    PARTITION_CLEARANCE_M,
    PARTITION_HEIGHT_M,
    carried_over,
    transfer_count,
)
from scenarios.schema import ScenarioError, load_sweep, parse_scenario
from sim.hand import model as hand_model
from sim.hand.objects import make_object

CUBE_HALF_M = 0.0125


# ------------------------------------------------------------------ the cube
def test_the_cube_weighs_its_volume_times_the_wood_density() -> None:
    cube = make_object("bbt_cube")
    assert cube.shape == "box" and cube.size_m == pytest.approx((CUBE_HALF_M,) * 3)
    # 2.5 cm cube of wood at 650 kg/m^3 (Roth 1895: 0.60-0.70 for maple, beech, birch)
    assert cube.mass_kg == pytest.approx(0.025 ** 3 * 650.0, rel=1e-12)
    assert 0.0094 < cube.mass_kg < 0.0110  # the density range's 9.4-10.9 g
    assert cube.breakable is False


def test_the_hand_meets_the_cube_on_its_sides_and_other_objects_where_it_did() -> None:
    for name in ("ball", "can", "cup", "egg", "block", "vet_block", "transfer_block"):
        obj = make_object(name)
        old = max(obj.half_height_m + hand_model.PAD_LEVER_M,
                  hand_model.FINGER_LENGTH_M + 0.011 + 0.01) + hand_model.HINGE_BELOW_PALM_M
        assert hand_model.approach_height_m(obj) == old, name
    cube = make_object("bbt_cube")
    hinge_m = hand_model.approach_height_m(cube) - hand_model.HINGE_BELOW_PALM_M
    tip_m = hinge_m - hand_model.fingertip_meet_depth_m(cube)
    # the fingertip's round end meets the side below the top edge by more than half a pad
    assert 0.0 < tip_m < cube.height_m - 0.5 * hand_model.FINGER_PAD_RADIUS_M
    # straight digits still clear the table
    assert hinge_m - hand_model.FINGER_LENGTH_M - hand_model.THUMB_PAD_RADIUS_M > 0.0


# ------------------------------------------------------------------ scoring
@pytest.mark.parametrize("outcome, released, over, expected", [
    ("held", True, True, "blocks"),            # carried over and let go
    ("dropped", False, True, "dropped_beyond"),  # fell beyond the partition: it counts
    ("dropped", True, False, "drops"),         # fell before the partition: it does not
    ("held", False, True, "not_released"),     # over, but the hand would not let go
    ("held", True, False, "not_cleared"),      # never clear of the partition
    ("crushed", True, True, "breaks"),
    ("not_lifted", True, False, "not_lifted"),
])
def test_the_published_scoring_of_one_transfer(outcome, released, over, expected) -> None:
    assert transfer_count(outcome, released, over) == expected
    assert expected in COUNT_KEYS


def _carry(block_lag_m: float, fell_at_s: float | None) -> tuple[dict, float | None]:
    """A carry up to the clearance and back down in 0.6 s; the block lags the wrist by
    ``block_lag_m``; it falls at ``fell_at_s``."""
    t = np.arange(0.0, 0.6, 0.01)
    wrist = PARTITION_CLEARANCE_M * np.sin(np.pi * t / 0.6) ** 2
    return ({"t_s": t, "wrist_height_m": wrist,
             "object_height_m": CUBE_HALF_M + wrist - block_lag_m}, fell_at_s)


def test_a_block_is_over_the_partition_when_clear_of_it_at_the_top_of_the_carry() -> None:
    assert carried_over(*_carry(0.0, None), CUBE_HALF_M)
    assert carried_over(*_carry(0.0, 0.45), CUBE_HALF_M)  # fell on the way down: beyond
    assert not carried_over(*_carry(0.0, 0.2), CUBE_HALF_M)  # fell on the way up
    lag = PARTITION_CLEARANCE_M - PARTITION_HEIGHT_M + 0.001
    assert not carried_over(*_carry(lag, None), CUBE_HALF_M)  # slid down: hits the partition


def test_the_summary_counts_drops_beyond_the_partition_as_blocks_moved() -> None:
    row = {"subject_id": 1, "feedback": "none", "transfers": 10, "blocks": 7,
           "dropped_beyond": 2, "drops": 1, "breaks": 0, "not_released": 1, "not_cleared": 1,
           "not_lifted": 0, "blocks_per_min": 7.0, "transfer_s": 5.0}
    out = aggregate("transfers", [row, {**row, "subject_id": 2, "blocks_per_min": 9.0}])
    assert out["blocks_per_min"] == pytest.approx(8.0)
    assert (out["dropped_beyond"], out["drops"], out["not_cleared"]) == (4, 2, 2)
    assert "by_feedback" not in out
    both = aggregate("transfers", [row, {**row, "feedback": "slip_vibration",
                                         "blocks_per_min": 11.0}])
    assert list(both["by_feedback"]) == ["none", "slip_vibration"]
    assert both["blocks_per_min"] == both["by_feedback"]["none"]["blocks_per_min"] == 7.0
    assert both["by_feedback"]["slip_vibration"]["blocks_per_min"] == 11.0


# ------------------------------------------------------------------ real transfers
def test_a_short_real_run_carries_the_cube_over_and_counts_it() -> None:
    row = run_scenario(parse_scenario({
        "kind": "transfers", "seed": 4,
        "protocol": {"name": "timed_transfers", "duration_s": 10.0},
        "object": {"name": "bbt_cube"}, "estimator": {"name": "intact"},
        "controller": {"kind": "pid"}, "user": {"kind": "reacting", "feedback": "touch"}},
        source="test"))
    assert row["object_name"] == "bbt_cube" and row["transfers"] >= 1
    assert row["blocks"] >= 1  # carried over the partition and let go (or dropped beyond)
    assert row["transfers"] == sum(row[k] for k in COUNT_KEYS if k != "dropped_beyond")
    assert row["blocks_per_min"] == pytest.approx(6.0 * row["blocks"])
    assert row["reach_s"] == row["transport_s"] == pytest.approx(0.6)  # the user's lift_s


def test_arm_times_are_refused_out_of_range(tmp_path) -> None:
    path = tmp_path / "bbt.yaml"
    path.write_text(textwrap.dedent("""\
        name: x
        base:
          kind: transfers
          protocol:
            name: timed_transfers
            reach_s: 0.01
        """))
    with pytest.raises(ScenarioError, match=r"bbt.yaml:6: base.protocol.reach_s: .*greater "
                                            "than or equal to 0.1"):
        load_sweep(path)


def test_an_unknown_object_is_refused_in_one_line(capsys) -> None:
    assert main(["transfers", "--controller", "pid", "--estimator", "intact",
                 "--object", "brick", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--object: expected one of" in err[0] and "'brick'" in err[0]
    assert "bbt_cube" in err[0]


def test_several_feedback_modes_give_by_feedback_on_the_same_subjects(tmp_path) -> None:
    out = tmp_path / "bbt.json"
    assert main(["transfers", "--controller", "pid", "--estimator", "ss_kf",
                 "--paradigm", "velocity", "--drive", "self_locking", "--subjects", "1",
                 "--duration-s", "10", "--feedback", "none,slip_vibration",
                 "--json", str(out), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    modes = result["by_feedback"]
    assert list(modes) == ["none", "slip_vibration"]
    assert result["blocks_per_min"] == modes["none"]["blocks_per_min"]
    for mode in modes.values():
        assert [s["subject_id"] for s in mode["per_subject"]] == [1]
        assert {"dropped_beyond", "drops", "not_released", "not_cleared"} <= set(mode)
        assert math.isfinite(mode["blocks_per_min"])
    assert result["settings"]["object.name"] == "bbt_cube"
