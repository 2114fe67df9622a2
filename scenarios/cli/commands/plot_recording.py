"""``griploop plot-recording``: force above the sEMG channels, like the paper's data log."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.recording_options import add_recording_options, load_with_options
from sim.recording import Recording


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``plot-recording`` subcommand."""
    parser = subparsers.add_parser(
        "plot-recording",
        help="plot a recording: force above the stacked sEMG channels",
        description="Draw the measured force (and the simulated true force, if present) above "
        "every sEMG channel, stacked on a shared time axis, with the start/end cues of the "
        "protocol when the recording's metadata has them. Writes a PNG.",
    )
    parser.add_argument("file", metavar="FILE", help="recording (.npz or .csv)")
    add_recording_options(parser)
    parser.add_argument("--out", required=True, metavar="PNG", help="image file to write")
    parser.add_argument(
        "--dpi", type=int, default=120, help="resolution in dots per inch (default: 120)"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    rec = load_with_options(args.file, args)
    out = plot_recording(rec, args.out, dpi=args.dpi)
    print(out)
    return 0


def plot_recording(rec: Recording, path: str | Path, *, dpi: int = 120) -> Path:
    """Save the data-log figure of ``rec`` to ``path`` (PNG, Agg backend); returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    t = rec.t_s
    n = rec.n_channels
    fig, axes = plt.subplots(
        n + 1, 1, sharex=True, figsize=(9.0, 1.0 + 0.8 * (n + 1)),
        gridspec_kw={"height_ratios": [2.5] + [1.0] * n},
    )
    top = axes[0]
    if rec.force_n is not None:
        top.plot(t, rec.force_n, color="k", lw=1.0, label="FSR force")
    if rec.intent_force_n is not None:
        top.plot(t, rec.intent_force_n, color="tab:orange", lw=0.8, ls="--", label="true force")
    if rec.force_n is None and rec.intent_force_n is None:
        top.text(0.5, 0.5, "no force in this recording", ha="center", va="center",
                 transform=top.transAxes)
    else:
        top.legend(loc="upper left", fontsize=7, frameon=False)
    top.set_ylabel("force (N)")
    unit = "LSB" if rec.emg_unit == "int8" else rec.emg_unit
    for ax, name, col in zip(axes[1:], rec.channel_names, rec.emg.T, strict=True):
        ax.plot(t, col, lw=0.4, color="tab:blue")
        ax.set_ylabel(name, rotation=0, ha="right", va="center", fontsize=8)
        ax.tick_params(labelsize=7)
        if rec.emg_unit == "int8":
            ax.set_ylim(-128, 127)
    axes[-1].set_xlabel("time (s)")
    axes[1].set_title(f"sEMG ({unit})", fontsize=8, loc="left")
    for kind, t_cue in rec.metadata.get("cues", []):
        for ax in axes:
            ax.axvline(float(t_cue), color="tab:green" if kind == "start" else "tab:red",
                       lw=0.7, ls=":")
    subject = rec.metadata.get("subject_id")
    title = Path(rec.source).name if subject is None else f"subject {subject}"
    top.set_title(title + (f" ({rec.metadata['generator']})" if "generator" in rec.metadata
                           else ""), fontsize=9)
    fig.tight_layout(h_pad=0.2)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path
