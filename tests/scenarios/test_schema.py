"""Scenario schema: validation messages, library files, sweep expansion and seeds."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

import scenarios
from scenarios.schema import (
    ESTIMATORS,
    OBJECTS,
    Scenario,
    ScenarioError,
    derive_seed,
    design_points,
    expand_sweep,
    field_paths,
    load_sweep,
    parse_sweep,
)

LIBRARY = Path(scenarios.__file__).parent / "library"
LIBRARY_FILES = sorted(LIBRARY.glob("*.yaml"))


def write(tmp_path: Path, text: str, name: str = "sweep.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def error_of(path: Path) -> str:
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(str(path))
    return message


# ------------------------------------------------------------------ library


def test_library_has_the_four_files_the_demo_and_the_benchmarks():
    names = {p.stem for p in LIBRARY_FILES}
    assert names == {"paper", "grasp_mass_friction", "fragile", "robustness", "demo",
                     "eggs", "slip_recovery", "force_matching", "transfers"}


@pytest.mark.parametrize("path", LIBRARY_FILES, ids=lambda p: p.stem)
def test_every_library_file_validates_and_expands(path):
    spec = load_sweep(path)
    expanded = expand_sweep(spec)
    assert spec.name == path.stem
    assert len(expanded) == math.prod(len(v) for v in spec.grid.values()) * spec.replicates
    assert len({e.scenario.canonical_json() for e in expanded}) == len(expanded)
    assert all(e.scenario.seed is not None for e in expanded)


def test_paper_library_covers_subjects_estimators_and_modes():
    expanded = expand_sweep(load_sweep(LIBRARY / "paper.yaml"))
    combos = {
        (e.scenario.subject.subject_id, e.scenario.estimator.name, e.scenario.estimator.mode)
        for e in expanded
    }
    assert {c[0] for c in combos} == set(range(1, 11))
    assert {"ss_kf", "ss", "features_mav", "mlp", "narx", "lda_qpf"} <= {c[1] for c in combos}
    assert {c[2] for c in combos} == {"one_step", "free_run"}
    assert all(e.scenario.kind == "reproduction" for e in expanded)


def test_fragile_library_spans_virtual_eggs_break_forces():
    spec = load_sweep(LIBRARY / "fragile.yaml")
    forces = spec.grid["object.break_force_n"]
    assert min(forces) == pytest.approx(0.4) and max(forces) == pytest.approx(12.0)


# ------------------------------------------------------------------ models


def test_default_scenario_is_valid_and_canonical_json_is_sorted_and_stable():
    a, b = Scenario(), Scenario.model_validate({"object": {"name": "ball"}})
    assert a.canonical_json() == b.canonical_json()
    assert a.canonical_json().index('"controller"') < a.canonical_json().index('"subject"')
    assert " " not in a.canonical_json()


def test_names_match_the_project():
    assert set(ESTIMATORS) >= {"ss_kf", "ss", "mlp", "narx", "lda_qpf", "latent_kf", "oracle",
                               "intact", "ideal_interface"}
    assert set(OBJECTS) == {"ball", "can", "cup", "egg", "block", "vet_block", "transfer_block",
                            "bbt_cube"}
    assert "object.mass_kg" in field_paths()
    assert "controller.slip_reflex.latency_s" in field_paths()


def test_object_and_subject_vocabulary_matches_sim():
    sim_objects = pytest.importorskip("sim.hand.objects")
    sim_subjects = pytest.importorskip("sim.user.subjects")
    from scenarios.schema import ObjectConfig, SubjectConfig

    assert set(OBJECTS) == set(sim_objects.LIBRARY)
    assert set(sim_objects.SHAPES) == {"sphere", "cylinder", "box"}
    mass = ObjectConfig.model_fields["mass_kg"].metadata
    friction = ObjectConfig.model_fields["friction"].metadata
    assert (mass[0].ge, mass[1].le) == sim_objects.MASS_RANGE_KG
    assert (friction[0].ge, friction[1].le) == sim_objects.FRICTION_RANGE
    from scenarios.schema import GENERATORS

    assert set(GENERATORS) == set(sim_subjects.GENERATORS)
    assert SubjectConfig.model_validate({"generator": "motor_units"}).generator == "motor_units"


def test_mpc_gets_a_default_horizon_and_pid_rejects_one():
    assert Scenario.model_validate({"controller": {"kind": "mpc"}}).controller.horizon == 20
    with pytest.raises(ValueError, match="horizon applies to controller kind mpc only"):
        Scenario.model_validate({"controller": {"kind": "pid", "horizon": 10}})


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        ({"object": {"mass_kg": 0.001}}, "greater than or equal to 0.005"),
        ({"object": {"friction": 1.6}}, "less than or equal to 1.5"),
        ({"object": {"shape": "box", "size_m": [0.02]}}, "size_m of a box needs 3"),
        ({"estimator": {"name": "kalman"}}, "ss_kf"),
        ({"controller": {"crossover_rad_s": 10, "bandwidth_rad_s": 5}}, "not both"),
        ({"kind": "reproduction"}, "needs protocol.name paper_calibration"),
        ({"protocol": {"episode_s": 2.0, "hold_s": 3.0}}, "hold_s must be shorter"),
    ],
)
def test_field_ranges_and_cross_checks(data, reason):
    with pytest.raises(ValueError, match=reason):
        Scenario.model_validate(data)


# ------------------------------------------------------------------ file errors


def test_unknown_key_names_file_line_path_and_allowed_keys(tmp_path):
    path = write(
        tmp_path,
        """\
        base:
          object:
            name: cup
            mas_kg: 0.3
        """,
    )
    message = error_of(path)
    assert message.startswith(f"{path}:4: base.object: unknown key 'mas_kg'")
    assert "mass_kg" in message


def test_out_of_range_value_reports_line_and_found_value(tmp_path):
    path = write(tmp_path, "name: x\nbase:\n  object:\n    mass_kg: 5\n")
    message = error_of(path)
    assert message.startswith(f"{path}:4: base.object.mass_kg:")
    assert "less than or equal to 2" in message and "found 5" in message


def test_malformed_yaml_reports_line_and_column(tmp_path):
    path = write(tmp_path, "base:\n  object: {name: cup\ngrid: [\n")
    assert error_of(path).startswith(f"{path}:3:5: malformed YAML:")


def test_duplicate_key_is_rejected(tmp_path):
    path = write(tmp_path, "seed: 1\nseed: 2\nbase: {}\n")
    assert "duplicate key 'seed'" in error_of(path)


def test_top_level_must_be_a_mapping(tmp_path):
    assert "expected a mapping" in error_of(write(tmp_path, "- 1\n- 2\n"))


def test_empty_file_is_rejected(tmp_path):
    assert "empty file" in error_of(write(tmp_path, ""))


def test_missing_file_is_a_file_not_found_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such scenario file"):
        load_sweep(tmp_path / "absent.yaml")


def test_grid_with_unknown_path_suggests_the_right_one(tmp_path):
    path = write(tmp_path, "base: {}\ngrid:\n  object.mas_kg: [0.1]\n")
    message = error_of(path)
    assert message.startswith(f"{path}:3: grid: unknown field path 'object.mas_kg'")
    assert "did you mean object.mass_kg" in message


def test_grid_value_out_of_range_names_its_index_and_line(tmp_path):
    path = write(tmp_path, "base: {}\ngrid:\n  object.friction:\n    - 0.5\n    - 3.0\n")
    message = error_of(path)
    assert message.startswith(f"{path}:5: grid.object.friction[1]:")
    assert "found 3.0" in message


def test_random_design_with_bad_bounds(tmp_path):
    path = write(
        tmp_path,
        """\
        base: {}
        random:
          n: 4
          params:
            object.friction: {dist: uniform, low: 1.2, high: 0.4}
        """,
    )
    assert "high must be > low" in error_of(path)


def test_grid_and_random_together_are_rejected(tmp_path):
    path = write(
        tmp_path,
        """\
        base: {}
        grid: {object.friction: [0.5]}
        random: {n: 2, params: {object.mass_kg: {dist: uniform, low: 0.1, high: 0.2}}}
        """,
    )
    assert "give grid or random, not both" in error_of(path)


def test_design_point_violating_a_cross_check_is_reported_at_expansion(tmp_path):
    path = write(tmp_path, "base: {controller: {kind: mpc, horizon: 10}}\n"
                 "grid:\n  controller.kind: [mpc, pid]\n")
    spec = load_sweep(path)
    with pytest.raises(ScenarioError) as info:
        expand_sweep(spec, str(path))
    assert str(info.value) == (
        f"{path}: design point (controller.kind='pid'): controller: "
        "horizon applies to controller kind mpc only (found kind pid)"
    )


def test_grid_values_valid_only_in_combination_are_accepted(tmp_path):
    path = write(tmp_path, "base: {kind: episode}\ngrid:\n  kind: [reproduction]\n"
                 "  protocol.name: [paper_calibration]\n")
    (item,) = expand_sweep(load_sweep(path))
    assert item.scenario.kind == "reproduction"


# ------------------------------------------------------------------ expansion


def grid_spec(**extra):
    data = {
        "name": "g",
        "seed": 5,
        "base": {"object": {"name": "cup"}},
        "grid": {"object.mass_kg": [0.1, 0.2, 0.4], "controller.kind": ["pid", "mpc"]},
    }
    data.update(extra)
    return parse_sweep(data)


def test_grid_is_a_row_major_cartesian_product():
    points = design_points(grid_spec())
    assert points == [
        {"object.mass_kg": m, "controller.kind": k}
        for m in (0.1, 0.2, 0.4)
        for k in ("pid", "mpc")
    ]
    expanded = expand_sweep(grid_spec())
    assert [e.scenario.object.mass_kg for e in expanded] == [0.1, 0.1, 0.2, 0.2, 0.4, 0.4]
    assert expanded[1].scenario.controller.horizon == 20  # mpc default filled per point
    assert all(e.scenario.object.name == "cup" for e in expanded)


def test_seeds_are_a_function_of_content_not_of_expansion_order():
    forward = expand_sweep(grid_spec())
    reordered = expand_sweep(
        grid_spec(grid={"controller.kind": ["mpc", "pid"], "object.mass_kg": [0.4, 0.2, 0.1]})
    )
    seeds = {e.scenario.model_copy(update={"seed": None}).canonical_json(): e.scenario.seed
             for e in forward}
    again = {e.scenario.model_copy(update={"seed": None}).canonical_json(): e.scenario.seed
             for e in reordered}
    assert seeds == again
    assert len(set(seeds.values())) == len(seeds)


def test_seed_depends_on_sweep_seed():
    a = [e.scenario.seed for e in expand_sweep(grid_spec())]
    b = [e.scenario.seed for e in expand_sweep(grid_spec(seed=6))]
    assert a != b


def test_derive_seed_matches_an_independent_seedsequence_computation():
    import hashlib

    content = Scenario().canonical_json()
    digest = hashlib.sha256(content.encode()).digest()
    words = [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 32, 4)]
    state = np.random.SeedSequence(42, spawn_key=(*words, 3)).generate_state(2, np.uint32)
    expected = (int(state[0]) | int(state[1]) << 32) >> 1
    assert derive_seed(42, content, 3) == expected
    assert 0 <= expected < 2**63


def test_replicates_share_content_but_not_seeds():
    spec = parse_sweep({"seed": 1, "replicates": 3, "base": {}})
    expanded = expand_sweep(spec)
    assert len(expanded) == 3
    assert len({e.scenario.seed for e in expanded}) == 3
    assert len({e.scenario.model_copy(update={"seed": None}).canonical_json()
                for e in expanded}) == 1


def test_explicit_seed_is_kept():
    spec = parse_sweep({"base": {"seed": 99}, "grid": {"object.friction": [0.4, 0.6]}})
    assert [e.scenario.seed for e in expand_sweep(spec)] == [99, 99]


def test_random_design_recomputed_independently():
    spec = parse_sweep(
        {
            "seed": 3,
            "base": {},
            "random": {
                "n": 6,
                "params": {
                    "object.mass_kg": {"dist": "loguniform", "low": 0.05, "high": 1.0},
                    "object.friction": {"dist": "uniform", "low": 0.3, "high": 1.2},
                    "controller.kind": {"dist": "choice", "values": ["pid", "mpc"]},
                },
            },
        }
    )
    expanded = expand_sweep(spec)
    rng = np.random.default_rng(3)  # paths drawn in sorted order
    kinds = [["pid", "mpc"][i] for i in rng.integers(0, 2, 6)]
    friction = rng.uniform(0.3, 1.2, 6)
    mass = np.exp(rng.uniform(np.log(0.05), np.log(1.0), 6))
    assert [e.scenario.controller.kind for e in expanded] == kinds
    np.testing.assert_array_equal([e.scenario.object.friction for e in expanded], friction)
    np.testing.assert_array_equal([e.scenario.object.mass_kg for e in expanded], mass)
    assert [e.scenario.seed for e in expand_sweep(spec)] == [e.scenario.seed for e in expanded]


def test_random_draw_outside_a_field_range_is_reported_with_its_point():
    spec = parse_sweep(
        {
            "seed": 0,
            "base": {},
            "random": {"n": 50, "params": {"object.friction": {"dist": "normal", "mean": 0.3,
                                                               "sd": 0.5}}},
        }
    )
    pattern = r"design point \(object.friction=.*\): object.friction: .*greater than or equal"
    with pytest.raises(ScenarioError, match=pattern):
        expand_sweep(spec)


def test_seed_by_pairs_scenarios_on_the_named_fields():
    expanded = expand_sweep(load_sweep(LIBRARY / "paper.yaml"))
    seeds: dict[int, set[int]] = {}
    for e in expanded:
        seeds.setdefault(e.scenario.subject.subject_id, set()).add(e.scenario.seed)
    assert all(len(s) == 1 for s in seeds.values())  # one session per subject
    assert len({next(iter(s)) for s in seeds.values()}) == 10


def test_seed_by_keeps_replicates_apart():
    spec = parse_sweep({"seed": 2, "replicates": 2, "seed_by": ["subject.subject_id"],
                        "base": {}, "grid": {"controller.kind": ["pid", "mpc"]}})
    seeds = [e.scenario.seed for e in expand_sweep(spec)]
    assert seeds[0] == seeds[2] and seeds[1] == seeds[3] and seeds[0] != seeds[1]


def test_seed_by_unknown_path_is_reported(tmp_path):
    path = write(tmp_path, "seed_by:\n  - subject\n  - subjet.subject_id\nbase: {}\n")
    assert error_of(path).startswith(f"{path}:3: seed_by[1]: unknown field path")


def test_mpc_solver_is_selectable_and_checked():
    from scenarios.schema import parse_scenario

    s = parse_scenario({"kind": "episode", "controller": {"kind": "mpc", "solver": "osqp"}})
    assert s.controller.solver == "osqp"
    with pytest.raises(ScenarioError, match="daqp, osqp, proxqp"):
        parse_scenario({"kind": "episode", "controller": {"kind": "mpc", "solver": "qrqp"}})
    with pytest.raises(ScenarioError, match="solver applies to"):
        parse_scenario({"kind": "episode", "controller": {"kind": "pid", "solver": "osqp"}})


# ------------------------------------------------------------------ the hand's settings


@pytest.mark.parametrize(("text", "line", "where", "known"), [
    ("base:\n  paradigm: hold\n", 2, "base.paradigm", "force, force_hold, velocity"),
    ("base:\n  hand:\n    drive: worm\n", 3, "base.hand.drive", "backdrivable, self_locking"),
])
def test_an_unknown_paradigm_or_drive_names_file_line_and_the_known_ones(tmp_path, text, line,
                                                                         where, known):
    path = write(tmp_path, text)
    message = error_of(path)
    assert message.startswith(f"{path}:{line}: {where}:") and known in message
    assert "\n" not in message


def test_the_hands_settings_stay_out_of_the_canonical_json_at_their_defaults():
    default = Scenario()
    same = Scenario.model_validate({"paradigm": "force", "hand": {"drive": "backdrivable"},
                                    "auto_grip": False})
    assert same.canonical_json() == default.canonical_json()
    for change in ({"paradigm": "force_hold"}, {"hand": {"drive": "self_locking"}},
                   {"auto_grip": True}):
        moved = Scenario.model_validate(change).canonical_dict()
        assert moved != default.canonical_dict() and set(moved) - set(
            default.canonical_dict()) == set(change)
