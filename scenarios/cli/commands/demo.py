"""``griploop demo``: the main job on embedded defaults, end to end.

Runs the same commands a user would: virtual subjects and a plot of one
recording, the paper reproduction, the margin tables of the three controller
families over grip force, the loop measured on the simulated hand by sine
injection, one closed-loop episode, the four-reference comparison, a small
mass x friction sweep, and the HTML report of it all.

The reproduction needs nothing the other steps make and only the report reads
it, so it runs in a ``griploop reproduce`` process of its own (its subjects on
``--workers`` processes) beside the steps after it; its output is printed, in
full, when the report step waits for it. Every step's time is printed at the end.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
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
                   help="worker processes of the reproduction and the sweep (default 2)")
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
                                "--workers", str(args.workers),
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
    took: list[tuple[str, float]] = []
    beside: Background | None = None
    try:
        for title, argv in steps:
            if title == "paper reproduction":
                beside = Background(title, argv)
                print(f"\n=== {title}: griploop {' '.join(argv)} (in its own process, beside "
                      "the next steps)", flush=True)
                continue
            if title == "report" and beside is not None:
                code = beside.wait()
                took.append((f"{beside.title} (beside)", beside.seconds))
                if code:
                    print(f"griploop demo: step '{beside.title}' failed with exit status {code}")
                    return code
            print(f"\n=== {title}: griploop {' '.join(argv)}", flush=True)
            t0 = time.perf_counter()
            code = main(argv)
            took.append((title, time.perf_counter() - t0))
            if code:
                print(f"griploop demo: step '{title}' failed with exit status {code}")
                return code
    finally:
        if beside is not None:
            beside.stop()
    print("\n=== time per step")
    for title, seconds in took:
        print(f"  {title:<34} {seconds:6.1f} s")
    print(f"\ndemo finished in {time.perf_counter() - start:.0f} s; report: "
          f"{out / 'report' / 'index.html'}")
    return 0


class Background:
    """A ``griploop`` command in a child process, its output kept until :meth:`wait`."""

    def __init__(self, title: str, argv: list[str]) -> None:
        self.title = title
        self.seconds = 0.0
        self._log = tempfile.TemporaryFile(mode="w+")
        self._start = time.perf_counter()
        self._proc = subprocess.Popen([sys.executable, "-m", "scenarios.cli", *argv],
                                      stdout=self._log, stderr=subprocess.STDOUT, text=True)

    def wait(self) -> int:
        """Wait for the command, print its output; its exit status."""
        code = self._proc.wait()
        self.seconds = time.perf_counter() - self._start
        print(f"\n=== {self.title} (ran beside the steps above, {self.seconds:.1f} s):",
              flush=True)
        self._log.seek(0)
        sys.stdout.write(self._log.read())
        sys.stdout.flush()
        return code

    def stop(self) -> None:
        """End the command if it still runs (an earlier step failed or was interrupted)."""
        if self._proc.poll() is None:
            self._proc.terminate()
            self._proc.wait()
        self._log.close()
