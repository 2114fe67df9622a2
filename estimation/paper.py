"""The paper's reported numbers (Dutra, Silveira and Pereira), for side-by-side tables.

Copied from its Table 2 (per-subject R^2 and NRMSE, one-step evaluation with
measured force for SS_KF and NARX), Table 3 (timing and system properties) and
section 4.2 (single features and SS without KF, mean and SD over 10 subjects).
"""

from __future__ import annotations

#: Table 2: subject -> estimator -> (R^2, NRMSE).
TABLE2: dict[str, dict[str, tuple[float, float]]] = {
    "V1": {"ss_kf": (0.90617, 0.6919), "mlp": (0.84759, 0.60641),
           "narx": (0.83113, 0.58778), "lda_qpf": (0.90513, 0.69198)},
    "V2": {"ss_kf": (0.91252, 0.70311), "mlp": (0.87473, 0.64598),
           "narx": (0.87539, 0.64521), "lda_qpf": (0.88021, 0.65197)},
    "V3": {"ss_kf": (0.94191, 0.75803), "mlp": (0.94277, 0.76073),
           "narx": (0.95003, 0.77618), "lda_qpf": (0.94686, 0.76948)},
    "V4": {"ss_kf": (0.8761, 0.64634), "mlp": (0.885, 0.66072),
           "narx": (0.88386, 0.65828), "lda_qpf": (0.88641, 0.66273)},
    "V5": {"ss_kf": (0.86109, 0.61933), "mlp": (0.83272, 0.58468),
           "narx": (0.8918, 0.6686), "lda_qpf": (0.82408, 0.58055)},
    "V6": {"ss_kf": (0.93978, 0.7546), "mlp": (0.93401, 0.7424),
           "narx": (0.94219, 0.75911), "lda_qpf": (0.9639, 0.80998)},
    "V7": {"ss_kf": (0.95433, 0.78678), "mlp": (0.952, 0.78091),
           "narx": (0.96634, 0.81624), "lda_qpf": (0.94259, 0.76034)},
    "V8": {"ss_kf": (0.93114, 0.7368), "mlp": (0.93758, 0.75016),
           "narx": (0.95473, 0.78723), "lda_qpf": (0.92541, 0.72669)},
    "V9": {"ss_kf": (0.93607, 0.74814), "mlp": (0.94734, 0.77033),
           "narx": (0.91806, 0.71305), "lda_qpf": (0.9337, 0.74251)},
    "V10": {"ss_kf": (0.95258, 0.78181), "mlp": (0.9449, 0.76526),
            "narx": (0.9517, 0.77961), "lda_qpf": (0.92708, 0.72984)},
}

#: Table 2 average and SD rows: estimator -> (R^2 mean, R^2 SD, NRMSE mean, NRMSE SD).
TABLE2_SUMMARY: dict[str, tuple[float, float, float, float]] = {
    "ss_kf": (0.92126, 0.0319, 0.72268, 0.056333),
    "mlp": (0.90986, 0.04537, 0.70676, 0.07440),
    "narx": (0.91652, 0.04425, 0.71913, 0.07571),
    "lda_qpf": (0.91354, 0.041017, 0.71261, 0.06701),
}

#: Section 4.2: estimator -> (R^2 mean, R^2 SD, NRMSE mean, NRMSE SD).
SECTION_4_2: dict[str, tuple[float, float, float, float]] = {
    "features": (0.796, 0.0611, 0.547, 0.0733),  # MAV, RMS, WL pooled
    "ss": (0.9066, 0.044, 0.70, 0.0718),
    "ss_kf": (0.9212, 0.0319, 0.7227, 0.0563),
}

#: Table 3: estimator -> training ms (mean, SD), loop runtime ms (mean, SD),
#: controllable, observable, stable ("yes" or "-").
TABLE3: dict[str, dict[str, object]] = {
    "ss_kf": {"train_ms": (6.97, 3.11), "loop_ms": (0.00735, 0.0035),
              "controllable": "yes", "observable": "yes", "stable": "yes"},
    "narx": {"train_ms": (26.5, 21.9), "loop_ms": (0.0338, 0.014),
             "controllable": "-", "observable": "-", "stable": "-"},
    "mlp": {"train_ms": (1572.0, 2106.0), "loop_ms": (0.010, 0.0033),
            "controllable": "-", "observable": "-", "stable": "-"},
    "lda_qpf": {"train_ms": (15.37, 10.6), "loop_ms": (0.00742, 0.0032),
                "controllable": "-", "observable": "-", "stable": "yes"},
}

#: Order chosen by AIC in the paper.
PAPER_ORDER = 4
