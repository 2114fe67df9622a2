"""Hostile sweep files: alias bombs, deep nesting, coercion, infinite ranges, huge designs.

Every failure is one ``FILE:LINE: field: expected ..., found ...`` line, in
bounded time and memory (measured in a subprocess with ``resource``).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from scenarios.schema import (
    ScenarioError,
    check_size,
    design_size,
    expand_sweep,
    iter_expanded,
    load_sweep,
    parse_sweep,
)


def laughs(levels: int) -> str:
    """A billion-laughs sweep file: ``levels`` levels of 9 aliases each."""
    lines = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, levels + 1):
        lines.append(f"l{i}: &l{i} [" + ",".join([f"*l{i - 1}"] * 9) + "]")
    return "description: bomb\n" + "\n".join(lines) + "\n"


_PEAK = textwrap.dedent(
    """
    import resource, sys, time
    resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))  # a bomb fails, not the host
    from scenarios.schema import ScenarioError, load_sweep
    t0 = time.perf_counter()
    try:
        load_sweep(sys.argv[1])
        print("loaded")
    except ScenarioError as exc:
        print("refused:", exc)
    print(time.perf_counter() - t0)
    # peak RSS of this program: VmHWM (ru_maxrss would include the forking parent's)
    try:
        with open("/proc/self/status") as fh:
            hwm = [line for line in fh if line.startswith("VmHWM:")][0]
        print(int(hwm.split()[1]) // 1024)
    except (OSError, IndexError):
        print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
    """
)


@pytest.mark.parametrize("levels", [6, 7, 9])
def test_alias_bomb_is_refused_in_bounded_memory_and_time(tmp_path: Path, levels: int) -> None:
    path = tmp_path / "bomb.yaml"
    path.write_text(laughs(levels))
    assert path.stat().st_size < 700
    proc = subprocess.run(
        [sys.executable, "-c", _PEAK, str(path)], capture_output=True, text=True, timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    message, seconds, peak = proc.stdout.strip().split("\n")
    assert message.startswith(f"refused: {path}:"), message
    assert "alias" in message and "expected at most" in message
    assert float(seconds) < 2.0
    assert int(peak) < 300, f"peak {peak} MB"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("base: &a\n  object: *a\n", "alias that contains itself"),
        ("a: &a [*a]\n", "alias that contains itself"),
        ("grid:\n  seed: " + "[" * 5000 + "]" * 5000 + "\n", "nesting of at most"),
        ("description:\n" + "".join("  " * i + f"k{i}:\n" for i in range(1, 60)),
         "nesting of at most"),
        ("seed: true\n", ":1: seed: expected a valid integer (found bool True)"),
        ("base:\n  object:\n    mass_kg: \"0.5\"\n",
         ":3: base.object.mass_kg: expected a valid number (found str '0.5')"),
        ("base:\n  seed: 1.0\n", ":2: base.seed: expected a valid integer"),
        ("base:\n  controller: {slip_reflex: {enabled: 1}}\n", "expected a valid boolean"),
        ("random:\n  n: 3\n  params:\n    object.friction: {dist: uniform, low: -.inf, "
         "high: .inf}\n", ":4: random.params.object.friction.low: expected a finite number"),
        ("random:\n  n: 3\n  params:\n    object.friction: {dist: uniform, low: -1e308, "
         "high: 1e308}\n", "finite span"),
        ("random:\n  n: 3\n  params:\n    subject.subject_id: {dist: integers, low: 1, "
         "high: 1e30}\n", "random.params.subject.subject_id.high"),
        ("grid:\n  object.friction: [.nan]\n",
         ":2: grid.object.friction[0]: object.friction: expected a finite"),
        ("base:\n  object: {mass_kg: .inf}\n", "base.object.mass_kg: expected a finite number"),
    ],
)
def test_hostile_files_give_one_line(tmp_path: Path, text: str, needle: str) -> None:
    path = tmp_path / "hostile.yaml"
    path.write_text(text)
    t0 = time.perf_counter()
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    message = str(info.value)
    assert time.perf_counter() - t0 < 2.0
    assert message.startswith(f"{path}:"), message
    assert needle in message, message
    assert "\n" not in message


def test_aliases_within_limits_still_work(tmp_path: Path) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text(
        "base:\n  object: &obj {name: cup, mass_kg: 0.2}\n"
        "grid:\n  object.friction: &f [0.5, 1.0]\n  subject.subject_id: [1, 2]\n"
    )
    spec = load_sweep(path)
    assert spec.base.object.mass_kg == 0.2 and len(expand_sweep(spec)) == 4


def test_design_is_counted_before_expanding() -> None:
    big = parse_sweep(
        {
            "random": {"n": 1_000_000, "params": {"object.friction": {
                "dist": "uniform", "low": 0.2, "high": 1.2}}},
            "replicates": 10_000,
        }
    )
    assert design_size(big) == 10**10
    t0 = time.perf_counter()
    with pytest.raises(ScenarioError, match="expected at most 100000 scenarios, found 10000000000"):
        expand_sweep(big)
    with pytest.raises(ScenarioError, match="found 10000000000"):
        iter_expanded(big)
    assert time.perf_counter() - t0 < 1.0
    grid = parse_sweep({"grid": {
        "object.friction": [0.2 + 0.1 * i for i in range(10)],
        "object.mass_kg": [0.1 + 0.1 * i for i in range(10)],
        "subject.subject_id": list(range(1, 11)),
        "subject.extra_noise_lsb": list(range(10)),
        "subject.population_seed": list(range(10)),
        "controller.phase_margin_deg": [30 + i for i in range(10)],
        "controller.safety_factor": [1 + 0.1 * i for i in range(10)],
    }})
    with pytest.raises(ScenarioError, match=r"found 10000000 \(10 x 10 x 10 x 10 x 10 x 10 x 10"):
        check_size(grid, 1000)
    assert check_size(grid, None) == 10**7
    first = next(iter_expanded(grid, max_scenarios=None))  # streams: no list of 10^7
    assert first.index == 0
