"""The paradigm table of issues 35 and 36: force and force_hold, on both drives, with and without
auto_grip; velocity with each decoder on the self-locking drive.

Every row runs the same practised virtual users on the same seeds (paired): the benchmarks
of ``griploop`` as their library files set them (``scenarios/library/*.yaml``), with the
hand's ``paradigm``, ``hand.drive`` and ``auto_grip`` of the row, for each estimator
(``ss_kf``, ``mlp``, ``latent_kf``; free run, PID) and each feedback (vision only,
``slip_vibration``). Columns:

- **rigid**: grasp-lift-hold episodes of rigid everyday objects drawn at random per
  subject (a can of 0.2-1.0 kg, friction 0.3-1.0, three times in four; the aluminium block
  once in four; ``benchmarks/closed_loop_verdicts.py``'s draw), 15 s trials: held (Wilson
  95 %), time to a secure lift (median), attempts (mean), safety margin (median);
- **slip**: slip recovery under a load rising at 1 N/s (3 loads per subject), at the
  paper's 400/125 ms window and at 200/50 ms: recovered / slipped (Wilson 95 %), and,
  since a hand that grips harder slips less often and later, **kept**: the lifted cans
  still in the hand at the end (recovered, or never slipped) over the lifted, and the
  mean load at the slip onset;
- **force**: force matching at 20/40/60 % of the hand force at MVC on the block: absolute
  error, the hand's CV and time to reach the target (within 10 %), means with
  Student-t 95 %;
- **transfers**: 60 s of timed transfers of the 50 mm block: blocks per minute (mean,
  Student-t 95 %) and blocks put down but not released;
- **eggs**: the Virtual Eggs Test's 11 eggs, one transfer each: success (Wilson 95 %),
  overall and for eggs breaking at 2-4 N.

The ``velocity`` rows (issue 36; ``velocity+pattern``, ``velocity+two_site``: the paradigm
and its decoder) run on the self-locking drive without auto-grip, and with ``ss_kf`` only:
velocity takes the grip from the decoded close signal, not from the force estimate, so the
estimator changes nothing in them.

Run::

    .venv/bin/python benchmarks/paradigm_table.py [--subjects 10] [--workers 2]
        [--rows all|issue35|velocity] [--out paradigm_table.jsonl] [--summary F.json]

Results are appended to ``--out`` one job per line as they finish, so an interrupted run
resumes where it stopped; ``--summary`` writes the table's figures. ``--markdown`` prints
the table as in docs/results/person-in-the-loop.md.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from multiprocessing import get_context
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

ISSUE35_ROWS = [(p, d, g) for p in ("force", "force_hold")
                for d in ("backdrivable", "self_locking") for g in (False, True)]
VELOCITY_ROWS = [(f"velocity+{decoder}", "self_locking", False)
                 for decoder in ("pattern", "two_site")]
ROWS = ISSUE35_ROWS + VELOCITY_ROWS
ESTIMATORS = ("ss_kf", "mlp", "latent_kf")
#: The estimators a row runs with (velocity's grip does not come from the estimate).
ROW_ESTIMATORS = {row: ESTIMATORS if row in ISSUE35_ROWS else ("ss_kf",) for row in ROWS}


def hand_fields(paradigm_id: str) -> dict:
    """A row's ``paradigm`` (and ``decoder``: ``velocity+pattern``) as scenario fields."""
    paradigm, _, decoder = paradigm_id.partition("+")
    return {"paradigm": paradigm, **({"decoder": decoder} if decoder else {})}
FEEDBACK = ("none", "slip_vibration")
WINDOWS = ((400.0, 125.0), (200.0, 50.0))
SEED = 35


def _library(kind: str) -> dict:
    from importlib.resources import files

    import yaml

    return yaml.safe_load((files("scenarios") / "library" / f"{kind}.yaml").read_text())["base"]


def _draws(subjects: int) -> list[tuple[int, dict, int]]:
    """Two rigid objects per subject and a seed for each (closed_loop_verdicts' draw)."""
    rng = np.random.default_rng(SEED)
    out = []
    for subject in range(1, subjects + 1):
        for _ in range(2):
            if rng.random() < 0.25:
                obj = {"name": "block"}
            else:
                obj = {"name": "can", "mass_kg": round(float(rng.uniform(0.2, 1.0)), 2),
                       "friction": round(float(rng.uniform(0.3, 1.0)), 2)}
            out.append((subject, obj, int(rng.integers(2**31))))
    return out


def jobs(subjects: int, rows: list = ROWS) -> list[dict]:
    """Every scenario of the table's ``rows``, as ``{"id": ..., "scenario": {...}}``."""
    from scenarios.schema import derive_seed

    out = []
    draws = _draws(subjects)
    for estimator in ESTIMATORS:
        for feedback in FEEDBACK:
            for paradigm, drive, auto_grip in rows:
                if estimator not in ROW_ESTIMATORS[(paradigm, drive, auto_grip)]:
                    continue
                row = {"estimator": {"name": estimator, "mode": "free_run"},
                       "controller": {"kind": "pid"}, **hand_fields(paradigm),
                       "hand": {"drive": drive}, "auto_grip": auto_grip,
                       "user": {"kind": "reacting", "feedback": feedback, "practice": 5}}
                key = f"{paradigm}|{drive}|{int(auto_grip)}|{estimator}|{feedback}"
                for subject, obj, seed in draws:
                    out.append({"id": f"rigid|{key}|{subject}|{seed}", "scenario": {
                        "kind": "episode", "seed": seed, "object": obj,
                        "subject": {"subject_id": subject}, **row}})
                for subject in range(1, subjects + 1):
                    seed = derive_seed(SEED, f"subject {subject}", 0)
                    subj = {"subject_id": subject}
                    for window, step in WINDOWS:
                        base = _library("slip_recovery")
                        out.append({"id": f"slip|{key}|{subject}|{window:g}", "scenario": {
                            **base, "seed": seed, "subject": subj, **row,
                            "estimator": {**row["estimator"], "window_ms": window,
                                          "step_ms": step}}})
                    for target in (0.2, 0.4, 0.6):
                        base = _library("force_matching")
                        out.append({"id": f"force|{key}|{subject}|{target:g}", "scenario": {
                            **base, "seed": seed, "subject": subj, **row,
                            "protocol": {**base["protocol"], "target_fraction": target}}})
                    base = _library("transfers")
                    out.append({"id": f"transfers|{key}|{subject}", "scenario": {
                        **base, "seed": seed, "subject": subj, **row}})
                    base = _library("eggs")
                    for egg in (0.4, 0.56, 0.78, 1.1, 1.53, 2.14, 3.0, 4.2, 5.87, 8.22, 11.5):
                        out.append({"id": f"eggs|{key}|{subject}|{egg:g}", "scenario": {
                            **base, "seed": seed, "subject": subj, **row,
                            "protocol": {**base["protocol"], "trials": 1},
                            "object": {**base["object"], "break_force_n": egg}}})
    return out


def _run(job: dict) -> dict:
    from scenarios.runners.dispatch import run_scenario
    from scenarios.schema import parse_scenario

    t0 = time.perf_counter()
    try:
        row = run_scenario(parse_scenario(job["scenario"], source=job["id"]))
    except Exception as exc:  # a failed scenario is counted, never dropped
        return {"id": job["id"], "error": f"{type(exc).__name__}: {exc}"}
    keep = {k: v for k, v in row.items() if k != "traces" and not k.startswith("t_")}
    return {"id": job["id"], "row": keep, "wall_s": time.perf_counter() - t0}


def summarize(results: list[dict], rows: list = ROWS) -> dict:
    """The table's figures per row (paradigm, drive, auto_grip) over estimators and feedback."""
    from scenarios.stats import mean_interval, wilson_interval

    def ci(values: list) -> dict:
        m, lo, hi = mean_interval([v for v in values if v is not None])
        return {"mean": None if np.isnan(m) else m,
                "ci95": None if np.isnan(lo) else [lo, hi], "n": len(values)}

    def rate(k: int, n: int) -> dict:
        return {"rate": k / n if n else None, "ci95": list(wilson_interval(k, n)) if n else None,
                "k": k, "n": n}

    table: dict = {}
    for paradigm, drive, auto_grip in rows:
        for feedback in (*FEEDBACK, "all"):
            key = f"{paradigm}|{drive}|{int(auto_grip)}"
            mine = [r for r in results if "row" in r and r["id"].split("|")[1:4]
                    == key.split("|") and (feedback == "all" or r["id"].split("|")[5]
                                           == feedback)]
            failed = sum(1 for r in results if "error" in r and r["id"].split("|")[1:4]
                         == key.split("|") and (feedback == "all" or r["id"].split("|")[5]
                                                == feedback))

            def of(kind: str, mine: list = mine) -> list[dict]:
                return [r["row"] for r in mine if r["id"].startswith(kind + "|")]

            rigid = of("rigid")
            held = sum(r["outcome"] == "held" for r in rigid)
            slip, kept, slip_load = {}, {}, {}
            for window, _ in WINDOWS:
                rows = [r["row"] for r in mine if r["id"].startswith("slip|")
                        and r["id"].endswith(f"|{window:g}")]
                slip[f"{window:g}"] = rate(sum(r["recovered"] for r in rows),
                                           sum(r["n"] for r in rows))
                kept[f"{window:g}"] = rate(sum(r["recovered"] + r["no_slip"] for r in rows),
                                           sum(r["n"] + r["no_slip"] for r in rows))
                slip_load[f"{window:g}"] = ci([r["slip_load_n"] for r in rows])["mean"]
            force = of("force")
            transfers = of("transfers")
            eggs = of("eggs")
            mid = [r for r in eggs if 2.0 <= r["break_force_n"] <= 4.0]
            table[f"{key}|{feedback}"] = {
                "paradigm": paradigm, "drive": drive, "auto_grip": auto_grip,
                "feedback": feedback, "failed": failed,
                "rigid_held": rate(held, len(rigid)),
                "rigid_held_by_estimator": {
                    e: rate(sum(r["outcome"] == "held" for r in rs), len(rs))
                    for e in ESTIMATORS
                    for rs in [[r["row"] for r in mine if r["id"].startswith("rigid|")
                                and r["id"].split("|")[4] == e]]},
                "time_to_lift_s": _median([r["time_to_lift_s"] for r in rigid]),
                "attempts": ci([r["attempts"] for r in rigid])["mean"],
                "margin_pct": _median([r["safety_margin_pct"] for r in rigid]),
                "slip_recovered": slip, "slip_kept": kept, "slip_load_n": slip_load,
                "force_abs_error_n": ci([r["abs_error_n"] for r in force]),
                "force_cv": ci([r["cv"] for r in force]),
                "time_to_target_s": ci([r.get("time_to_target_s") for r in force]),
                "transfers_per_min": ci([r["blocks_per_min"] for r in transfers]),
                "not_released": int(sum(r["not_released"] for r in transfers)),
                "rigid_unrequested_opens": int(sum(r.get("unrequested_opens") or 0
                                                   for r in rigid)),
                "rigid_decoder_windows": int(sum(r.get("decoder_windows") or 0
                                                 for r in rigid)),
                "transfers_started": int(sum(r["transfers"] for r in transfers)),
                "eggs_success": rate(sum(r["success"] for r in eggs),
                                     sum(r["transfers"] for r in eggs)),
                "eggs_success_2_4_n": rate(sum(r["success"] for r in mid),
                                           sum(r["transfers"] for r in mid)),
            }
    return table


def _median(values: list) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.median(kept)) if kept else None


def markdown(table: dict, feedback: str = "all") -> str:
    """The table's rows for one feedback (``all``: both pooled)."""
    def pct(r: dict) -> str:
        if not r or r["rate"] is None:
            return "-"
        return f"{100 * r['rate']:.0f} ({100 * r['ci95'][0]:.0f}-{100 * r['ci95'][1]:.0f})"

    def mean(r: dict, spec: str = ".2f") -> str:
        if r["mean"] is None:
            return "-"
        ci = r["ci95"]
        return format(r["mean"], spec) + ("" if ci is None else
                                          f" ({format(ci[0], spec)}-{format(ci[1], spec)})")

    lines = ["| paradigm | drive | auto-grip | rigid held % | lift s | attempts | margin % | "
             "slip recovered 400/125 % | kept 400/125 % | slip recovered 200/50 % | "
             "kept 200/50 % | force error N | hand CV % | to target s | transfers/min | "
             "not released | eggs % | eggs 2-4 N % | failed |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for entry in table.values():
        if entry["feedback"] != feedback:
            continue
        lines.append(
            f"| {entry['paradigm']} | {entry['drive']} | {'on' if entry['auto_grip'] else 'off'}"
            f" | {pct(entry['rigid_held'])} | {_fmt(entry['time_to_lift_s'])} | "
            f"{_fmt(entry['attempts'])} | {_fmt(entry['margin_pct'], '.0f')} | "
            f"{pct(entry['slip_recovered']['400'])} | {pct(entry['slip_kept']['400'])} | "
            f"{pct(entry['slip_recovered']['200'])} | {pct(entry['slip_kept']['200'])} | "
            f"{mean(entry['force_abs_error_n'])} | {mean(_pct_of(entry['force_cv']), '.1f')} | "
            f"{mean(entry['time_to_target_s'])} | "
            f"{mean(entry['transfers_per_min'], '.1f')} | {entry['not_released']} of "
            f"{entry['transfers_started']} | {pct(entry['eggs_success'])} | "
            f"{pct(entry['eggs_success_2_4_n'])} | {entry['failed']} |")
    return "\n".join(lines)


def markdown_rigid(table: dict, feedback: str = "all") -> str:
    """Rigid objects held, per estimator, for one feedback."""
    def pct(r: dict) -> str:
        if not r or r["rate"] is None:
            return "-"
        return (f"{100 * r['rate']:.0f} ({100 * r['ci95'][0]:.0f}-{100 * r['ci95'][1]:.0f}; "
                f"{r['k']} of {r['n']})")

    lines = ["| paradigm | drive | auto-grip | " + " | ".join(ESTIMATORS) + " |",
             "|---|---|---|" + "---|" * len(ESTIMATORS)]
    for entry in table.values():
        if entry["feedback"] == feedback:
            by = entry["rigid_held_by_estimator"]
            lines.append(f"| {entry['paradigm']} | {entry['drive']} | "
                         f"{'on' if entry['auto_grip'] else 'off'} | "
                         + " | ".join(pct(by[e]) for e in ESTIMATORS) + " |")
    return "\n".join(lines)


def _pct_of(r: dict) -> dict:
    """A mean-and-interval of fractions, in percent."""
    return {"mean": None if r["mean"] is None else 100 * r["mean"],
            "ci95": None if r["ci95"] is None else [100 * v for v in r["ci95"]], "n": r["n"]}


def _fmt(value: float | None, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=Path("paradigm_table.jsonl"))
    parser.add_argument("--summary", type=Path, default=None)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--rows", choices=("all", "issue35", "velocity"), default="all",
                        help="the table's rows to run and summarize (default all)")
    parser.add_argument("--summarize-only", action="store_true",
                        help="summarize --out as it is, running nothing")
    args = parser.parse_args(argv)
    rows = {"all": ROWS, "issue35": ISSUE35_ROWS, "velocity": VELOCITY_ROWS}[args.rows]
    todo = jobs(args.subjects, rows)
    done = {}
    if args.out.exists():
        for line in args.out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[r["id"]] = r
    pending = [] if args.summarize_only else [j for j in todo if j["id"] not in done]
    print(f"{len(todo)} scenarios, {len(done)} done, {len(pending)} to run", flush=True)
    t0 = time.perf_counter()
    with get_context("fork").Pool(args.workers, maxtasksperchild=200) as pool, \
            args.out.open("a") as fh:
        for i, result in enumerate(pool.imap(_run, pending, chunksize=1), 1):
            fh.write(json.dumps(result, default=float) + "\n")
            fh.flush()
            done[result["id"]] = result
            if i % 200 == 0 or i == len(pending):
                print(f"{i} of {len(pending)} in {time.perf_counter() - t0:.0f} s", flush=True)
    results = [done[j["id"]] for j in todo if j["id"] in done]
    table = summarize(results, rows)
    if args.summary is not None:
        args.summary.write_text(json.dumps(table, indent=1, default=float))
    if args.markdown:
        for feedback in (*FEEDBACK, "all"):
            print(f"\nfeedback: {feedback}\n")
            print(markdown(table, feedback))
        print("\nrigid objects held, per estimator (both feedbacks):\n")
        print(markdown_rigid(table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
