"""The practised, self-paced user across the commands: options, contracts, verdicts.

The acceptance over rigid objects draws its cans, subjects and seeds from a generator
rather than naming them; the results' table over ten subjects
(docs/results/person-in-the-loop.md) is
``benchmarks/closed_loop_verdicts.py``.
"""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.runners.compare import compare_references, session_seed
from scenarios.runners.episode import EpisodeSpec, run_episode
from scenarios.schema import ScenarioError, load_sweep
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject


@pytest.mark.parametrize("argv, expected", [
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
      "--practice", "60"], "--practice: expected 0..50 lifts, found 60"),
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
      "--window-ms", "20"], "--window-ms: expected 50..1000 ms, found 20"),
    (["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
      "--window-ms", "100", "--step-ms", "150"],
     "--step-ms: expected at most the window (--window-ms 100), found 150"),
    (["slip-recovery", "--controller", "pid", "--estimator", "oracle", "--step-ms", "5"],
     "--step-ms: expected 10..500 ms, found 5"),
    (["eggs", "--controller", "pid", "--estimator", "oracle", "--practice", "-1"],
     "--practice: expected 0..50 lifts, found -1"),
    (["compare-references", "--practice", "51"], "--practice: expected 0..50 lifts, found 51"),
    (["transfers", "--controller", "pid", "--estimator", "oracle", "--duration-s", "5"],
     "--duration-s: expected 10..600 s, found 5"),
])
def test_bad_practice_window_and_duration_are_one_line_naming_the_flag(argv, expected,
                                                                       capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0]


@pytest.mark.parametrize("section, line, expected", [
    ("user", "practice: 60", "less than or equal to 50"),
    ("estimator", "window_ms: 20", "greater than or equal to 50"),
    ("estimator", "step_ms: 700", "less than or equal to 500"),
])
def test_bad_practice_and_window_are_refused_at_load_with_the_line(tmp_path, section, line,
                                                                   expected) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(f"name: x\nbase:\n  {section}:\n    {line}\n")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    key = line.split(":")[0]
    assert str(info.value).startswith(f"{path}:4: base.{section}.{key}:")
    assert expected in str(info.value)


def test_a_window_shorter_than_its_step_is_refused_at_load(tmp_path) -> None:
    path = tmp_path / "sweep.yaml"
    path.write_text(textwrap.dedent("""\
        name: x
        base:
          estimator:
            window_ms: 100
            step_ms: 150
        """))
    with pytest.raises(ScenarioError, match=r"sweep.yaml:3: base.estimator: step_ms must "
                                            "not exceed window_ms=100 ms"):
        load_sweep(path)


def test_transfers_json_contract_and_the_intact_reference(tmp_path) -> None:
    out = tmp_path / "transfers.json"
    assert main(["transfers", "--controller", "pid", "--estimator", "latent_kf", "--subjects",
                 "1", "--duration-s", "12", "--json", str(out), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    for arm in (result, result["intact"]):
        assert {"blocks_per_min", "ci95", "drops", "breaks"} <= set(arm)
        assert isinstance(arm["drops"], int) and isinstance(arm["breaks"], int)
        assert (arm["blocks_per_min"] * 12.0 / 60.0).is_integer()  # whole blocks in 12 s
    assert result["intact"]["blocks_per_min"] > 0
    assert result["settings"]["estimator.name"] == "latent_kf"


def test_every_subject_draws_sessions_of_their_own() -> None:
    seeds = {session_seed(0, 0, sid) for sid in range(1, 11)}
    assert len(seeds) == 10 and session_seed(0, 0, 3) == session_seed(0, 0, 3)
    assert session_seed(0, 0, 3, 1) != session_seed(0, 0, 3) != session_seed(1, 0, 3)
    out = compare_references(make_object("can"), EpisodeSpec(episode_s=1.5, practice=0),
                             estimators=["oracle"], subject_ids=[1, 2], sessions=2)
    assert len({r["seed"] for r in out["rows"]}) == 4
    assert out["summary"]["oracle"]["held_by_subject"] is not None


@pytest.mark.slow
@pytest.mark.verdict
def test_practised_users_hold_rigid_everyday_objects() -> None:
    """At least 95 % held within a 15 s trial, every estimator whose real R2 is at least 0.8
    and every controller, on cans (0.2-1.0 kg, friction 0.3-1.0) and the block drawn at
    random, two subjects drawn at random, seeds drawn at random."""
    rng = np.random.default_rng(2027)
    outcomes = []
    for estimator in ("mlp", "features_mav", "ridge", "gbt", "latent_kf"):
        for controller in ("pid", "lead_lag", "mpc"):
            for sid in rng.choice(np.arange(1, 21), 2, replace=False):
                if rng.random() < 0.25:
                    obj = make_object("block")
                else:
                    obj = make_object("can", mass_kg=round(float(rng.uniform(0.2, 1.0)), 2),
                                      friction=round(float(rng.uniform(0.3, 1.0)), 2))
                row = run_episode(VirtualSubject.sample(0, int(sid)), obj,
                                  EpisodeSpec(estimator=estimator, controller=controller,
                                  seed=int(rng.integers(2**31)))).row
                outcomes.append(row["outcome"])
                assert row["simulated_s"] <= 15.0 + 1e-9
    held = outcomes.count("held") / len(outcomes)
    assert held >= 0.95, f"{outcomes.count('held')} of {len(outcomes)} held: {outcomes}"
