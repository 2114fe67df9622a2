"""
A sweep and its report
======================

A question is a YAML sweep: a base scenario and a grid (or a random design) over any of
its fields. ``griploop sweep`` expands it, runs every scenario once (an interrupted sweep
resumes where it stopped) and keeps one row per scenario in an SQLite store;
``griploop report`` writes a self-contained HTML report of the store, and
``griploop export`` a table for your own analysis. ``scenarios/library/`` holds the
sweeps of the benchmarks and the demo.
"""

# %%
# The sweep file
# --------------
# The can at two masses and two frictions, held by the scheduled PI on the oracle
# reference (the controller alone), by one practised virtual user: four episodes.
import contextlib
import io
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import pyarrow.parquet as pq

from scenarios.cli import main

SWEEP = """\
name: newcomer
description: The can over mass x friction, scheduled PI, oracle reference.
seed: 7
base:
  kind: episode
  subject: {population_seed: 0, subject_id: 1}
  protocol: {name: grasp_lift_hold, hold_s: 1.0}
  object: {name: can}
  estimator: {name: oracle, mode: free_run}
  controller: {kind: pid, phase_margin_deg: 60.0, crossover_rad_s: 30.0}
  user: {kind: reacting, practice: 5}
grid:
  object.mass_kg: [0.2, 1.0]
  object.friction: [0.3, 1.0]
"""

work = Path(tempfile.mkdtemp(prefix="griploop-sweep-"))
(work / "newcomer.yaml").write_text(SWEEP)
store = work / "results.sqlite"


def griploop(*args: str) -> None:
    """Run one griploop command; stop with its error line on a non-zero exit status."""
    errors = io.StringIO()  # the error line, and progress bars, go to stderr
    with contextlib.redirect_stderr(errors):
        status = main(list(args))
    if status != 0:
        raise RuntimeError(f"griploop {' '.join(args)}: exit status {status}: "
                           f"{errors.getvalue().strip()}")


# %%
# Run it
# ------
# ``--dry-run`` counts the design first; ``--workers 2`` would fork two local workers.
griploop("sweep", str(work / "newcomer.yaml"), "--db", str(store), "--dry-run")
griploop("sweep", str(work / "newcomer.yaml"), "--db", str(store), "--workers", "1")

# %%
# Its report
# ----------
# Findings first (the factor that changes the outcome most, rates with intervals), then
# tables, force traces, loop analyses and outcome maps; one HTML file, figures embedded.
griploop("report", str(store), "--out", str(work / "report"))
print((work / "report" / "index.html").stat().st_size // 1024, "KB")

# %%
# Your own analysis
# -----------------
# ``griploop export`` writes Parquet and CSV: one row per scenario, the swept settings as
# ``config.*`` columns beside the results (``result.*``).
griploop("export", str(store), "--out", str(work / "table"))
table = pq.read_table(work / "table.parquet").to_pydict()
print(table["result.outcome"])
fig, ax = plt.subplots(figsize=(6, 3.5))
for mu in sorted(set(table["config.object.friction"])):
    rows = [i for i, f in enumerate(table["config.object.friction"]) if f == mu]
    rows.sort(key=lambda i: table["config.object.mass_kg"][i])
    ax.plot([table["config.object.mass_kg"][i] for i in rows],
            [table["result.held_force_n"][i] for i in rows], "o-", label=f"friction {mu}")
ax.set_xlabel("mass (kg)")
ax.set_ylabel("held grip force (N)")
ax.set_title("The practised user grips harder for heavier, more slippery cans")
ax.legend()
fig.tight_layout()
