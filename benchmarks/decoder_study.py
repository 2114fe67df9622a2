"""The open/close decoders on each virtual subject, beside their squeeze co-contraction (issue 36).

Run: ``.venv/bin/python benchmarks/decoder_study.py [--subjects 10] [--seed 0] [--json F]``

Each subject of the default population and of ``extensor_dominant`` is calibrated (the
paper's squeezes and a session of open contractions) and judged on a second pair of
sessions (:mod:`scenarios.runners.decoding`). Prints one row per subject and decoder:
the squeeze flexor/extensor RMS ratio, the squeeze windows decoded as open (unrequested
opens), the rest windows decoded as close (unrequested closes), and the open and squeeze
windows found; then each decoder's worst and median subject, and the decoder with the
fewer unrequested opens (the default, ``estimation.decoding.DEFAULT_DECODER``).
Issue 36's goal: at most 1 % unrequested opens for every subject.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


def _f(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def main(argv: list[str] | None = None) -> int:
    from estimation.decoding import DEFAULT_DECODER
    from scenarios.runners.decoding import DecoderStudy, preferred_decoder, run_study, summarize

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    rows = run_study(DecoderStudy(subjects=args.subjects, seed=args.seed))
    print("| population | subject | squeeze ratio | decoder | unrequested opens % | "
          "unrequested closes % | opens found % | squeezes found % |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['subject_id']} | {r['flexor_extensor_ratio']:.2f} | "
              f"{r['decoder']} | {_f(r['unrequested_opens_pct'])} | "
              f"{_f(r['unrequested_closes_pct'])} | {_f(r['opens_found_pct'])} | "
              f"{_f(r['closes_found_pct'])} |" + (f" {r['error']}" if r["error"] else ""))
    summary = summarize(rows)
    print()
    for name, s in summary.items():
        print(f"{name}: unrequested opens worst {_f(s['worst_unrequested_opens_pct'])} %, "
              f"median {_f(s['median_unrequested_opens_pct'])} %; unrequested closes worst "
              f"{_f(s['worst_unrequested_closes_pct'])} %, median "
              f"{_f(s['median_unrequested_closes_pct'])} %; opens found median "
              f"{_f(s['median_opens_found_pct'])} %, squeezes found median "
              f"{_f(s['median_closes_found_pct'])} %; failed {s['failed']} of {s['subjects']}")
    best = preferred_decoder(rows)
    worst = summary[best]["worst_unrequested_opens_pct"]
    print(f"fewer unrequested opens: {best} (the default: {DEFAULT_DECODER}); goal <= 1 % "
          f"for every subject: {'met' if worst is not None and worst <= 1.0 else 'NOT met'} "
          f"(worst {_f(worst)} %); {time.perf_counter() - t0:.0f} s")
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "summary": summary, "preferred": best},
                                        indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
