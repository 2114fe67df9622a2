"""Closed-loop verdicts of practised users, and what practice changes (docs/results/, issue 27).

For each estimator whose real R2 is at least 0.8 (``mlp``, ``features_mav``, ``ridge``,
``gbt``, ``latent_kf``) and the oracle, with each controller (``pid``, ``lead_lag``,
``mpc``), and the two references the user's own force drives with ``pid`` and touch
(``ideal_interface``, the prosthesis's hand: the "intact hand" row of the results before
issue 37; ``intact``, the human-speed hand with grip coupled to load), every virtual
subject grasps rigid everyday objects drawn at random (a can of 0.2-1.0 kg with friction
0.3-1.0, three times in four; the aluminium block once in four), each episode with its own
seed, vision only (touch for the two references), in a 15 s trial: once
as a novice (``practice 0``) and once practised (5 lifts of the object's class). The
objects, subjects and seeds come from one generator seeded by ``--seed``; no test names
them. Prints, per user and arm: held with its 95 % Wilson interval, not lifted, dropped,
crushed, the median time from first contact to a secure lift, the mean attempts and the
median safety margin (held grip over the slip force, minus 1).

Run::

    .venv/bin/python benchmarks/closed_loop_verdicts.py [--subjects 10] [--objects 2]
        [--seed 27] [--workers 2] [--json FILE]
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

ESTIMATORS = ("mlp", "features_mav", "ridge", "gbt", "latent_kf")
#: The references the user's own force drives, felt by touch (scenarios.schema.names.OWN_FORCE).
OWN_FORCE = ("ideal_interface", "intact")
CONTROLLERS = ("pid", "lead_lag", "mpc")


def _episode(job: tuple) -> dict:
    from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from sim.hand.objects import make_object
    from sim.user.subjects import VirtualSubject

    estimator, controller, subject, obj, seed, practice = job
    feedback = "touch" if estimator in OWN_FORCE else "none"
    try:
        row = run_episode(VirtualSubject.sample(0, subject), make_object(**obj),
                          EpisodeSpec(estimator=estimator, controller=controller, seed=seed,
                          practice=practice, feedback=feedback)).row
    except (DivergedError, UnsupportedScenarioError) as exc:
        return {"job": job, "outcome": "failed", "error": str(exc)}
    return {"job": job, **{k: row[k] for k in ("outcome", "attempts", "time_to_lift_s",
                                               "safety_margin_pct", "belief_margin_pct",
                                               "user_corrections")}}


def jobs(subjects: int, objects: int, seed: int) -> list[tuple]:
    """Every (estimator, controller, subject, object, seed, practice) of the design."""
    rng = np.random.default_rng(seed)
    draws = []
    for subject in range(1, subjects + 1):
        for _ in range(objects):
            if rng.random() < 0.25:
                obj = {"name": "block"}
            else:
                obj = {"name": "can", "mass_kg": round(float(rng.uniform(0.2, 1.0)), 2),
                       "friction": round(float(rng.uniform(0.3, 1.0)), 2)}
            draws.append((subject, obj, int(rng.integers(2**31))))
    arms = ([(e, c) for e in (*ESTIMATORS, "oracle") for c in CONTROLLERS]
            + [(e, "pid") for e in OWN_FORCE])
    return [(e, c, s, o, sd, p) for p in (0, 5) for e, c in arms for s, o, sd in draws]


def summarize(results: list[dict]) -> list[dict]:
    from scenarios.stats import wilson_interval

    out = []
    keys = sorted({(r["job"][5], r["job"][0], r["job"][1]) for r in results},
                  key=lambda k: (k[0], (*ESTIMATORS, "oracle", *OWN_FORCE).index(k[1]), k[2]))
    for practice, estimator, controller in keys:
        mine = [r for r in results if (r["job"][5], r["job"][0], r["job"][1])
                == (practice, estimator, controller)]
        n = len(mine)
        held = sum(r["outcome"] == "held" for r in mine)

        def median(key: str, rows: list[dict] = mine) -> float | None:
            v = [r[key] for r in rows if r.get(key) is not None]
            return float(np.median(v)) if v else None

        attempts = [r["attempts"] for r in mine if r.get("attempts") is not None]
        out.append({"practice": practice, "estimator": estimator, "controller": controller,
                    "n": n, "held": held, "held_ci95": list(wilson_interval(held, n)),
                    **{o: sum(r["outcome"] == o for r in mine)
                       for o in ("not_lifted", "dropped", "crushed", "failed")},
                    "time_to_lift_s": median("time_to_lift_s"),
                    "attempts": float(np.mean(attempts)) if attempts else None,
                    "safety_margin_pct": median("safety_margin_pct"),
                    "belief_margin_pct": median("belief_margin_pct")})
    return out


def markdown(rows: list[dict]) -> str:
    def f(v: float | None, spec: str) -> str:
        return "-" if v is None else format(v, spec)

    lines = ["| user | reference | controller | held | 95 % CI | not lifted | dropped | "
             "crushed | time to lift (s) | attempts | safety margin (%) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lo, hi = r["held_ci95"]
        lines.append(f"| {'practised' if r['practice'] else 'novice'} | {r['estimator']} | "
                     f"{r['controller']} | {r['held']} of {r['n']} | "
                     f"{100 * lo:.0f}-{100 * hi:.0f} % | {r['not_lifted']} | {r['dropped']} | "
                     f"{r['crushed']} | {f(r['time_to_lift_s'], '.2f')} | "
                     f"{f(r['attempts'], '.2f')} | {f(r['safety_margin_pct'], '.0f')} |")
    for practice in (0, 5):
        mine = [r for r in rows if r["practice"] == practice and r["estimator"] in ESTIMATORS]
        held, n = sum(r["held"] for r in mine), sum(r["n"] for r in mine)
        lines.append(f"\n{'practised' if practice else 'novice'}, the five estimators x three "
                     f"controllers: {held} of {n} held ({100 * held / n:.1f} %)")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=10)
    parser.add_argument("--objects", type=int, default=2, help="rigid objects per subject")
    parser.add_argument("--seed", type=int, default=27)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    todo = jobs(args.subjects, args.objects, args.seed)
    t0 = time.perf_counter()
    with get_context("fork").Pool(args.workers) as pool:
        results = pool.map(_episode, todo, chunksize=4)
    rows = summarize(results)
    print(f"{len(todo)} episodes in {time.perf_counter() - t0:.0f} s "
          f"(.venv/bin/python {' '.join(sys.argv)})")
    print(markdown(rows))
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "episodes": results}, indent=1,
                                        default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
