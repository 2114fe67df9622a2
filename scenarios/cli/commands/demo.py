"""``griploop demo``: the main job on embedded defaults, end to end.

Runs, in order, the same commands a user would: virtual subjects and a plot of
one recording, the paper reproduction, the margin tables of the three
controller families over grip force, the loop measured on the simulated hand
by sine injection, one closed-loop episode, the four-reference comparison, a
small mass x friction sweep, and the HTML report of it all.
"""

from __future__ import annotations

import argparse
import time
from importlib.resources import files
from pathlib import Path

from controllers.design import DEFAULT_SPECS


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``demo`` subcommand."""
    p = subparsers.add_parser(
        "demo",
        help="run the main job on embedded defaults and write a report",
        description="Generate 10 virtual subjects, reproduce the paper's tables (one_step and "
        "free_run), print the controllers' margin tables, run one closed-loop episode and the "
        "four-reference comparison, sweep the can over mass x friction x controller, and write "
        "an HTML report. Everything lands in --out.",
    )
    p.add_argument("--out", type=Path, default=Path("demo_out"), metavar="DIR",
                   help="output directory (default demo_out)")
    p.add_argument("--workers", type=int, default=2,
                   help="sweep worker processes (default 2)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop demo``; returns the exit status of the first failing step, or 0."""
    from scenarios.cli.main import main

    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    sweep_file = str(files("scenarios") / "library" / "demo.yaml")
    steps = [
        ("virtual subjects", ["subjects", "--n", "10", "--seed", "0", "--generator", "noise",
                              "--out", str(out / "subjects")]),
        ("data log of subject 10", ["plot-recording", str(out / "subjects" / "subject10.npz"),
                                    "--out", str(out / "subject10.png")]),
        ("paper reproduction", ["reproduce", "--subjects", "10", "--seed", "0",
                                "--json", str(out / "reproduce.json"),
                                "--csv", str(out / "reproduce")]),
        *[(f"margins: {name}", ["margins", "--controller", name, "--object", "can",
                                "--mass-kg", "0.4", "--friction", "0.5",
                                "--json", str(out / "margins" / f"{name}.json"),
                                "--plots", str(out / "margins")])
          for name in DEFAULT_SPECS],
        ("loop measured on the hand", ["measure-loop", "--controller", "pid", "--object", "can",
                                       "--mass-kg", "0.2", "--friction", "1.0",
                                       "--at-force", "3,5,10,20",
                                       "--json", str(out / "measured_pid.json"),
                                       "--plots", str(out / "margins")]),
        ("closed-loop episode", ["episode", "--controller", "pid", "--estimator", "ss_kf",
                                 "--object", "can", "--mass-kg", "0.4", "--friction", "0.5",
                                 "--json", str(out / "episode.json")]),
        ("four references", ["compare-references", "--object", "can", "--mass-kg", "0.4",
                             "--friction", "0.5", "--subjects", "5",
                             "--json", str(out / "compare.json")]),
        ("mass x friction sweep", ["sweep", sweep_file, "--workers", str(args.workers),
                                   "--db", str(out / "results.sqlite")]),
        ("report", ["report", str(out / "results.sqlite"), "--out", str(out / "report"),
                    "--reproduction", str(out / "reproduce.json")]),
    ]
    start = time.perf_counter()
    for title, argv in steps:
        print(f"\n=== {title}: griploop {' '.join(argv)}", flush=True)
        code = main(argv)
        if code:
            print(f"griploop demo: step '{title}' failed with exit status {code}")
            return code
    print(f"\ndemo finished in {time.perf_counter() - start:.0f} s; report: "
          f"{out / 'report' / 'index.html'}")
    return 0
