"""Run every benchmark and summarize their goals in one table (``make bench``).

Each ``benchmarks/bench_*.py`` runs in its own Python process (so one
benchmark's imports, caches and threads never colour another's timings), in
name order; its output is echoed as it comes. Every line of the form printed
by :func:`_timing.goal_line`::

    GOAL | goal | figure | reference | met

is collected, and a summary table follows: one row per goal, with the
benchmark it came from. ``--markdown FILE`` also writes the table as Markdown
(the speed table, docs/results/speed.md). The exit status is 0 when every benchmark exited
0, and 1 otherwise; goals not met are reported, not failed on
(``--strict`` fails on them too), since timings depend on the machine.

Run::

    .venv/bin/python benchmarks/run_all.py [--only sweep,episode] [--markdown FILE] [--strict]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
PREFIX = "GOAL |"


@dataclass(frozen=True)
class Goal:
    """One ``GOAL`` line of a benchmark."""

    bench: str
    goal: str
    figure: str
    reference: str
    met: bool


def parse_goal(line: str, bench: str) -> Goal | None:
    """The goal in one output line, or None if it is not a ``GOAL |`` line."""
    line = line.strip()
    if not line.startswith(PREFIX):
        return None
    fields = [f.strip() for f in line[len(PREFIX):].split(" | ")]
    if len(fields) < 4:
        return None
    goal, figure, *reference, status = fields
    return Goal(bench, goal, figure, " | ".join(reference), status.lower() == "met")


def benchmarks(only: list[str] | None = None) -> list[Path]:
    """The ``bench_*.py`` scripts, in name order (``only``: names without ``bench_``)."""
    found = sorted(HERE.glob("bench_*.py"))
    if only:
        wanted = {name.removeprefix("bench_").removesuffix(".py") for name in only}
        found = [p for p in found if p.stem.removeprefix("bench_") in wanted]
    return found


def run_one(path: Path, timeout_s: float | None) -> tuple[int, list[Goal], float]:
    """Run one benchmark, echoing its output; exit status, goals and wall time."""
    env = dict(os.environ)
    root = str(HERE.parent)  # the tree being benchmarked, ahead of any installed copy
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("MPLBACKEND", "Agg")
    goals: list[Goal] = []
    t0 = time.perf_counter()
    with subprocess.Popen([sys.executable, str(path)], cwd=root, env=env, text=True,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, bufsize=1) as proc:
        assert proc.stdout is not None
        try:
            for line in proc.stdout:
                print(line, end="", flush=True)
                goal = parse_goal(line, path.stem)
                if goal is not None:
                    goals.append(goal)
                if timeout_s is not None and time.perf_counter() - t0 > timeout_s:
                    proc.kill()
                    print(f"{path.name}: stopped after {timeout_s:g} s", flush=True)
            code = proc.wait()
        except BaseException:
            proc.kill()
            raise
    return code, goals, time.perf_counter() - t0


def table(goals: list[Goal], failed: dict[str, int]) -> list[list[str]]:
    """Rows of the summary: benchmark, goal, figure, reference, met."""
    rows = [[g.bench, g.goal, g.figure, g.reference or "-", "met" if g.met else "NOT MET"]
            for g in goals]
    rows += [[bench, "(benchmark failed)", f"exit {code}", "-", "NOT MET"]
             for bench, code in failed.items()]
    return rows


HEADER = ["benchmark", "goal", "figure", "reference (same run)", "met"]


def format_text(rows: list[list[str]]) -> str:
    """The summary as an aligned plain-text table."""
    widths = [max(len(r[i]) for r in [HEADER, *rows]) for i in range(len(HEADER))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
             for row in [HEADER, ["-" * w for w in widths], *rows]]
    return "\n".join(lines)


def format_markdown(rows: list[list[str]]) -> str:
    """The summary as a Markdown table."""

    def cells(row: list[str]) -> str:
        return "| " + " | ".join(c.replace("|", "\\|") for c in row) + " |"

    return "\n".join([cells(HEADER), cells(["---"] * len(HEADER)), *map(cells, rows)]) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="comma-separated benchmark names "
                        "(e.g. sweep,episode); default all")
    parser.add_argument("--markdown", type=Path, default=None, metavar="FILE",
                        help="also write the summary table to FILE as Markdown")
    parser.add_argument("--strict", action="store_true",
                        help="exit 1 when a goal is not met (default: only when a benchmark "
                        "fails)")
    parser.add_argument("--timeout-s", type=float, default=None,
                        help="stop a benchmark that runs longer than this")
    args = parser.parse_args(argv)
    scripts = benchmarks([s for s in args.only.split(",") if s])
    if not scripts:
        parser.error(f"no benchmark matches --only {args.only!r}")
    goals: list[Goal] = []
    failed: dict[str, int] = {}
    for path in scripts:
        print(f"== {path.relative_to(HERE.parent)}", flush=True)
        code, found, wall = run_one(path, args.timeout_s)
        goals += found
        if code != 0:
            failed[path.stem] = code
        print(f"== {path.name}: exit {code}, {len(found)} goal(s), {wall:.1f} s\n", flush=True)
    rows = table(goals, failed)
    n_met = sum(g.met for g in goals)
    print(f"== summary: {n_met} of {len(goals)} goals met, "
          f"{len(scripts) - len(failed)} of {len(scripts)} benchmarks ran cleanly")
    print(format_text(rows))
    if args.markdown is not None:
        args.markdown.write_text(format_markdown(rows))
        print(f"markdown table written to {args.markdown}")
    if failed or (args.strict and n_met < len(goals)):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
