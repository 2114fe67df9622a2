"""What griploop's estimators score on real MYO + FSR recordings of the paper's protocol.

The recordings themselves cannot be shipped (their licence forbids it); these are the
derived figures of ``shared/REAL_RECORDINGS.md``: ten real subjects (S1-S10, the paper's
volunteers, from the first author's public data log), each evaluated with
``griploop evaluate --recording FILE --channels all --json OUT`` on griploop 0.3.0
(validation half, R^2 of the force). They are the yardstick of the virtual population:
a simulator whose estimation verdicts differ from these is not a proxy for real people.

:func:`transfer_agreement` compares a virtual table with them the way issue 18 defines
agreement: over every estimator whose mean R^2 reaches 0.5 on either side, the Spearman
rank correlation of the means, the mean absolute difference and the largest one.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: Where the figures come from (for reports and test messages).
SOURCE = ("shared/REAL_RECORDINGS.md: griploop evaluate --channels all on 10 real MYO + FSR "
          "recordings of the paper's protocol (griploop 0.3.0, validation half)")

#: Subjects of the per-subject columns, in order.
SUBJECTS = ("S1", "S2", "S3", "S4", "S5", "S6", "S7", "S8", "S9", "S10")

#: free_run (sEMG only), all 8 channels: estimator -> R^2 of S1..S10 (two decimals, as published).
FREE_RUN_PER_SUBJECT: dict[str, tuple[float, ...]] = {
    "mlp": (0.83, 0.84, 0.95, 0.88, 0.78, 0.95, 0.96, 0.96, 0.89, 0.94),
    "gbt": (0.78, 0.86, 0.90, 0.85, 0.62, 0.97, 0.96, 0.94, 0.86, 0.94),
    "ridge": (0.73, 0.83, 0.90, 0.82, 0.62, 0.96, 0.96, 0.93, 0.86, 0.94),
    "features_mav": (0.84, 0.73, 0.95, 0.90, 0.58, 0.95, 0.91, 0.91, 0.82, 0.93),
    "features_wl": (0.82, 0.78, 0.94, 0.91, 0.47, 0.95, 0.93, 0.91, 0.86, 0.92),
    "lda_qpf": (0.73, 0.93, 0.87, 0.82, 0.39, 0.95, 0.95, 0.92, 0.81, 0.91),
    "latent_kf": (0.72, 0.83, 0.96, 0.86, 0.33, 0.95, 0.93, 0.91, 0.78, 0.91),
    "narx": (0.77, 0.93, 0.90, 0.66, 0.55, 0.94, 0.95, 0.94, 0.62, 0.90),
    "features_rms": (0.84, 0.76, 0.94, 0.90, -0.01, 0.96, 0.93, 0.91, 0.81, 0.91),
    "ss_sim": (0.19, 0.66, -0.09, -1.05, -0.67, 0.87, 0.84, 0.72, 0.31, 0.50),
    "ss_kf": (0.65, 0.38, 0.38, 0.11, -0.93, 0.91, 0.83, 0.84, 0.41, 0.00),
}

#: free_run means as published (three decimals; the per-subject values are rounded).
FREE_RUN_MEAN: dict[str, float] = {
    "mlp": 0.898, "gbt": 0.867, "ridge": 0.854, "features_mav": 0.851, "features_wl": 0.848,
    "lda_qpf": 0.829, "latent_kf": 0.818, "narx": 0.818, "features_rms": 0.796,
    "ss_sim": 0.227, "ss_kf": 0.359,
}

#: one_step (the measured force up to k-1 enters), all 8 channels: estimator -> S1..S10.
ONE_STEP_PER_SUBJECT: dict[str, tuple[float, ...]] = {
    "persistence": (0.98, 0.99, 0.97, 0.96, 0.97, 0.99, 0.97, 0.96, 0.94, 0.96),
    "narx": (0.98, 1.00, 0.98, 0.97, 0.97, 0.99, 0.99, 0.97, 0.96, 0.97),
    "ss_kf": (0.97, 0.75, 0.95, 0.96, 0.86, 0.97, 0.98, 0.94, 0.91, 0.75),
}

#: one_step means as published.
ONE_STEP_MEAN: dict[str, float] = {"persistence": 0.969, "narx": 0.978, "ss_kf": 0.904}

#: Per-subject statistics of the recordings (definitions in shared/tools/recording_difficulty.py
#: and :mod:`sim.user.difficulty`): statistic -> S1..S10.
RECORDING_STATISTICS: dict[str, tuple[float, ...]] = {
    "squeezes": (8, 9, 6, 6, 7, 6, 6, 6, 6, 6),
    "peak_cv": (0.428, 0.449, 0.216, 0.445, 0.627, 0.408, 0.174, 0.232, 0.237, 0.312),
    "duty": (0.453, 0.521, 0.497, 0.32, 0.373, 0.457, 0.543, 0.465, 0.425, 0.475),
    "r2_lin_in": (0.945, 0.928, 0.936, 0.897, 0.918, 0.982, 0.967, 0.975, 0.942, 0.972),
    "r2_lin_out": (0.849, 0.728, 0.958, 0.916, 0.633, 0.95, 0.901, 0.911, 0.857, 0.936),
    "drift": (0.974, 0.802, 1.05, 1.16, 1.13, 0.784, 0.886, 1.15, 1.12, 1.06),
    "lag_ms": (-500, -125, -125, -625, 125, -500, 0, 0, -125, 125),
    "nonlin": (0.0453, 0.0231, 0.0284, 0.114, 0.0101, 0.00541, 0.091, 0.0229, 0.0406, 0.0334),
}

#: Agreement thresholds of issue 18 (over estimators reaching ``AGREEMENT_FLOOR`` on a side).
AGREEMENT_FLOOR = 0.5
MIN_SPEARMAN = 0.8
MAX_MEAN_ABS_DIFF = 0.04
MAX_ABS_DIFF = 0.10


def real_free_run(name: str) -> dict | None:
    """Real free_run figures of ``name``: ``{"r2_mean", "r2_min", "per_subject"}`` or None."""
    if name not in FREE_RUN_MEAN:
        return None
    per = FREE_RUN_PER_SUBJECT[name]
    return {"r2_mean": FREE_RUN_MEAN[name], "r2_min": min(per), "per_subject": list(per)}


def transfer_agreement(virtual_mean: Mapping[str, float | None],
                       real_mean: Mapping[str, float] | None = None,
                       *, floor: float = AGREEMENT_FLOOR) -> dict:
    """How far a virtual per-estimator table agrees with the real one.

    Parameters
    ----------
    virtual_mean : mapping
        Estimator name -> mean free_run R^2 on virtual subjects (``None``: not run).
    real_mean : mapping, optional
        Estimator name -> real mean R^2 (default :data:`FREE_RUN_MEAN`).
    floor : float
        Estimators enter when either mean reaches it (issue 18: 0.5).

    Returns
    -------
    dict
        ``names`` (compared, in real order), ``rows`` (name, virtual, real, difference),
        ``spearman``, ``mean_abs_diff``, ``max_abs_diff``, ``worst`` (name of the largest
        difference), ``n`` and ``agrees`` (all three thresholds met). With fewer than
        three comparable estimators the statistics are ``None`` and ``agrees`` is False.
    """
    from scipy.stats import spearmanr

    real_mean = FREE_RUN_MEAN if real_mean is None else real_mean
    names = [n for n in sorted(real_mean, key=lambda k: -real_mean[k])
             if virtual_mean.get(n) is not None
             and (virtual_mean[n] >= floor or real_mean[n] >= floor)]
    rows = [{"estimator": n, "virtual": float(virtual_mean[n]), "real": float(real_mean[n]),
             "difference": float(virtual_mean[n]) - float(real_mean[n])} for n in names]
    out: dict = {"names": names, "rows": rows, "n": len(names), "floor": floor,
                 "thresholds": {"spearman": MIN_SPEARMAN, "mean_abs_diff": MAX_MEAN_ABS_DIFF,
                                "max_abs_diff": MAX_ABS_DIFF}}
    if len(names) < 3:
        out.update(spearman=None, mean_abs_diff=None, max_abs_diff=None, worst=None,
                   agrees=False)
        return out
    v = np.array([r["virtual"] for r in rows])
    r = np.array([r["real"] for r in rows])
    d = np.abs(v - r)
    rho = float(spearmanr(v, r).statistic)
    out.update(spearman=rho, mean_abs_diff=float(d.mean()), max_abs_diff=float(d.max()),
               worst=names[int(np.argmax(d))])
    out["agrees"] = bool(rho >= MIN_SPEARMAN and out["mean_abs_diff"] <= MAX_MEAN_ABS_DIFF
                         and out["max_abs_diff"] <= MAX_ABS_DIFF)
    return out
