"""``griploop report``: data gathering against independent re-computations, and the HTML.

The store holds real reproduction rows (a tiny sweep run through the sweep
engine, with two scenarios that really fail) and episode rows of the shape the
episode runner writes, computed here: three controllers designed by
``controllers.registry`` on a first-order hand plant, their closed loops
simulated with python-control, and drop / crush / slip judged against the
Coulomb threshold of each object.
"""

from __future__ import annotations

import base64
import datetime as dt
import io
import json
import re
import textwrap
import time
from html import unescape
from pathlib import Path
from xml.etree import ElementTree

import control
import matplotlib.image
import numpy as np
import pytest

from controllers.analysis import loop_margins
from controllers.bounds import slip_threshold_n
from controllers.registry import design_controller
from estimation.paper import TABLE2, TABLE2_SUMMARY
from estimation.reproduce import ScoreSettings
from scenarios.cli import main
from scenarios.execution.sweep import plan, run_sweep
from scenarios.outcomes import row_outcome
from scenarios.report import ReportInputError, build_report
from scenarios.report import data as D
from scenarios.report import factors as FA
from scenarios.report import loops as LP
from scenarios.report import reproduction_data as RD
from scenarios.report import summaries as SU
from scenarios.runners.reproduction import ReproductionAnalyses, run_reproduction
from scenarios.schema import Scenario, expand_sweep, load_sweep
from scenarios.stats import wilson_interval
from scenarios.store import Outcome, ResultStore, content_hash, encode_traces, package_version

CREATED = dt.datetime(2026, 1, 2, 3, 4, 5, tzinfo=dt.timezone.utc)
DT_S = 0.002
HAND_GAIN_N = 88.0  # N per unit command, the simulated hand's static gain (scenarios.margins)
HAND_TAU_S = 0.01
EPISODE_S = 2.0
MASSES_KG = (0.1, 0.4)
FRICTIONS = (0.3, 0.8)
SEEDS = (1, 2)
SPECS = {"pid": {"phase_margin_deg": 60.0, "crossover_rad_s": 150.0},
         "lead_lag": {"phase_margin_deg": 60.0, "crossover_rad_s": 150.0},
         "mpc": {"horizon": 20}}
REPRO_SWEEP = """\
name: tiny_paper
seed: 2019
seed_by: [subject]
base:
  kind: reproduction
  subject: {population_seed: 0, generator: noise}
  protocol: {name: paper_calibration}
  estimator: {name: ss_kf, mode: one_step}
grid:
  subject.subject_id: [1, 2, 3]
  estimator.name: [ss_kf, features_mav, persistence]
  estimator.mode: [one_step, free_run]
"""


# ------------------------------------------------------------------ fixtures


def simulate_episode(loop: control.StateSpace, controller: str, estimator: str, mass_kg: float,
                     friction: float, seed: int) -> tuple[dict, dict]:
    """One grasp-and-hold episode of the closed loop ``L / (1 + L)``: result row and traces.

    The intent ramps to 1.5x the object's slip threshold; the estimator sees it
    every 125 ms with a seeded gain error (none for the oracle); the reference
    holds each estimate; the grip force is the closed loop's response.
    """
    rng = np.random.default_rng([seed, int(mass_kg * 1e3), int(friction * 1e3)])
    t_s = np.arange(int(EPISODE_S / DT_S)) * DT_S
    threshold_n = slip_threshold_n(mass_kg, friction)
    intent_n = 1.5 * threshold_n * np.clip(t_s / 0.5, 0.0, 1.0)
    gain = 1.0 if estimator == "oracle" else rng.normal(0.8, 0.25)
    window = np.floor(t_s / 0.125).astype(int)
    reference_n = gain * intent_n[np.searchsorted(t_s, window * 0.125)]
    closed = control.feedback(loop, 1)
    grip_force_n = control.forced_response(closed, T=t_s, U=reference_n).outputs
    lifted_s = t_s >= 0.6
    below = (grip_force_n < threshold_n) & lifted_s
    slip_events = int(np.count_nonzero(np.diff(below.astype(int)) == 1))
    break_force_n = 12.0 if mass_kg < 0.2 else None
    margins = loop_margins(loop)
    result = {
        "kind": "episode", "mode": "one_step" if estimator == "oracle" else "free_run",
        "subject_id": 1, "seed": seed, "object_name": "block" if mass_kg > 0.2 else "egg",
        "object_mass_kg": mass_kg, "object_friction": friction,
        "object_break_force_n": break_force_n, "controller": controller,
        "estimator": estimator,
        "tracking_rmse_n": float(np.sqrt(np.mean((grip_force_n - reference_n) ** 2))),
        "estimation_rmse_n": float(np.sqrt(np.mean((reference_n - intent_n) ** 2))),
        "overshoot_pct": float(100 * (grip_force_n.max() / reference_n[-1] - 1)),
        "settling_time_s": None, "slip_events": slip_events,
        "slip_distance_m": 1e-3 * slip_events,
        "dropped": bool(np.mean(below[lifted_s]) > 0.5),
        "crushed": bool(break_force_n is not None and grip_force_n.max() > break_force_n),
        "lifted": True, "peak_force_n": float(grip_force_n.max()),
        "hold_reference_n": float(reference_n[-1]), "reference_volatility_n_per_s": 0.0,
        "gain_margin_db": margins.gain_margin_db, "phase_margin_deg": margins.phase_margin_deg,
        "delay_margin_s": margins.delay_margin_s, "ms": margins.ms,
        "crossover_rad_s": margins.crossover_rad_s[0],
        "n_crossovers": len(margins.crossover_rad_s), "stable": margins.stable,
        "loop_dt_s": DT_S, "mpc_failures": 0, "t_semg_s": 0.01, "t_estimator_s": 0.01,
        "t_controller_s": 0.01, "t_physics_s": 0.1, "realtime_factor": 10.0,
        "cal_r2": None if estimator == "oracle" else 0.9,
    }
    traces = {"t_s": t_s, "intent_n": intent_n, "reference_n": reference_n,
              "grip_force_n": grip_force_n, "command": grip_force_n / HAND_GAIN_N,
              "object_height_m": 0.05 * lifted_s, "slip_speed_m_s": 1e-3 * below,
              "loop_A": loop.A, "loop_B": loop.B, "loop_C": loop.C, "loop_D": loop.D}
    return result, traces


def designed_loops() -> dict[str, control.StateSpace]:
    """Open loops of the three controller families on the first-order hand plant."""
    plant = control.c2d(control.tf([HAND_GAIN_N], [HAND_TAU_S, 1.0]), DT_S)
    return {name: control.ss(design_controller(name, plant, **spec).report_.margins.loop)
            for name, spec in SPECS.items()}


def insert_episodes(store: ResultStore, sweep: str = "episodes") -> list[str]:
    """Episode rows over controller x mass x friction x seed (+ oracle PID), as a sweep."""
    version = package_version()
    members, hashes = [], []
    loops = designed_loops()
    combos = [(c, "ss_kf") for c in loops] + [("pid", "oracle")]
    index = 0
    for controller, estimator in combos:
        for mass_kg in MASSES_KG:
            for friction in FRICTIONS:
                for seed in SEEDS:
                    result, traces = simulate_episode(loops[controller], controller, estimator,
                                                      mass_kg, friction, seed)
                    scenario = Scenario.model_validate({
                        "kind": "episode", "seed": seed,
                        "object": {"name": result["object_name"], "mass_kg": mass_kg,
                                   "friction": friction},
                        "estimator": {"name": estimator, "mode": result["mode"]},
                        "controller": {"kind": controller},
                    })
                    config = scenario.canonical_json()
                    key = content_hash(config, version, "test_report:simulate_episode")
                    store.record(Outcome(key, "ok", result, encode_traces(traces), None, None,
                                         0.0, 1.0, 1.0, "test:0"), kind="episode",
                                 config_json=config, task="test_report:simulate_episode",
                                 version=version)
                    members.append((key, index, {"controller.kind": controller}))
                    hashes.append(key)
                    index += 1
    store.add_members(sweep, members)
    return hashes


@pytest.fixture(scope="module")
def store_path(tmp_path_factory) -> Path:
    """A store with a real reproduction sweep (2 failed rows) and simulated episode rows."""
    tmp = tmp_path_factory.mktemp("report")
    sweep_file = tmp / "tiny_paper.yaml"
    sweep_file.write_text(textwrap.dedent(REPRO_SWEEP))
    path = tmp / "results.sqlite"
    spec = load_sweep(sweep_file)
    with ResultStore(path) as store:
        run_sweep(plan(expand_sweep(spec, sweep_file)), store, sweep_name=spec.name,
                  progress=False)
        insert_episodes(store)
    return path


@pytest.fixture(scope="module")
def reproduction_json(tmp_path_factory) -> Path:
    """The JSON of ``griploop reproduce --json`` for two subjects and three estimators."""
    result = run_reproduction(2, 0, estimators=("ss_kf", "features_mav", "persistence"),
                              analyses=ReproductionAnalyses(orders=(1, 2, 3, 4)))
    path = tmp_path_factory.mktemp("repro") / "repro.json"
    path.write_text(json.dumps(result))
    return path


@pytest.fixture(scope="module")
def report(store_path, reproduction_json, tmp_path_factory):
    """The full report (rendered frame included) and its HTML text."""
    out = tmp_path_factory.mktemp("html")
    result = build_report(store_path, out, reproduction=reproduction_json, created=CREATED)
    return result, result.path.read_text()


def section(html: str, anchor: str) -> str:
    match = re.search(rf'<section id="{anchor}">(.*?)</section>', html, re.S)
    assert match, f"no section {anchor}"
    return match.group(1)


def tables(text: str) -> list[tuple[str, list[str], list[list[str]]]]:
    """(caption, headers, rows) of every table in ``html``."""
    out = []
    for body in re.findall(r"<table>(.*?)</table>", text, re.S):
        caption = re.search(r"<caption>(.*?)</caption>", body)
        headers = [unescape(h) for h in re.findall(r"<th(?:\s[^>]*)?>(.*?)</th>", body)]
        rows = [[unescape(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", r)]
                for r in re.findall(r"<tr>(.*?)</tr>", body)]
        out.append((unescape(caption.group(1)) if caption else "", headers,
                    [r for r in rows if r]))
    return out


# ------------------------------------------------------------------ data: independent checks


def test_outcome_grids_match_a_plain_recount(store_path):
    with ResultStore(store_path) as store:
        episodes = D.split_rows(store.rows()).episodes
    grids = D.outcome_grids(episodes)
    assert [g.key for g in grids] == [("pid", "ss_kf", "free_run"),
                                      ("lead_lag", "ss_kf", "free_run"),
                                      ("mpc", "ss_kf", "free_run"),
                                      ("pid", "oracle", "one_step")]
    for grid in grids:
        np.testing.assert_array_equal(grid.mass_kg, MASSES_KG)
        np.testing.assert_array_equal(grid.friction, FRICTIONS)
        for i, mass_kg in enumerate(MASSES_KG):
            for j, friction in enumerate(FRICTIONS):
                cell = [e["result"] for e in episodes
                        if D.group_key(e["result"]) == grid.key
                        and e["result"]["object_mass_kg"] == mass_kg
                        and e["result"]["object_friction"] == friction]
                assert grid.n_episodes[i, j] == len(cell) == len(SEEDS)
                assert grid.dropped_frac[i, j] == sum(r["dropped"] for r in cell) / len(cell)
                assert grid.crushed_frac[i, j] == sum(r["crushed"] for r in cell) / len(cell)
                assert grid.slip_events_mean[i, j] == pytest.approx(
                    sum(r["slip_events"] for r in cell) / len(cell), rel=1e-12)
    # the physics of the fixture shows through: a light object on high friction is held
    # (threshold 0.61 N) by the oracle, whose reference is 1.5x the threshold
    oracle = grids[3]
    assert oracle.dropped_frac[0, 1] == 0.0


def test_empty_cells_are_nan_not_zero():
    rows = [{"hash": f"h{i}", "kind": "episode", "result": {
        "controller": "pid", "estimator": "oracle", "mode": "one_step", "object_mass_kg": m,
        "object_friction": mu, "dropped": True, "crushed": False, "slip_events": 3}}
        for i, (m, mu) in enumerate([(0.1, 0.3), (0.2, 0.5)])]
    (grid,) = D.outcome_grids(rows)
    assert grid.n_episodes.tolist() == [[1, 0], [0, 1]]
    assert np.isnan(grid.dropped_frac[0, 1]) and np.isnan(grid.slip_events_mean[1, 0])
    assert grid.dropped_frac[0, 0] == 1.0 and grid.slip_events_mean[1, 1] == 3.0


def test_loop_designs_dedupe_and_match_the_designs(store_path):
    with ResultStore(store_path) as store:
        episodes = D.split_rows(store.rows()).episodes
        traces = {e["hash"]: store.traces(e["hash"]) for e in episodes}
    designs = LP.loop_designs(episodes, traces)
    # one loop per controller family: the oracle PID shares the ss_kf PID's loop
    assert [d.controller for d in designs] == ["pid", "lead_lag", "mpc"]
    per_combo = len(MASSES_KG) * len(FRICTIONS) * len(SEEDS)
    assert [len(d.hashes) for d in designs] == [2 * per_combo, per_combo, per_combo]
    assert all(d.row_agrees for d in designs)
    # golden: PI and lead-lag were designed for PM 60 deg at 150 rad/s
    for d in designs[:2]:
        assert d.margins.phase_margin_deg == pytest.approx(60.0, abs=1e-6)
        assert d.margins.crossover_rad_s[0] == pytest.approx(150.0, rel=1e-6)
        assert d.margins.stable
    # the rebuilt loop has the plant's DC gain times the controller's: compare frequency
    # responses of the stored and freshly designed loops
    fresh = designed_loops()
    for d in designs:
        w = np.array([1.0, 30.0, 300.0])
        np.testing.assert_allclose(d.margins.loop(np.exp(1j * w * DT_S)),
                                   fresh[d.controller](np.exp(1j * w * DT_S)), rtol=1e-9)


def test_scores_from_rows_match_numpy(store_path):
    with ResultStore(store_path) as store:
        rows = D.split_rows(store.rows()).reproduction
    table = RD.scores_from_rows(rows)
    assert list(table) == ["one_step", "free_run"]
    assert "persistence" in table["one_step"] and "persistence" not in table["free_run"]
    for mode, by_name in table.items():
        for name, scores in by_name.items():
            mine = [r["result"] for r in rows if r["result"]["mode"] == mode
                    and r["result"]["estimator"] == name]
            r2 = np.array([r["r2"] for r in mine])
            assert scores.n == len(mine) == 3
            assert scores.r2_mean == pytest.approx(r2.mean(), rel=1e-12)
            assert scores.r2_sd == pytest.approx(r2.std(ddof=1), rel=1e-12)
            assert scores.per_subject[2][1] == next(r["nrmse"] for r in mine
                                                    if r["subject_id"] == 2)
            # NRMSE fit and R^2 from the same validation data: nrmse = 1 - sqrt(1 - r2)
            for r in mine:
                assert r["nrmse"] == pytest.approx(1 - np.sqrt(1 - r["r2"]), abs=1e-9)


def test_reproduction_json_is_read_per_mode(reproduction_json):
    raw = json.loads(reproduction_json.read_text())
    table = RD.load_reproduction_json(reproduction_json)
    assert list(table) == ["one_step", "free_run"]
    got = table["free_run"]["ss_kf"]
    want = raw["estimators"]["ss_kf"]["free_run"]
    assert got.r2_mean == want["r2_mean"] and got.nrmse_sd == want["nrmse_sd"]
    assert got.per_subject[1] == (want["per_subject"][0]["r2"], want["per_subject"][0]["nrmse"])
    assert got.train_ms == (raw["timing"]["ss_kf"]["train_ms_mean"],
                            raw["timing"]["ss_kf"]["train_ms_sd"])


@pytest.mark.parametrize(("text", "expected"), [
    ("not json", "not JSON"),
    ('{"estimators": {"ss_kf": {"one_step": {"r2_mean": 0.9}}}}', "lacks ['r2_sd'"),
    ("[1, 2]", "found a JSON list"),
    ('{"timing": {}}', "found keys ['timing']"),
])
def test_bad_reproduction_json_says_what_was_expected(tmp_path, text, expected):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ReportInputError, match=re.escape(expected)):
        RD.load_reproduction_json(path)


def test_episode_row_missing_a_field_is_rejected(tmp_path):
    row = {"hash": "ab" * 32, "kind": "episode", "status": "ok", "result": {"controller": "pid"}}
    with pytest.raises(ReportInputError, match=r"episode row abababababab: missing result "
                                                r"field\(s\) estimator, mode"):
        D.split_rows([row])


# ------------------------------------------------------------------ the page


def test_report_has_every_section_with_real_content(report):
    result, html = report
    assert [s.anchor for s in result.sections] == [
        "summary", "published", "combinations", "compare", "paper", "traces", "loops",
        "outcomes", "margins", "frame", "feedback", "failed", "provenance"]
    # the store holds episodes, no feedback benchmark (tests/scenarios/test_feedback_tasks.py
    # reports one) and no published board (tests/scenarios/test_published.py reports one)
    assert not any(s.omitted for s in result.sections
                   if s.anchor not in ("feedback", "published")), \
        [s.title for s in result.sections]
    # 2 bar charts + the summary's forest plot and held-rate figure + one trace chart per
    # episode + one loop figure (the designs overlaid) + frame; the outcome maps are tables
    n_episodes = 4 * len(MASSES_KG) * len(FRICTIONS) * len(SEEDS)
    assert result.n_images == 2 + 2 + n_episodes + 1 + 1
    assert html.count('<table class="heat">') > 0


def test_page_is_self_contained(report):
    _, html = report
    assert "<script" not in html.lower()
    assert not re.search(r"""(src|href)\s*=\s*["'](?!data:image/(png|svg\+xml);base64,|#)""",
                         html)
    assert "http://" not in html and "https://" not in html
    images = re.findall(r'<img (?:class="[^"]*" )?src="data:image/(png|svg\+xml);base64,'
                        r'([^"]+)" alt="[^"]+">', html)
    assert len(images) == html.count("<img ")
    assert {kind for kind, _ in images} == {"png", "svg+xml"}  # the frame, the figures
    for kind, data in images:
        raw = base64.b64decode(data)
        if kind == "png":
            pixels = matplotlib.image.imread(io.BytesIO(raw), format="png")
            assert pixels.shape[0] > 50 and pixels.shape[1] > 50
            assert pixels[..., :3].std() > 0.01  # not a blank canvas
        else:  # a well-formed SVG document with drawn paths and text
            root = ElementTree.fromstring(raw)
            assert root.tag == "{http://www.w3.org/2000/svg}svg"
            assert float(root.get("width").removesuffix("pt")) > 50
            assert len(root.findall(".//{http://www.w3.org/2000/svg}path")) > 5
            assert root.findall(".//{http://www.w3.org/2000/svg}text")
    for chart in re.findall(r"<svg .*?</svg>", html, re.S):  # the inline trace charts
        ElementTree.fromstring(chart)
        assert chart.count("<path ") >= 4  # grid + intent, reference, grip force


def test_paper_values_sit_only_beside_one_step(report, store_path):
    _, html = report
    parsed = tables(section(html, "paper"))
    one_step = [t for t in parsed if t[0] == "Summary, mode one_step"]
    free_run = [t for t in parsed if t[0] == "Summary, mode free_run"]
    assert len(one_step) == len(free_run) == 2  # from the store and from the JSON
    for _, headers, _ in free_run:
        assert not any("paper" in h for h in headers)
    _, headers, rows = one_step[0]
    ss_kf = next(r for r in rows if r[0] == "ss_kf")
    ref = TABLE2_SUMMARY["ss_kf"]
    assert ss_kf[headers.index("paper R² mean ± SD")] == f"{ref[0]:.4g} ± {ref[1]:.4g}"
    with ResultStore(store_path) as store:
        r2 = [r["result"]["r2"] for r in store.rows(sweep="tiny_paper", status="ok")
              if r["result"]["estimator"] == "ss_kf" and r["result"]["mode"] == "one_step"]
    assert ss_kf[headers.index("R² mean ± SD")] == \
        f"{np.mean(r2):.4g} ± {np.std(r2, ddof=1):.4g}"
    per_subject = next(t for t in parsed if t[0] == "Per subject (Table 2 layout), mode one_step")
    v2 = next(r for r in per_subject[2] if r[0] == "V2")
    assert v2[per_subject[1].index("paper ss_kf R²")] == f"{TABLE2['V2']['ss_kf'][0]:.4g}"


def test_margin_table_equals_recomputed_margins(report, store_path, tmp_path):
    _, html = report
    ((caption, headers, rows),) = tables(section(html, "margins"))
    assert caption.startswith("Stored by the episode runner")
    assert [r[0] for r in rows] == ["D1 pid", "D2 lead_lag", "D3 mpc"]
    loops = designed_loops()
    for row, name in zip(rows, ("pid", "lead_lag", "mpc"), strict=True):
        m = loop_margins(loops[name])
        assert row[headers.index("GM (dB)")] == f"{m.gain_margin_db:.4g}"
        assert row[headers.index("PM (deg)")] == f"{m.phase_margin_deg:.4g}"
        assert row[headers.index("delay margin (s)")] == f"{m.delay_margin_s:.4g}"
        assert row[headers.index("Ms")] == f"{m.ms:.4g}"
        more = len(m.crossover_rad_s) - 1
        assert row[headers.index("gain crossovers (rad/s)")] == \
            f"{m.crossover_rad_s[0]:.4g}" + (f" (+{more} more)" if more else "")
        assert row[headers.index("stable")] == "yes"
    # asked to, the report re-analyses every loop and checks the stored margins against it
    out = build_report(store_path, tmp_path, sweep="episodes", render_frame=False,
                       recheck_margins=True)
    ((caption, headers, rows),) = tables(section(out.path.read_text(), "margins"))
    assert caption.startswith("Recomputed from each loop's state space")
    for row, name in zip(rows, ("pid", "lead_lag", "mpc"), strict=True):
        m = loop_margins(loops[name])
        assert row[headers.index("gain crossovers (rad/s)")] == \
            ", ".join(f"{w:.4g}" for w in m.crossover_rad_s)
        assert row[headers.index("phase crossovers (rad/s)")] == \
            (", ".join(f"{w:.4g}" for w in m.phase_crossover_rad_s) or "none")
        assert row[headers.index("row agrees")] == "yes"


def test_failed_rows_are_listed_with_their_error(report, store_path):
    _, html = report
    ((caption, headers, rows),) = tables(section(html, "failed"))
    with ResultStore(store_path) as store:
        failed = store.rows(status="failed")
    # persistence has no free run: the runner refuses it for each of the 3 subjects
    assert len(failed) == len(rows) == 3
    assert caption == "3 failed row(s)"
    for row, stored in zip(rows, failed, strict=True):
        assert row[0] == stored["hash"][:12]
        assert "persistence (free_run)" in row[1]
        assert row[2] == stored["error"].splitlines()[0]
        assert row[2].startswith("UnsupportedScenarioError: estimator persistence has modes")


def test_provenance_lists_versions_sweeps_and_hashes(report, store_path):
    import mujoco

    _, html = report
    prov = section(html, "provenance")
    assert f"<td class=\"text\">mujoco</td><td class=\"text\">{mujoco.__version__}</td>" in prov
    assert f"<td class=\"text\">control</td><td class=\"text\">{control.__version__}</td>" in prov
    assert "2026-01-02T03:04:05+00:00" in prov
    with ResultStore(store_path) as store:
        hashes = [r["hash"] for r in store.rows()]
        assert set(store.sweeps()) == {"episodes", "tiny_paper"}
    assert all(f"<code>{h}</code>" in prov for h in hashes)
    assert "<details>" in prov


def test_same_inputs_give_identical_html(store_path, tmp_path):
    a = build_report(store_path, tmp_path / "a", render_frame=False, created=CREATED)
    b = build_report(store_path, tmp_path / "b", render_frame=False, created=CREATED)
    assert a.path.read_bytes() == b.path.read_bytes()


def test_sections_without_data_become_a_note(store_path, tmp_path):
    result = build_report(store_path, tmp_path, sweep="tiny_paper", render_frame=False)
    omitted = {s.anchor for s in result.sections if s.omitted}
    assert omitted == {"summary", "combinations", "compare", "traces", "loops", "outcomes",
                       "margins", "frame", "feedback", "published"}
    html = result.path.read_text()
    assert "No episode rows: section omitted." in section(html, "traces")
    with ResultStore(store_path) as store:
        rows = store.rows(sweep="tiny_paper")
    failed = sum(r["status"] == "failed" for r in rows)
    assert (f"Sweep tiny_paper holds no episode rows ({len(rows) - failed} reproduction, 0 "
            f"other, {failed} failed): there is no grasp outcome to summarize.") \
        in unescape(section(html, "summary"))
    assert result.n_images == 1  # the bar chart


# ------------------------------------------------------------------ the command


def test_cli_writes_the_report(store_path, tmp_path, capsys):
    t0 = time.perf_counter()
    code = main(["report", str(store_path), "--out", str(tmp_path / "out"), "--sweep",
                 "episodes", "--no-render"])
    elapsed_s = time.perf_counter() - t0
    out, err = capsys.readouterr()
    assert code == 0 and err == ""
    assert out.startswith(f"wrote {tmp_path / 'out' / 'index.html'} (")
    assert "no data: 4. Paper tables" in out
    assert (tmp_path / "out" / "index.html").stat().st_size > 10_000
    print(f"report of {4 * 8} episode rows: {elapsed_s:.1f} s")


@pytest.mark.parametrize(("argv", "expected"), [
    (["nope.sqlite"], "nope.sqlite: no such results store (expected a file written by "
                      "griploop sweep)"),
    (["{db}", "--sweep", "nope"], "no sweep named 'nope' (found: episodes, tiny_paper)"),
    (["{db}", "--reproduction", "missing.json"], "missing.json: no such reproduction file"),
])
def test_cli_user_errors_are_one_line(store_path, tmp_path, capsys, monkeypatch, argv,
                                      expected):
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{db}", str(store_path)) for a in argv]
    code = main(["report", *argv, "--out", str(tmp_path / "out"), "--no-render"])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("griploop report: error: ")
    assert expected in err


# ------------------------------------------------------------------ grouping by swept factors

FIXTURE_FACTORS = ["object.name", "object.mass_kg", "object.friction", "controller.kind",
                   "estimator.name", "estimator.mode"]


def test_swept_factors_come_from_the_configs(store_path):
    with ResultStore(store_path) as store:
        episodes = D.split_rows(store.rows()).episodes
    # the seed varies too but is never a factor; the MPC's horizon (filled in by the schema
    # for the MPC only) is a consequence of the controller, not a factor
    assert FA.swept_factors(episodes) == FIXTURE_FACTORS
    assert len({e["config"]["seed"] for e in episodes}) == len(SEEDS)


def test_summary_has_one_row_per_factor_combination(report, store_path):
    _, html = report
    body = section(html, "combinations")
    assert re.search(r"<details><summary>Table of the 16 combinations</summary>\s*"
                     r'<div class="scroll"><table>', body)  # collapsed below the findings
    ((caption, headers, rows),) = tables(body)
    names = ["object", "mass (kg)", "friction", "controller", "estimator", "mode"]
    assert headers[:7] == [*names, "n"]
    with ResultStore(store_path) as store:
        episodes = [r["result"] for r in D.split_rows(store.rows()).episodes]
    fields = ("object_name", "object_mass_kg", "object_friction", "controller", "estimator",
              "mode")
    combos = {tuple(f"{r[f]:g}" if isinstance(r[f], float) else str(r[f]) for f in fields)
              for r in episodes}
    got = [tuple(r[:6]) for r in rows]
    assert len(got) == len(set(got)) == len(combos) == 16
    assert set(got) == combos
    for row in rows:
        cell = [r for r in episodes
                if tuple(f"{r[f]:g}" if isinstance(r[f], float) else str(r[f])
                         for f in fields) == tuple(row[:6])]
        assert int(row[6]) == len(cell) == len(SEEDS)
        dropped = sum(row_outcome(r) == "dropped" for r in cell)
        low, high = wilson_interval(dropped, len(cell))
        assert row[headers.index("dropped %")] == \
            f"{100 * dropped / len(cell):.0f} % ({100 * low:.0f}–{100 * high:.0f} %)"
        rmse = np.mean([r["tracking_rmse_n"] for r in cell])
        assert row[headers.index("tracking RMSE (N)")] == f"{rmse:.4g}"


@pytest.mark.parametrize(("k", "n", "low", "high"), [
    (0, 1, 0.0, 1.959963984540054 ** 2 / (1 + 1.959963984540054 ** 2)),
    (1, 1, 1 / (1 + 1.959963984540054 ** 2), 1.0),
    (8, 10, 0.4901625, 0.9433178),  # textbook value (Newcombe 1998, method 3)
])
def test_wilson_interval_closed_form(k, n, low, high):
    assert wilson_interval(k, n) == pytest.approx((low, high), abs=1e-6)
    assert all(np.isnan(wilson_interval(0, 0)))


def hand_row(i: int, controller: str, mass_kg: float, seed: int, *, held: bool = True,
             rmse: float = 1.0, slip_m: float = 0.0, reflex: bool = False,
             break_n: float = 4.0) -> dict:
    """An episode row as the store returns it, with only what the grouping reads."""
    config = {"kind": "episode", "seed": seed,
              "object": {"name": "egg", "mass_kg": mass_kg, "friction": 0.5,
                         "break_force_n": break_n},
              "controller": {"kind": controller, "horizon": 20 if controller == "mpc" else None,
                             "slip_reflex": {"enabled": reflex}},
              "estimator": {"name": "oracle", "mode": "free_run"}}
    result = {"controller": controller, "estimator": "oracle", "mode": "free_run",
              "object_name": "egg", "object_mass_kg": mass_kg, "object_friction": 0.5,
              "object_break_force_n": break_n, "seed": seed, "subject_id": 1,
              "outcome": "held" if held else "dropped", "lifted": True, "dropped": not held,
              "crushed": False, "slip_events": 0 if held else 2, "tracking_rmse_n": rmse,
              "slip_distance_m": slip_m, "contact_peak_ratio": 1.0}
    return {"hash": f"{i:064x}", "kind": "episode", "status": "ok", "config": config,
            "result": result}


def test_paired_differences_closed_form():
    # pid and mpc on the same 3 masses x 1 seed; mpc's RMSE is lower by 1, 2 and 3 N and it
    # drops the heaviest object; an extra mpc row (seed 9) has no pid partner
    rows = []
    for i, (mass, gap) in enumerate([(0.1, 1.0), (0.2, 2.0), (0.4, 3.0)]):
        rows.append(hand_row(2 * i, "pid", mass, 1, rmse=5.0 + gap, slip_m=0.01))
        rows.append(hand_row(2 * i + 1, "mpc", mass, 1, rmse=5.0, held=mass < 0.3,
                             slip_m=0.01 * (1 + i)))
    rows.append(hand_row(99, "mpc", 0.1, 9, rmse=100.0, held=False))
    factors = FA.swept_factors(rows)
    assert factors == ["object.mass_kg", "controller.kind"]  # horizon follows the controller
    diffs = {d.metric: d for d in SU.paired_differences(rows, factors)}
    t_975_2 = 4.302652729911275  # Student t, 97.5 % quantile, 2 degrees of freedom
    rmse = diffs["tracking_rmse_n"]
    assert (rmse.baseline, rmse.other, rmse.n_pairs) == ("pid", "mpc", 3)
    assert rmse.baseline_mean == pytest.approx(7.0) and rmse.other_mean == pytest.approx(5.0)
    # differences -1, -2, -3: mean -2, SD 1
    assert rmse.mean_diff == pytest.approx(-2.0)
    assert (rmse.ci_low, rmse.ci_high) == pytest.approx(
        (-2.0 - t_975_2 / np.sqrt(3), -2.0 + t_975_2 / np.sqrt(3)))
    held = diffs["held"]
    # differences 0, 0, -1: mean -1/3, SD 1/sqrt(3)
    assert held.mean_diff == pytest.approx(-1 / 3)
    assert held.ci_high - held.mean_diff == pytest.approx(t_975_2 / 3)
    slip = diffs["slip_distance_m"]
    assert slip.mean_diff == pytest.approx(0.01)  # 0, 0.01, 0.02
    # a row differing in another factor is not a pair
    shifted = [hand_row(0, "pid", 0.1, 1), hand_row(1, "mpc", 0.1, 1, reflex=True)]
    factors = FA.swept_factors(shifted)
    assert factors == ["controller.kind", "controller.slip_reflex.enabled"]
    assert all(d.n_pairs == 0 for d in SU.paired_differences(shifted, factors))
    assert SU.paired_differences(rows, ["object.mass_kg"]) == []  # controller not swept


def test_comparison_section_matches_a_recount(report, store_path):
    _, html = report
    ((caption, headers, rows),) = tables(section(html, "compare"))
    assert caption == "Paired differences"
    with ResultStore(store_path) as store:
        episodes = [r["result"] for r in D.split_rows(store.rows()).episodes]
    by = {(r["controller"], r["estimator"], r["object_mass_kg"], r["object_friction"],
           r["seed"]): r for r in episodes}
    pairs = [(a, by[("lead_lag", *k[1:])]) for k, a in by.items()
             if k[0] == "pid" and ("lead_lag", *k[1:]) in by]
    assert len(pairs) == len(MASSES_KG) * len(FRICTIONS) * len(SEEDS)  # ss_kf only
    row = next(r for r in rows if r[:3] == ["pid", "lead_lag", "tracking RMSE (N)"])
    diff = np.array([b["tracking_rmse_n"] - a["tracking_rmse_n"] for a, b in pairs])
    assert int(row[3]) == len(pairs)
    assert row[headers.index("B - A")] == f"{diff.mean():.4g}"
    half = 2.3646242510102993 * diff.std(ddof=1) / np.sqrt(diff.size)  # t(0.975, 7)
    assert row[-1] == f"{diff.mean() - half:.4g} to {diff.mean() + half:.4g}"
    assert {tuple(r[:2]) for r in rows} == {("pid", "lead_lag"), ("pid", "mpc"),
                                            ("lead_lag", "mpc")}


def test_heatmaps_are_faceted_by_the_factors_they_do_not_plot():
    # fragile.yaml's shape: mass and friction fixed, break force x controller x reflex
    rows = [hand_row(i, c, 0.06, 1, held=b > 1.0, reflex=r, break_n=b)
            for i, (b, c, r) in enumerate((b, c, r) for b in (0.4, 1.0, 4.0)
                                          for c in ("pid", "mpc") for r in (False, True))]
    factors = FA.swept_factors(rows)
    assert factors == ["object.break_force_n", "controller.kind",
                       "controller.slip_reflex.enabled"]
    rows_f, cols_f, grids = FA.faceted_grids(rows, factors)
    assert (rows_f, cols_f) == ("object.break_force_n", "controller.kind")
    assert [g.label for g in grids] == ["reflex no", "reflex yes"]
    for g in grids:
        assert g.row_levels == [0.4, 1.0, 4.0] and g.col_levels == ["pid", "mpc"]
        assert g.n_episodes.tolist() == [[1, 1]] * 3  # nothing averaged across facets
        assert g.dropped_frac[:, 0].tolist() == [1.0, 1.0, 0.0]  # held above 1 N only
    # the mass x friction grid of the fixture: one panel per object / design
    demo = [hand_row(i, c, m, 1) for i, (m, c) in enumerate(
        (m, c) for m in (0.1, 0.2) for c in ("pid", "mpc"))]
    for i, row in enumerate(demo):
        row["config"]["object"]["friction"] = row["result"]["object_friction"] = 0.3 + 0.1 * i
    rows_f, cols_f, grids = FA.faceted_grids(demo, FA.swept_factors(demo))
    assert (rows_f, cols_f) == ("object.mass_kg", "object.friction")
    assert [g.label for g in grids] == ["pid", "mpc"]


def test_traces_are_one_selectable_figure_per_scenario(report, store_path):
    _, html = report
    body = section(html, "traces")
    with ResultStore(store_path) as store:
        episodes = D.split_rows(store.rows()).episodes
    summaries = re.findall(r"<summary>(.*?)</summary>", body)
    captions = [unescape(c) for c in re.findall(r"<figcaption>(.*?)</figcaption>", body)]
    assert len(summaries) == len(captions) == body.count('<svg class="chart"') == len(episodes)
    assert body.count("<details open>") == 1
    for row, caption in zip(episodes, captions, strict=True):
        assert f"seed {row['result']['seed']}," in caption
        assert row["hash"][:12] in caption


def test_hostile_text_is_escaped(tmp_path):
    hostile = '<script>alert("x")</script>&amp;'
    loop = designed_loops()["pid"]
    path = tmp_path / "hostile.sqlite"
    version = package_version()
    with ResultStore(path) as store:
        members = []
        for i, name in enumerate((hostile, "can")):
            result, traces = simulate_episode(loop, "pid", "oracle", 0.4, 0.8, 1)
            result["object_name"] = name
            config = json.dumps({"kind": "episode", "seed": 1,
                                 "object": {"name": name}, "controller": {"kind": "pid"}},
                                sort_keys=True)
            key = content_hash(config, version, f"hostile:{i}")
            store.record(Outcome(key, "ok", result, encode_traces(traces), None, None, 0.0,
                                 1.0, 1.0, "test:0"), kind="episode", config_json=config,
                         task=f"hostile:{i}", version=version)
            members.append((key, i, {}))
        store.add_members(hostile, members)
    html = build_report(path, tmp_path / "out", render_frame=False).path.read_text()
    assert "<script" not in html.lower()
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt;&amp;amp;" in html
    ((_, headers, rows),) = tables(section(html, "combinations"))
    assert headers[0] == "object" and {r[0] for r in rows} == {hostile, "can"}


def test_episodes_that_held_no_force_have_no_loop(store_path):
    with ResultStore(store_path) as store:
        episodes = D.split_rows(store.rows()).episodes[:3]
        traces = {e["hash"]: dict(store.traces(e["hash"])) for e in episodes}
    crushed = episodes[0]
    crushed["result"] = {**crushed["result"], "held_force_n": None, "outcome": "crushed"}
    for name in D.LOOP_TRACES:
        del traces[crushed["hash"]][name]
    designs = LP.loop_designs(episodes, traces)
    assert sum(len(d.hashes) for d in designs) == 2
    assert crushed["hash"] not in designs[0].hashes
    del traces[episodes[1]["hash"]]["loop_A"]  # held a force but lost a matrix: an error
    with pytest.raises(ReportInputError, match="missing trace"):
        LP.loop_designs(episodes, traces)


def test_report_sets_virtual_next_to_real_and_says_the_reproduction_recommendation(
        store_path, tmp_path):
    import html

    result = run_reproduction(2, 0, estimators=("ridge", "features_mav", "features_wl",
                                                "ss_kf"), settings=ScoreSettings(channels=None),
                              analyses=ReproductionAnalyses(orders=(4,)))
    path = tmp_path / "all.json"
    path.write_text(json.dumps(result))
    out = build_report(store_path, tmp_path / "report", reproduction=path, created=CREATED)
    text = html.unescape(out.path.read_text())
    assert "Virtual subjects next to real people" in text
    assert "Estimation verdicts, virtual and real" in text
    # the sentence is generated by one function: the report says what reproduce said
    assert result["recommendation"]["reason"] in text
    a = result["transfer"]["agreement"]
    assert f"mean |virtual − real| {a['mean_abs_diff']:.3f}" in text
