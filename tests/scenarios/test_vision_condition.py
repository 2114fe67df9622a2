"""Vision as a condition (``user.vision``, ``--vision on|off``) and Raveh et al.'s untimed
16-block test (``protocol.blocks``): schema, CLI refusals and a real run."""

from __future__ import annotations

import textwrap

import pytest

from scenarios.cli.main import main
from scenarios.feedback_summary import aggregate_transfers
from scenarios.runners.transfers import run_transfers_scenario
from scenarios.schema import Scenario, ScenarioError, load_sweep, parse_scenario


def _transfers(**user) -> Scenario:
    """Two blocks moved, untimed, by a novice on the clinical paradigm."""
    return parse_scenario({
        "kind": "transfers", "seed": 5, "subject": {"subject_id": 2},
        "protocol": {"name": "timed_transfers", "blocks": 2},
        "object": {"name": "bbt_cube"}, "estimator": {"name": "ss_kf", "mode": "free_run"},
        "controller": {"kind": "pid"},
        "user": {"kind": "reacting", "feedback": "none", "practice": 0, **user},
        "paradigm": "velocity", "hand": {"drive": "self_locking"}, "decoder": "pattern"},
        source="test")


def test_defaults_stay_out_of_the_canonical_scenario() -> None:
    plain = Scenario.model_validate({"kind": "transfers",
                                     "protocol": {"name": "timed_transfers"}})
    canonical = plain.canonical_dict()
    assert "vision" not in canonical["user"] and "blocks" not in canonical["protocol"]
    seen = _transfers(vision=True)
    assert "vision" not in seen.canonical_dict()["user"]
    blind = _transfers(vision=False)
    assert blind.canonical_dict()["user"]["vision"] is False
    assert blind.canonical_dict()["protocol"]["blocks"] == 2
    assert blind.canonical_json() != seen.canonical_json()


@pytest.mark.parametrize("section, line, expected", [
    ("user", "vision: maybe", "base.user.vision:"),
    ("protocol", "blocks: 0", "base.protocol.blocks:"),
    ("protocol", "blocks: 61", "base.protocol.blocks:"),
])
def test_the_schema_refuses_bad_values_in_one_line_with_the_file_line(
        tmp_path, section, line, expected) -> None:
    path = tmp_path / "dark.yaml"
    path.write_text(textwrap.dedent(f"""\
        name: x
        base:
          kind: transfers
          {section}:
            {line}
        """))
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}:5: {expected}")


@pytest.mark.parametrize("command, extra, expected", [
    ("transfers", ["--vision", "maybe"], "--vision: expected on or off, found 'maybe'"),
    ("eggs", ["--vision", "dark"], "--vision: expected on or off"),
    ("slip-recovery", ["--vision", "no"], "--vision: expected on or off"),
    ("force-matching", ["--vision", "1"], "--vision: expected on or off"),
    ("transfers", ["--blocks", "0"], "--blocks: expected 1..60, found 0"),
])
def test_every_benchmark_refuses_a_bad_vision_in_one_line(capsys, command, extra,
                                                          expected) -> None:
    assert main([command, "--controller", "pid", "--estimator", "oracle", *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]


@pytest.fixture(scope="module")
def runs() -> dict[str, dict]:
    return {"seen": run_transfers_scenario(_transfers()),
            "seen_explicit": run_transfers_scenario(_transfers(vision=True)),
            "blind": run_transfers_scenario(_transfers(vision=False))}


def test_the_untimed_test_makes_its_blocks_and_reports_time_per_block(runs) -> None:
    for r in runs.values():
        assert r["transfers"] == 2  # each block once, whatever became of it
        assert r["time_per_block_s"] == pytest.approx(r["elapsed_s"] / 2, rel=1e-12)
        assert r["blocks_dropped"] == r["drops"] + r["dropped_beyond"]
        assert r["blocks_per_min"] == pytest.approx(60.0 * r["blocks"] / r["elapsed_s"])
    summary = aggregate_transfers([{**runs["seen"], "subject_id": 2}])
    assert summary["time_per_block_s"] == pytest.approx(runs["seen"]["time_per_block_s"])


def test_vision_on_is_the_run_without_the_field_and_off_is_another(runs) -> None:
    seen, explicit, blind = runs["seen"], runs["seen_explicit"], runs["blind"]
    for key in ("elapsed_s", "blocks", "drops", "user_corrections", "attempts"):
        assert seen[key] == explicit[key]
    assert blind["elapsed_s"] != seen["elapsed_s"]  # the user without vision acts otherwise
