"""Which parts of the virtual population make its estimation verdicts those of real people.

Run: ``.venv/bin/python benchmarks/population_vs_real.py [--subjects 20] [--seed 0]
[--only default,one_round] [--generator noise]`` (about a minute per variant on 2 cores).

For the default population and for variants that each remove one mechanism (the
"change one thing" experiment of issue 18), it records every subject's paper session,
scores the free_run estimators of the real table on all 8 channels (validation half),
and prints the agreement with the real recordings (:mod:`estimation.real_recordings`:
Spearman of the means, mean and largest absolute difference over the estimators reaching
R^2 0.5 on either side) with the estimators that move most, and the recordings'
difficulty statistics (:mod:`sim.user.difficulty`) next to the real ones.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from estimation.evaluation import fit_and_score  # noqa: E402
from estimation.features import extract_features  # noqa: E402
from estimation.real_recordings import (  # noqa: E402
    FREE_RUN_MEAN,
    RECORDING_STATISTICS,
    transfer_agreement,
)
from estimation.threads import one_blas_thread  # noqa: E402
from sim.user import subjects as S  # noqa: E402
from sim.user.difficulty import recording_difficulty, summarize  # noqa: E402

ESTIMATORS = tuple(FREE_RUN_MEAN)
SHOWN = ("mlp", "gbt", "ridge", "features_mav", "features_rms", "narx", "ss_sim")


def _old_exponents(s: S.VirtualSubject) -> S.VirtualSubject:
    """The sEMG-drive exponents of griploop 0.3.0 (flexors 0.85-1.15, ...), same quantiles."""
    old = {"flexor": (0.85, 1.15), "extensor": (1.00, 1.80), "other": (1.00, 2.00)}
    roles = S.MUSCLE_ROLES
    p = []
    for role, value in zip(roles, s.muscles.amplitude_exponent, strict=True):
        lo, hi = S._EXPONENT[role]
        q = (value - lo) / (hi - lo)
        p.append(old[role][0] + q * (old[role][1] - old[role][0]))
    gamma = tuple((v - S._MUAP_EXPONENT_FIT[0]) / S._MUAP_EXPONENT_FIT[1] for v in p)
    return dataclasses.replace(s, muscles=dataclasses.replace(
        s.muscles, amplitude_exponent=tuple(p), muap_exponent=gamma))


def _replace_armband(**kw: float) -> Callable[[S.VirtualSubject], S.VirtualSubject]:
    return lambda s: dataclasses.replace(s, armband=dataclasses.replace(s.armband, **kw))


def _replace_muscles(**kw: float) -> Callable[[S.VirtualSubject], S.VirtualSubject]:
    return lambda s: dataclasses.replace(s, muscles=dataclasses.replace(s.muscles, **kw))


#: name -> (what is removed, subject change, protocol rounds)
VARIANTS: dict[str, tuple[str, Callable[[S.VirtualSubject], S.VirtualSubject], int]] = {
    "default": ("nothing (griploop's population)", lambda s: s, 2),
    "one_round": ("the second round of squeezes (the paper's text: 3 squeezes)", lambda s: s, 1),
    "no_rig_lag": ("the sEMG stream's lag behind the FSR stream",
                   lambda s: dataclasses.replace(s, rig_lag_s=0.0), 2),
    "noisy_fsr": ("the steadier FSR contact (0.3.0: 12-16 %, 0.1-0.2 s)",
                  lambda s: dataclasses.replace(s, contact_std=0.14, contact_time_s=0.15), 2),
    "no_noise_drift": ("the drift of the electrodes' noise floor",
                       _replace_armband(noise_drift_std=0.0), 2),
    "no_artifacts": ("the loose-electrode bursts", _replace_armband(artifact_rate_hz=0.0), 2),
    "gaussian_carrier": ("the Laplacian-like sEMG distribution",
                         _replace_muscles(carrier_laplace=0.0), 2),
    "fixed_synergy": ("the squeeze-to-squeeze co-contraction changes",
                      _replace_muscles(cocontraction_drift_std=0.0), 2),
    "old_exponents": ("amplitude cancellation (0.3.0's sEMG-drive exponents)", _old_exponents, 2),
}


def run_variant(name: str, n: int, seed: int, generator: str) -> dict:
    """Scores, agreement and difficulty statistics of one variant."""
    _, change, rounds = VARIANTS[name]
    children = np.random.SeedSequence([seed, 0x5EED]).spawn(n)
    scores: dict[str, list[float]] = {e: [] for e in ESTIMATORS}
    stats = []
    with one_blas_thread():
        for subject, child in zip(S.make_population(n, seed), children, strict=True):
            session_ss, est_ss = child.spawn(2)
            rec = change(subject).paper_session(rng=np.random.default_rng(session_ss),
                                                generator=generator, rounds=rounds)
            stats.append(recording_difficulty(rec.emg, rec.force_n, rec.fs_hz))
            fs = extract_features(rec, channels=None)
            res, _ = fit_and_score(fs, ESTIMATORS, rng=np.random.default_rng(est_ss), order=4,
                                   time_steps=False)
            for e in ESTIMATORS:
                r2 = res[e]["modes"]["free_run"]["r2"]
                scores[e].append(np.nan if r2 is None else r2)
    means = {e: float(np.nanmean(v)) for e, v in scores.items()}
    return {"means": means, "agreement": transfer_agreement(means), "stats": summarize(stats)}


def main() -> None:
    """Parse the options, run the variants, print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--generator", default="noise")
    parser.add_argument("--only", default=",".join(VARIANTS),
                        help="comma-separated variants (default: all)")
    args = parser.parse_args()
    names = [v.strip() for v in args.only.split(",") if v.strip()]
    print(f"population_vs_real: {args.subjects} subjects, seed {args.seed}, generator "
          f"{args.generator}, free_run on all 8 channels, validation half")
    head = ("| variant (removed) | Spearman | mean abs diff | largest (estimator) | "
            + " | ".join(SHOWN) + " |")
    print(head)
    print("|" + "---|" * (4 + len(SHOWN)))
    print("| real recordings | 1 | 0 | 0 | "
          + " | ".join(f"{FREE_RUN_MEAN[e]:.3f}" for e in SHOWN) + " |")
    results = {}
    for name in names:
        t0 = time.perf_counter()
        r = results[name] = run_variant(name, args.subjects, args.seed, args.generator)
        a = r["agreement"]
        print(f"| {name} ({VARIANTS[name][0]}) | {a['spearman']:.2f} | "
              f"{a['mean_abs_diff']:.3f} | {a['max_abs_diff']:.3f} ({a['worst']}) | "
              + " | ".join(f"{r['means'][e]:.3f}" for e in SHOWN)
              + f" |  ({time.perf_counter() - t0:.0f} s)", flush=True)
    print("\nRecording statistics, median [min-max] (real: shared/REAL_RECORDINGS.md)")
    keys = list(RECORDING_STATISTICS)
    print("| variant | " + " | ".join(keys) + " |")
    print("|" + "---|" * (1 + len(keys)))
    print("| real | " + " | ".join(
        f"{np.median(RECORDING_STATISTICS[k]):.3g} [{min(RECORDING_STATISTICS[k]):.3g}-"
        f"{max(RECORDING_STATISTICS[k]):.3g}]" for k in keys) + " |")
    for name, r in results.items():
        print(f"| {name} | " + " | ".join(
            f"{r['stats'][k]['median']:.3g} [{r['stats'][k]['min']:.3g}-"
            f"{r['stats'][k]['max']:.3g}]" for k in keys) + " |")


if __name__ == "__main__":
    main()
