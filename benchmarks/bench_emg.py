"""Speed of the sEMG generators (x real time) and their calibration figures.

Run: ``.venv/bin/python benchmarks/bench_emg.py [--repeat 5] [--no-calibration]``

Measures ``generator.generate`` (drive -> muscle sEMG + force, 8 muscles, ADC
rate 200 Hz) on one paper-protocol session, and the whole
``VirtualSubject.paper_session`` (protocol, drive, generator, armband, FSR), and
prints best-of-``repeat`` wall times as x real time against the goals
(noise >= 10,000x; motor units >= 50x with a few hundred units per muscle).
Then, for ``make_population(10, seed=0)``'s paper sessions, prints the MYO
statistics and the paper's Fig. 7A single-feature R^2 next to their targets
(CALIBRATION.md).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

from estimation.features import extract_features  # noqa: E402
from sim.user.emg_stats import REAL_RANGES, STAT_KEYS, population_statistics  # noqa: E402
from sim.user.intent import paper_protocol  # noqa: E402
from sim.user.subjects import make_generator, make_population  # noqa: E402

GOALS = {"noise": 10_000.0, "motor_units": 50.0}


def best_time(fn, repeat: int) -> float:
    """Best wall time of ``repeat`` calls, seconds."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def calibration(generator: str) -> dict[str, tuple[float, float]]:
    """Mean and std over the default population of each calibration figure."""
    rows: dict[str, list[float]] = {}

    def add(key: str, value: float) -> None:
        rows.setdefault(key, []).append(float(value))

    for subject in make_population(10, seed=0):
        rec = subject.paper_session(generator=generator)
        emg = rec.emg.astype(float)
        rest = (rec.intent == 0.0) & (rec.intent_force_n < 1e-3)
        active = rec.intent > 0.15
        medium = np.abs(rec.intent - rec.metadata["profile"]["levels"][1]) < 1e-9
        add("rest std (LSB)", emg[rest].std())
        add("rest within +/-1 LSB", np.mean(np.abs(emg[rest]) <= 1))
        add("RMS ch6-8 at medium force (LSB)", np.sqrt(np.mean(emg[medium][:, 5:] ** 2)))
        f, p = signal.welch(emg[active], fs=rec.fs_hz, nperseg=256, axis=0)
        p = p.sum(axis=1)
        add("median frequency (Hz)", f[np.searchsorted(np.cumsum(p) / p.sum(), 0.5)])
        for lo, hi in ((0, 10), (20, 50), (50, 80), (80, 101)):
            add(f"power {lo}-{min(hi, 100)} Hz", p[(f >= lo) & (f < hi)].sum() / p.sum())
        c = np.corrcoef(emg[active].T)
        add("r adjacent channels", np.mean([c[i, (i + 1) % 8] for i in range(8)]))
        add("r two apart", np.mean([c[i, (i + 2) % 8] for i in range(8)]))
        add("saturated samples", np.mean((rec.emg == 127) | (rec.emg == -128)))
        add("SNR ch6-8 (dB)",
            10 * np.log10(np.mean(emg[active][:, 5:] ** 2) / np.mean(emg[rest][:, 5:] ** 2)))
        fs = extract_features(rec, channels=(6, 7, 8))
        half = fs.n_windows // 2
        for feature in ("mav", "rms", "wl"):
            x = np.column_stack([fs.columns(feature), np.ones(fs.n_windows)])
            theta, *_ = np.linalg.lstsq(x[:half], fs.y[:half], rcond=None)
            y = fs.y[half:]
            add(f"R2 {feature} ch6-8 (validation)",
                1 - np.sum((y - x[half:] @ theta) ** 2) / np.sum((y - y.mean()) ** 2))
    return {k: (float(np.mean(v)), float(np.std(v))) for k, v in rows.items()}


TARGETS = {
    "rest std (LSB)": "1.0-4.7 (real recordings)",
    "rest within +/-1 LSB": "real 0.55",
    "RMS ch6-8 at medium force (LSB)": "5-45",
    "median frequency (Hz)": "45-80 (real 64)",
    "power 0-10 Hz": "real 0.05",
    "power 20-50 Hz": "real 0.25",
    "power 50-80 Hz": "real 0.37",
    "power 80-100 Hz": "real 0.26",
    "r adjacent channels": "0.2-0.6 (real abs 0.31-0.71)",
    "r two apart": "real 0.20",
    "saturated samples": "< 0.015 (real 9e-5 to 9e-3)",
    "SNR ch6-8 (dB)": "8-32",
    "R2 mav ch6-8 (validation)": "0.70-0.88 (paper 0.796 +/- 0.061)",
    "R2 rms ch6-8 (validation)": "0.70-0.88",
    "R2 wl ch6-8 (validation)": "0.70-0.88",
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="repetitions (best is kept)")
    parser.add_argument("--no-calibration", action="store_true",
                        help="skip the calibration figures")
    args = parser.parse_args(argv)
    print("command:", " ".join([sys.executable.split("/")[-1], *sys.argv]))
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    subject = make_population(1, seed=0)[0]
    profile = paper_protocol(0)
    duration = profile.duration_s
    rng = np.random.default_rng(0)
    cases = [("noise", {}), ("motor_units", {}), ("motor_units", {"n_units": 300})]
    print(f"session {duration:.1f} s at 200 Hz, 8 channels")
    print(f"{'generator':<26}{'generate ms':>12}{'x real time':>13}{'session ms':>12}"
          f"{'x real time':>13}  goal")
    goals = []
    for name, settings in cases:
        gen = make_generator(name, **settings)
        drive = subject.drive(profile.intent, 200.0, rng, gen)
        t_gen = best_time(lambda g=gen, d=drive: g.generate(
            d, subject.muscles, subject.armband.front_end, fs_hz=200.0, rng=rng), args.repeat)
        t_rec = best_time(lambda g=gen: subject.record(profile, generator=g, rng=rng),
                          args.repeat)
        label = name + (f" ({settings['n_units']} units)" if settings else "")
        goal = GOALS[name]
        x_gen = duration / t_gen
        print(f"{label:<26}{1e3 * t_gen:>12.2f}{x_gen:>13.0f}{1e3 * t_rec:>12.2f}"
              f"{duration / t_rec:>13.0f}  >= {goal:,.0f}x {'ok' if x_gen >= goal else 'MISSED'}")
        goals.append((f"sEMG generator {label} >= {goal:,.0f}x real time", x_gen, goal,
                      f"{duration:.1f} s session generated in {1e3 * t_gen:.2f} ms"))
    for text, figure, goal, reference in goals:
        goal_line(text, figure, "x real time", limit=goal, better="higher", reference=reference)
    pop = make_population(10, seed=0)
    for name in ("noise", "motor_units"):
        t = best_time(lambda n=name: [s.paper_session(generator=n) for s in pop], 1)
        print(f"10 paper sessions with {name}: {t:.2f} s")
    if not args.no_calibration:
        tables = {name: calibration(name) for name in ("noise", "motor_units")}
        print("\ncalibration, make_population(10, seed=0), paper sessions: mean +/- std")
        print(f"{'figure':<34}{'noise':>18}{'motor_units':>18}  target")
        for key, target in TARGETS.items():
            cells = "".join(f"{tables[g][key][0]:>10.3g} +/- {tables[g][key][1]:<5.2g}"
                            for g in tables)
            print(f"{key:<34}{cells}  {target}")
        print(versus_real(pop))
    return 0


def versus_real(population: list) -> str:
    """The population table: median [min-max] over subjects, real recordings vs both generators."""

    def cell(median: float, lo: float, hi: float) -> str:
        return f"{median:.3g} [{lo:.3g}-{hi:.3g}]"

    stats = {g: population_statistics([s.paper_session(generator=g) for s in population])
             for g in ("noise", "motor_units")}
    lines = ["\nper-subject statistics vs real recordings (sim.user.emg_stats; median [min-max]):",
             f"{'statistic':<24}{'real':>28}{'noise':>28}{'motor_units':>28}"]
    for key in STAT_KEYS:
        row = f"{key:<24}{cell(*REAL_RANGES[key]):>28}"
        for g in stats:
            v = stats[g][key]
            row += f"{cell(v['median'], v['min'], v['max']):>28}"
        lines.append(row)
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
