"""
Your own recording
==================

``griploop evaluate`` runs the paper's protocol on one recording: MAV, RMS and WL
features every 125 ms, the first half of the windows to identify each estimator, the
second half to score it. Here the recording comes from a virtual subject
(``griploop subjects``); a file of yours takes its place, as NPZ or as another tool's CSV
with column options (see :doc:`/FORMAT`).
"""

# %%
# A recording to score
# --------------------
# ``griploop subjects`` writes one recording per virtual subject, as NPZ (lossless) and
# as plain CSV with a JSON sidecar. ``scenarios.cli.main`` runs any ``griploop``
# command in this process and returns its exit status.
import contextlib
import io
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from scenarios.cli import main
from sim.recording import load_recording


def griploop(*args: str) -> None:
    """Run one griploop command; stop with its error line on a non-zero exit status."""
    errors = io.StringIO()  # the error line, and progress bars, go to stderr
    with contextlib.redirect_stderr(errors):
        status = main(list(args))
    if status != 0:
        raise RuntimeError(f"griploop {' '.join(args)}: exit status {status}: "
                           f"{errors.getvalue().strip()}")


work = Path(tempfile.mkdtemp(prefix="griploop-recording-"))
griploop("subjects", "--n", "1", "--seed", "0", "--out", str(work))

# %%
# What it holds
# -------------
# ``load_recording`` reads NPZ and CSV alike: int8 sEMG of shape (n_samples, 8) at
# ``fs_hz``, and the force the FSR measured, in newtons.
rec = load_recording(work / "subject01.csv")
t_s = np.arange(rec.emg.shape[0]) / rec.fs_hz
fig, (ax_f, ax_e) = plt.subplots(2, 1, sharex=True, figsize=(8, 4.5),
                                 gridspec_kw={"height_ratios": [1, 2]})
ax_f.plot(t_s, rec.force_n, color="k")
ax_f.set_ylabel("force (N)")
for ch in range(rec.emg.shape[1]):
    ax_e.plot(t_s, rec.emg[:, ch] / 300.0 + ch + 1, lw=0.3)
ax_e.set_yticks(range(1, rec.emg.shape[1] + 1), rec.channel_names)
ax_e.set_xlabel("time (s)")
fig.suptitle(f"{rec.emg.shape[1]} channels at {rec.fs_hz:g} Hz, {t_s[-1]:.0f} s")
fig.tight_layout()

# %%
# Score it
# --------
# The paper's channels (6-8) and a few estimators; ``--estimators`` left out scores every
# registered one. ``one_step`` feeds the measured force up to k-1 into the estimate (the
# paper's evaluation), ``free_run`` uses sEMG only, as a prosthesis must.
scores = work / "scores.json"
griploop("evaluate", "--recording", str(work / "subject01.csv"),
         "--estimators", "ss_kf,persistence,features_mav,ridge", "--json", str(scores))

# %%
# The JSON holds every figure of the table, by estimator and mode, and how the recording
# was split. What a prosthesis without a force sensor gets is the ``free_run`` column:
result = json.loads(scores.read_text())
print(f"{result['recording']['n_windows']} windows, "
      f"{result['recording']['n_identification']} to identify")
for name, modes in result["estimators"].items():
    if "free_run" in modes:
        print(f"{name:14s} free_run R2 {modes['free_run']['r2_mean']:.3f}")
