"""The report's first section: the factor finder on stores whose answer is known by
construction, and reports of stores with nothing to find (empty, only failed rows, one
level of every factor).

Episode rows are the fixture's simulated closed loops (``test_report.simulate_episode``)
with the outcome set by the test, so which factor decides the outcome is known.
"""

from __future__ import annotations

import itertools
import json
import re
from html import unescape
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from test_report import designed_loops, section, simulate_episode, tables

from scenarios.cli import main
from scenarios.report import build_report
from scenarios.report import data as D
from scenarios.report import factors as FA
from scenarios.report.findings import factor_effects, findings_sentence
from scenarios.store import Outcome, ResultStore, content_hash, encode_traces, package_version

Z95 = 1.959963984540054


def wilson(k: int, n: int) -> tuple[float, float]:
    """95 % Wilson interval, written out here (not the report's function)."""
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * np.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def pct(k: int, n: int) -> str:
    low, high = wilson(k, n)
    return f"{100 * k / n:.0f} % ({100 * low:.0f}–{100 * high:.0f} %)"


def write_store(path: Path, episodes: list[dict], failed: int = 0) -> Path:
    """A results store of episode rows ``{"mass": m, "controller": c, "seed": s,
    "outcome": o}`` (friction 0.5, the can) and ``failed`` failed rows."""
    loops = designed_loops()
    version = package_version()
    with ResultStore(path) as store:
        members = []
        for i, e in enumerate(episodes):
            result, traces = simulate_episode(loops[e["controller"]], e["controller"], "oracle",
                                              e["mass"], 0.5, e["seed"])
            outcome = e["outcome"]
            result.update(object_name="can", outcome=outcome, lifted=outcome != "not_lifted",
                          dropped=outcome == "dropped", crushed=outcome == "crushed")
            config = json.dumps({"kind": "episode", "seed": e["seed"],
                                 "object": {"name": "can", "mass_kg": e["mass"],
                                            "friction": 0.5},
                                 "estimator": {"name": "oracle", "mode": "one_step"},
                                 "controller": {"kind": e["controller"]}}, sort_keys=True)
            key = content_hash(config, version, f"findings:{i}")
            store.record(Outcome(key, "ok", result, encode_traces(traces), None, None, 0.0,
                                 1.0, 1.0, "test:0"), kind="episode", config_json=config,
                         task=f"findings:{i}", version=version)
            members.append((key, i, {}))
        for j in range(failed):
            config = json.dumps({"kind": "episode", "seed": j}, sort_keys=True)
            key = content_hash(config, version, f"failed:{j}")
            store.record(Outcome(key, "failed", {}, None, "RuntimeError: physics diverged",
                                 "Traceback ...", 0.0, 1.0, 1.0, "test:0"), kind="episode",
                         config_json=config, task=f"failed:{j}", version=version)
            members.append((key, len(episodes) + j, {}))
        if members:
            store.add_members("s", members)
    return path


def rows_of(path: Path) -> list[dict]:
    with ResultStore(path, read_only=True) as store:
        return D.split_rows(store.rows()).episodes


def finding(html: str) -> str:
    match = re.search(r'<p class="finding">(.*?)</p>', section(html, "summary"), re.S)
    assert match, "no finding sentence"
    return unescape(match.group(1))


# ------------------------------------------------------------------ the factor finder


def test_the_factor_that_decides_the_outcome_is_found(tmp_path):
    # mass decides (held at 0.1 kg, dropped at 0.4 kg); the controller changes nothing
    episodes = [{"mass": m, "controller": c, "seed": s, "outcome": "held" if m < 0.2 else
                 "dropped"} for m, c, s in itertools.product((0.1, 0.4), ("pid", "mpc"),
                                                            (1, 2, 3))]
    rows = rows_of(write_store(tmp_path / "r.sqlite", episodes))
    factors = FA.swept_factors(rows)
    assert factors == ["object.mass_kg", "controller.kind"]
    effects = factor_effects(rows, factors)
    assert [e.factor for e in effects] == ["object.mass_kg", "controller.kind"]
    assert effects[0].cramers_v == pytest.approx(1.0)
    assert effects[1].cramers_v == pytest.approx(0.0, abs=1e-12)
    # 2 x 2 table [[6, 0], [0, 6]]: chi2 = 12 with 1 degree of freedom
    assert effects[0].chi2 == pytest.approx(12.0)
    assert effects[0].p_value == pytest.approx(stats.chi2.sf(12.0, 1), rel=1e-9)
    assert (effects[0].outcome, effects[0].high.level, effects[0].low.level) == \
        ("held", 0.1, 0.4)
    assert stats.chi2.sf(12.0, 1) < 1e-3  # said as "p < 0.001"
    sentence = findings_sentence(rows, effects)
    match = re.fullmatch(
        r"Of the swept factors, mass \(kg\) changes the outcome most \(Cramér's V 1\.00; "
        r"permutation p = (\S+) with the sessions kept together, p = (\S+) after Holm's "
        r"correction over 2 factors\): (.*)\.", sentence)
    assert match, sentence
    # three sessions of four episodes, two of them at 0.1 kg: the split is as decisive only
    # when every session splits alike, one way or the other: p = 2 (1/6)^3 exactly; the
    # Monte Carlo estimate of 4000 shuffles is within 3 standard errors of it
    exact = 2 / 6**3
    assert float(match[1]) == pytest.approx(exact, abs=3 * np.sqrt(exact / 4000) + 5e-4)
    assert float(match[2]) == pytest.approx(2 * float(match[1]), rel=0.06)  # Holm, 2 factors
    assert match[3] == (f"held in {pct(6, 6)} of the 6 episodes at mass (kg) = 0.1 and in "
                        f"{pct(0, 6)} of the 6 at mass (kg) = 0.4")


def test_a_partial_effect_is_ranked_by_cramers_v(tmp_path):
    # controller: mpc holds 5 of 6, pid 1 of 6 (V 2/3); mass: 4 of 6 held at 0.1 kg, 2 of 6
    # at 0.4 kg (V 1/3); the others are dropped
    held = {("mpc", 0.1): (1, 1, 1), ("mpc", 0.4): (1, 1, 0), ("pid", 0.1): (1, 0, 0),
            ("pid", 0.4): (0, 0, 0)}
    episodes = [{"mass": m, "controller": c, "seed": seed, "outcome": "held" if ok else "dropped"}
                for (c, m), flags in held.items() for seed, ok in enumerate(flags, start=1)]
    rows = rows_of(write_store(tmp_path / "r.sqlite", episodes))
    effects = {e.factor: e for e in factor_effects(rows, FA.swept_factors(rows))}
    for factor, field in (("controller.kind", "controller"), ("object.mass_kg",
                                                               "object_mass_kg")):
        levels = sorted({r["result"][field] for r in rows}, key=str)
        outcomes = sorted({r["result"]["outcome"] for r in rows})
        counts = np.array([[sum(r["result"][field] == lv and r["result"]["outcome"] == o
                                for r in rows) for o in outcomes] for lv in levels])
        chi2, p, dof, _ = stats.chi2_contingency(counts, correction=False)
        v = stats.contingency.association(counts, method="cramer", correction=False)
        assert effects[factor].chi2 == pytest.approx(chi2, rel=1e-9)
        assert effects[factor].dof == dof
        assert effects[factor].p_value == pytest.approx(p, rel=1e-9)
        assert effects[factor].cramers_v == pytest.approx(v, rel=1e-9)
    ranked = factor_effects(rows, FA.swept_factors(rows))
    assert ranked[0].factor == "controller.kind"
    assert ranked[0].cramers_v > ranked[1].cramers_v > 0
    # the held rate is what the controller changes: 5 of 6 with mpc, 1 of 6 with pid
    assert (ranked[0].outcome, ranked[0].high.level, ranked[0].low.level) == \
        ("held", "mpc", "pid")
    assert f"held in {pct(5, 6)} of the 6 episodes at controller = mpc and in {pct(1, 6)}" \
        in findings_sentence(rows, ranked)


def test_factors_that_split_the_episodes_alike_are_one_effect():
    rows = []
    for i, (m, c) in enumerate(itertools.product((0.1, 0.4), ("pid", "mpc"))):
        result = {"controller": c, "estimator": "oracle", "mode": "one_step",
                  "object_name": "egg" if m < 0.2 else "block", "object_mass_kg": m,
                  "object_friction": 0.5, "outcome": "held" if m < 0.2 else "dropped"}
        rows.append({"hash": f"{i:064x}", "kind": "episode", "status": "ok", "result": result,
                     "config": {"seed": 1, "object": {"name": result["object_name"],
                                                      "mass_kg": m},
                                "controller": {"kind": c}}})
    effects = factor_effects(rows, FA.swept_factors(rows))
    assert [(e.factor, e.aliases) for e in effects] == [
        ("object.name", ("object.mass_kg",)), ("controller.kind", ())]
    assert effects[0].name == "object (same split as mass (kg))"


def test_no_factor_changing_the_outcome_is_said_so(tmp_path):
    episodes = [{"mass": m, "controller": c, "seed": 1, "outcome": "held"}
                for m, c in itertools.product((0.1, 0.4), ("pid", "mpc"))]
    path = write_store(tmp_path / "r.sqlite", episodes)
    html = build_report(path, tmp_path / "out", render_frame=False).path.read_text()
    assert finding(html) == ("No swept factor changes the outcome: every level of mass (kg), "
                             "controller has the same outcome rates (4 episodes: 4 held (none "
                             "not lifted, dropped or crushed)).")


def test_rates_by_factor_show_one_episode_as_its_outcome(tmp_path):
    episodes = [{"mass": 0.1, "controller": "pid", "seed": 1, "outcome": "held"},
                {"mass": 0.4, "controller": "pid", "seed": 1, "outcome": "dropped"},
                {"mass": 0.4, "controller": "pid", "seed": 2, "outcome": "held"}]
    path = write_store(tmp_path / "r.sqlite", episodes)
    html = build_report(path, tmp_path / "out", render_frame=False).path.read_text()
    ((_, headers, rows),) = tables(section(html, "summary"))
    assert headers == ["factor", "level", "n", "held % (95 % CI)", "dropped % (95 % CI)"]
    assert rows[0][1:] == ["0.1", "1", "held", "–"]  # n = 1: the outcome, not "100 (21-100)"
    assert rows[1][1:] == ["0.4", "2", pct(1, 2), pct(1, 2)]
    # per combination: every row ran once here but one, so rates where n > 1 only
    ((_, headers, rows),) = tables(section(html, "combinations"))
    assert [r[headers.index("held %")] for r in rows] == ["held", pct(1, 2)]


# ------------------------------------------------------------------ nothing to find


def check_page(html: str) -> None:
    """Every section is on the page, the summary first, none of them empty."""
    anchors = re.findall(r'<section id="(\w+)"><h2>', html)
    assert anchors[0] == "summary" and anchors[-1] == "provenance"
    for anchor in anchors:
        assert re.sub(r"<[^>]+>|\s", "", section(html, anchor)), anchor


@pytest.mark.parametrize(("episodes", "failed", "expected"), [
    ([], 0, "The store holds no rows: nothing has run, so there is nothing to summarize."),
    ([], 3, "All 3 rows of the store failed, so there is no outcome to summarize: their "
            "errors are listed under Failed scenarios."),
    ([{"mass": 0.2, "controller": "pid", "seed": s, "outcome": o}
      for s, o in ((1, "held"), (2, "dropped"), (3, "held"))], 0,
     f"Nothing varies between these 3 episodes but the seed (every factor has one level): "
     f"held in 2 of 3, {pct(2, 3)}; there is no factor to compare."),
    ([{"mass": 0.2, "controller": "pid", "seed": 1, "outcome": "crushed"}], 0,
     "The store holds one episode (crushed) and nothing varies: there is no factor to "
     "compare."),
], ids=["empty", "only-failed", "one-level", "one-episode"])
def test_a_store_with_nothing_to_compare_says_so_in_one_sentence(tmp_path, capsys, episodes,
                                                                  failed, expected):
    path = write_store(tmp_path / "r.sqlite", episodes, failed)
    code = main(["report", str(path), "--out", str(tmp_path / "out"), "--no-render"])
    out, err = capsys.readouterr()
    assert code == 0 and err == "", err
    html = (tmp_path / "out" / "index.html").read_text()
    assert finding(html) == expected
    check_page(html)
    if failed:
        ((caption, _, rows),) = tables(section(html, "failed"))
        assert caption == f"{failed} failed row(s)" and len(rows) == failed


def test_the_trial_table_gives_held_time_to_lift_attempts_and_margin_by_level() -> None:
    from scenarios.report.findings import trial_rows

    def episode(i: int, level: str, outcome: str, ttl: float | None, attempts: int,
                margin: float | None) -> dict:
        return {"hash": f"h{i}", "config": {"controller": {"kind": level}, "seed": i},
                "result": {"outcome": outcome, "controller": level, "attempts": attempts,
                           "time_to_lift_s": ttl, "safety_margin_pct": margin}}

    episodes = [episode(0, "pid", "held", 1.0, 1, 40.0), episode(1, "pid", "held", 2.0, 2, 60.0),
                episode(2, "pid", "not_lifted", None, 3, None),
                episode(3, "mpc", "held", 1.5, 1, 80.0)]
    rows = {r[0]: r for r in trial_rows(episodes, "controller.kind")}
    pid = rows["pid"]
    assert pid[1] == 3 and pid[6] == 2
    assert pid[2].startswith("67 %") and pid[4] == "2.00"  # held 2 of 3; mean attempts
    lo, hi = wilson(2, 3)
    assert f"({100 * lo:.0f}–{100 * hi:.0f} %)" in pid[2]
    assert pid[3] == "1.50 [1.25–1.75]" and pid[5] == "50 [45–55]"  # medians, quartiles
    assert rows["mpc"][3] == "1.50 [1.50–1.50]"


def test_the_summary_counts_the_sessions_the_episodes_rest_on() -> None:
    from scenarios.report.findings import session_text

    def episode(subject: int, seed: int) -> dict:
        return {"config": {"seed": seed}, "result": {"subject_id": subject, "seed": seed}}

    one = [episode(1, 0) for _ in range(27)]  # 27 episodes of one calibration session
    assert session_text(one) == ("1 subject in 1 session (the intervals describe these "
                                 "sessions, not a population)")
    many = [episode(s, 100 + s) for s in (1, 2, 3) for _ in range(4)] + [episode(1, 7)]
    assert session_text(many) == "3 subjects in 4 sessions"


def test_trace_bands_shade_the_phases_and_number_the_lift_offs() -> None:
    from scenarios.outcomes import PHASE_CODES
    from scenarios.report.build import phase_bands

    names = ["grasp"] * 3 + ["liftoff"] * 2 + ["grasp"] * 2 + ["liftoff"] * 2 + ["lift"] * 3
    t = np.arange(len(names)) * 0.1
    bands = phase_bands(t, np.array([PHASE_CODES.index(n) for n in names]))
    assert [b[2] for b in bands] == ["lift-off 1", "lift-off 2", "lift, hold"]
    assert bands[0][:2] == pytest.approx((0.3, 0.5)) and bands[2][1] == pytest.approx(1.2)
