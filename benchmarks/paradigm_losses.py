"""Why the paradigm table's objects were lost: the grip falling with a dip of the estimate?

Run (after ``benchmarks/paradigm_table.py``)::

    .venv/bin/python benchmarks/paradigm_losses.py --results paradigm_table.jsonl
        [--workers 2] [--out paradigm_losses.json]

Every lost object of the table is run again from its scenario (the same seed: the same
trial) with its traces: each slip-recovery trial whose object fell after the slip
onset, and each rigid episode that ended ``dropped``. A loss is read as **the grip fell
with a dip of the estimate** when, at its slip onset (the first step after the lift
with the hand's slip speed above 5 mm/s; for slip recovery the task's onset), both the
hand reference and the grip force are at most :data:`DIP` of their largest value over
the :data:`LOOKBACK_S` before it: the estimate dipped and the hand followed it down.
Otherwise the object went with the grip held (the load outgrew the grip, or the contact
chattered once it slid). Printed per row of the table (paradigm, drive, auto-grip).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import defaultdict
from multiprocessing import get_context
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parent))
import paradigm_table  # noqa: E402

DIP = 0.85
"""A reference and a grip at most this fraction of their largest over the lookback dipped."""
LOOKBACK_S = 2.0
SLIP_ONSET_M_S = 0.005


def classify(t_s: np.ndarray, reference_n: np.ndarray, grip_n: np.ndarray,
             onset_s: float) -> bool:
    """True when the reference and the grip both dipped before ``onset_s`` (module notes)."""
    window = (t_s >= onset_s - LOOKBACK_S) & (t_s <= onset_s)
    k = int(np.searchsorted(t_s, onset_s))
    k = min(k, t_s.size - 1)
    ref_max, grip_max = float(np.max(reference_n[window])), float(np.max(grip_n[window]))
    return bool(reference_n[k] <= DIP * ref_max and grip_n[k] <= DIP * grip_max
                and ref_max > 0 and grip_max > 0)


def _slip_losses(scenario) -> list[dict]:
    from scenarios.runners.feedback_tasks import TaskSetup, slip_trials

    setup = TaskSetup(scenario)
    out = []
    for t, load in slip_trials(setup, scenario):
        if load.onset_s is None or not t.info["dropped"]:
            continue
        tr = t.traces
        out.append({"onset_s": load.onset_s, "dip": classify(
            tr["t_s"], tr["reference_n"], tr["grip_force_n"], load.onset_s)})
    return out


def _rigid_losses(scenario) -> list[dict]:
    from scenarios.runners.episode import episode_from_scenario

    result = episode_from_scenario(scenario)
    if result.row["outcome"] != "dropped":
        return []
    tr = result.traces
    t, slip = tr["t_s"], tr["slip_speed_m_s"]
    up = np.flatnonzero(tr["wrist_height_m"] > 0.005)
    if not up.size:
        return []
    after = np.flatnonzero((slip > SLIP_ONSET_M_S) & (np.arange(t.size) >= up[0]))
    onset = float(t[after[0]]) if after.size else float(t[-1])
    return [{"onset_s": onset, "dip": classify(t, tr["reference_n"], tr["grip_force_n"],
                                               onset)}]


def _rerun(job: dict) -> dict:
    from scenarios.schema import parse_scenario

    scenario = parse_scenario(job["scenario"], source=job["id"])
    kind = job["id"].split("|")[0]
    losses = _slip_losses(scenario) if kind == "slip" else _rigid_losses(scenario)
    return {"id": job["id"], "losses": losses}


def lost_jobs(results: dict[str, dict], subjects: int) -> list[dict]:
    """The table's jobs that lost an object."""
    out = []
    for job in paradigm_table.jobs(subjects):
        r = results.get(job["id"])
        if r is None or "row" not in r:
            continue
        row = r["row"]
        kind = job["id"].split("|")[0]
        if (kind == "slip" and row["recovered"] < row["n"]) or (
                kind == "rigid" and row["outcome"] == "dropped"):
            out.append(job)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=Path("paradigm_table.jsonl"))
    parser.add_argument("--subjects", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    results = {}
    for line in args.results.read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            results[r["id"]] = r
    todo = lost_jobs(results, args.subjects)
    print(f"{len(todo)} scenarios lost an object; running them again with their traces",
          flush=True)
    with get_context("fork").Pool(args.workers, maxtasksperchild=100) as pool:
        reruns = list(pool.imap(_rerun, todo, chunksize=1))
    table: dict = defaultdict(lambda: defaultdict(lambda: {"losses": 0, "dip": 0}))
    for r in reruns:
        parts = r["id"].split("|")
        row = "|".join(parts[1:4])
        what = parts[0] if parts[0] == "rigid" else f"slip {parts[-1]}"
        for loss in r["losses"]:
            table[row][what]["losses"] += 1
            table[row][what]["dip"] += int(loss["dip"])
    print(f"\nlosses, and of them the grip falling with a dip of the estimate (both at most "
          f"{DIP:g} of their largest over the {LOOKBACK_S:g} s before the slip onset):\n")
    print("| paradigm | drive | auto-grip | slip 400/125 | slip 200/50 | rigid |")
    print("|---|---|---|---|---|---|")
    for p, d, g in paradigm_table.ROWS:
        cells = table[f"{p}|{d}|{int(g)}"]

        def cell(what: str, cells=cells) -> str:
            c = cells[what]
            return f"{c['dip']} of {c['losses']}"

        print(f"| {p} | {d} | {'on' if g else 'off'} | {cell('slip 400')} | "
              f"{cell('slip 200')} | {cell('rigid')} |")
    if args.out is not None:
        args.out.write_text(json.dumps({"reruns": reruns, "table": table}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
