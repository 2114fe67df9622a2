"""Bode, Nyquist and pole-zero figures of a loop, with its margins marked.

Figures are drawn on :class:`matplotlib.figure.Figure` objects directly (no
pyplot state, works headless) and saved to PNG.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.analysis import LoopMargins, frequency_grid, minimal_tf
from controllers.plant import frequency_response

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _new_figure(**kwargs: Any) -> Figure:
    """A matplotlib Figure (matplotlib's figure module is imported when a figure is drawn)."""
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def bode_figure(margins: LoopMargins, title: str = "") -> Figure:
    """Magnitude (dB) and phase (deg) of ``L`` with every crossover and margin marked."""
    loop = margins.loop
    omega = frequency_grid(loop)
    resp = frequency_response(loop, omega)
    fig = _new_figure(figsize=(7, 6), layout="constrained")
    ax_mag, ax_ph = fig.subplots(2, 1, sharex=True)
    ax_mag.semilogx(omega, 20 * np.log10(np.abs(resp)), color="C0")
    ax_mag.axhline(0.0, color="0.5", lw=0.8, ls="--")
    ax_ph.semilogx(omega, np.rad2deg(np.unwrap(np.angle(resp))), color="C0")
    ax_ph.axhline(-180.0, color="0.5", lw=0.8, ls="--")
    phase_at = np.rad2deg(np.unwrap(np.angle(resp)))
    for w, pm in zip(margins.crossover_rad_s, margins.phase_margins_deg, strict=True):
        ax_mag.axvline(w, color="C2", lw=0.8)
        ph = np.interp(w, omega, phase_at)
        ax_ph.vlines(w, ph - pm, ph, color="C2", lw=2)
        ax_ph.annotate(f"PM {pm:.1f} deg\n@ {w:.3g} rad/s", (w, ph), fontsize=8)
    for w, gm in zip(margins.phase_crossover_rad_s, margins.gain_margins_db, strict=True):
        mag = -gm
        ax_ph.axvline(w, color="C3", lw=0.8)
        ax_mag.vlines(w, mag, 0.0, color="C3", lw=2)
        ax_mag.annotate(f"GM {gm:.1f} dB\n@ {w:.3g} rad/s", (w, mag), fontsize=8)
    if margins.dt is not None:
        for ax in (ax_mag, ax_ph):
            ax.axvline(np.pi / margins.dt, color="k", lw=0.8, ls=":")
    ax_mag.set_ylabel("|L| (dB)")
    ax_ph.set_ylabel("phase L (deg)")
    ax_ph.set_xlabel("frequency (rad/s)")
    ax_mag.set_title(title or "Open loop L = C P")
    for ax in (ax_mag, ax_ph):
        ax.grid(True, which="both", alpha=0.3)
    return fig


def nyquist_figure(margins: LoopMargins, title: str = "") -> Figure:
    """Nyquist curve of ``L`` with -1, the unit circle, the Ms circle and the margins."""
    loop = margins.loop
    omega = frequency_grid(loop)
    resp = frequency_response(loop, omega)
    fig = _new_figure(figsize=(6, 6), layout="constrained")
    ax = fig.subplots()
    ax.plot(resp.real, resp.imag, color="C0", label="L(jw), w > 0")
    ax.plot(resp.real, -resp.imag, color="C0", ls="--", alpha=0.5, label="w < 0")
    theta = np.linspace(0, 2 * np.pi, 256)
    ax.plot(np.cos(theta), np.sin(theta), color="0.6", lw=0.8, label="unit circle")
    radius = 1.0 / margins.ms
    ax.plot(-1 + radius * np.cos(theta), radius * np.sin(theta), color="C1", lw=0.8,
            label=f"1/Ms, Ms = {margins.ms:.2f}")
    ax.plot([-1], [0], "k+", ms=12)
    for w, pm in zip(margins.crossover_rad_s, margins.phase_margins_deg, strict=True):
        point = frequency_response(loop, np.array([w]))[0]
        ax.plot([0, point.real], [0, point.imag], color="C2", lw=1)
        ax.annotate(f"PM {pm:.1f} deg", (point.real, point.imag), fontsize=8)
    for w, gm in zip(margins.phase_crossover_rad_s, margins.gain_margins_db, strict=True):
        point = frequency_response(loop, np.array([w]))[0]
        ax.plot(point.real, 0.0, "o", color="C3", ms=4)
        ax.annotate(f"GM {gm:.1f} dB", (point.real, 0.0), fontsize=8)
    span = float(np.clip(1.1 * np.max(np.abs(resp)), 2.0, 5.0))
    ax.set_xlim(-span, span)
    ax.set_ylim(-span, span)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_xlabel("Re L")
    ax.set_ylabel("Im L")
    ax.set_title(title or "Nyquist")
    return fig


def pole_zero_figure(margins: LoopMargins, title: str = "") -> Figure:
    """Open-loop poles/zeros and closed-loop poles, with the unit circle for discrete loops."""
    loop = margins.loop
    fig = _new_figure(figsize=(6, 6), layout="constrained")
    ax = fig.subplots()
    tf = minimal_tf(loop)
    poles, zeros = tf.poles(), tf.zeros()
    ax.plot(poles.real, poles.imag, "x", color="C0", label="open-loop poles")
    ax.plot(zeros.real, zeros.imag, "o", mfc="none", color="C0", label="open-loop zeros")
    cl = margins.closed_loop_poles
    ax.plot(cl.real, cl.imag, "x", color="C3", ms=9, label="closed-loop poles")
    if margins.dt is not None:
        theta = np.linspace(0, 2 * np.pi, 256)
        ax.plot(np.cos(theta), np.sin(theta), color="0.6", lw=0.8)
        ax.set_aspect("equal")
    else:
        ax.axvline(0.0, color="0.6", lw=0.8)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_xlabel("Re")
    ax.set_ylabel("Im")
    ax.set_title(title or "Poles and zeros")
    return fig


def save_loop_figures(margins: LoopMargins, directory: str | Path, stem: str) -> list[Path]:
    """Write ``<stem>_bode.png``, ``<stem>_nyquist.png`` and ``<stem>_pz.png``.

    Returns
    -------
    list of Path
        The files written.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for suffix, make in (("bode", bode_figure), ("nyquist", nyquist_figure),
                         ("pz", pole_zero_figure)):
        path = directory / f"{stem}_{suffix}.png"
        make(margins, title=f"{stem}: {suffix}").savefig(path, dpi=110)
        written.append(path)
    return written


def margins_over_force_figure(analyses: dict[str, list], title: str = "") -> Figure:
    """Gain margin, phase margin and crossover against grip force, one line per controller.

    Parameters
    ----------
    analyses : dict
        ``{controller name: [OperatingAnalysis, ...]}``
        (:meth:`controllers.design.ControllerDesign.analyse`); failed points are
        left out of the lines and marked with an ``x`` on the force axis.
    title : str
        Figure title (the object).
    """
    fig = _new_figure(figsize=(7.5, 6.5), layout="constrained")
    ax_gm, ax_pm, ax_wc = fig.subplots(3, 1, sharex=True)
    for i, (name, points) in enumerate(analyses.items()):
        good = [a for a in points if a.ok]
        f = np.array([a.force_n for a in good])
        gm = np.array([a.margins.gain_margin_db for a in good])
        pm = np.array([a.margins.phase_margin_deg for a in good])
        wc = np.array([a.margins.crossover_rad_s[0] if a.margins.crossover_rad_s else np.nan
                       for a in good])
        color = f"C{i}"
        ax_gm.plot(f, np.where(np.isfinite(gm), gm, np.nan), "o-", ms=3, color=color, label=name)
        ax_pm.plot(f, np.where(np.isfinite(pm), pm, np.nan), "o-", ms=3, color=color)
        ax_wc.plot(f, wc, "o-", ms=3, color=color)
        failed = [a.force_n for a in points if not a.ok]
        if failed:
            ax_pm.plot(failed, np.zeros(len(failed)), "x", color=color, ms=8,
                       label=f"{name}: no model")
    ax_pm.axhline(45.0, color="0.5", lw=0.8, ls="--")
    ax_gm.axhline(6.0, color="0.5", lw=0.8, ls="--")
    ax_gm.set_ylabel("gain margin (dB)", fontsize=11)
    ax_pm.set_ylabel("phase margin (deg)", fontsize=11)
    ax_wc.set_ylabel("crossover (rad/s)", fontsize=11)
    ax_wc.set_xlabel("grip force (N)", fontsize=11)
    ax_gm.set_title(title or "Margins over grip force", fontsize=12)
    ax_gm.legend(fontsize=9, loc="best")
    for ax in (ax_gm, ax_pm, ax_wc):
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.tick_params(labelsize=9)
    return fig


def measured_bode_figure(margins: LoopMargins, frequencies_rad_s: np.ndarray,
                         measured_loop: np.ndarray, title: str = "") -> Figure:
    """The predicted Bode plot of ``L`` with loop gains measured on the hand overlaid."""
    fig = bode_figure(margins, title=title)
    ax_mag, ax_ph = fig.axes[:2]
    w = np.asarray(frequencies_rad_s, float)
    lm = np.asarray(measured_loop, complex)
    pred = frequency_response(margins.loop, w)
    # measured phases are placed on the predicted curve's branch (multiples of 360)
    ph_pred = np.interp(w, frequency_grid(margins.loop),
                        np.rad2deg(np.unwrap(np.angle(frequency_response(
                            margins.loop, frequency_grid(margins.loop))))))
    ph = np.angle(lm, deg=True)
    ph = ph + 360.0 * np.round((ph_pred - ph) / 360.0)
    ax_mag.plot(w, 20 * np.log10(np.abs(lm)), "ks", ms=5, mfc="none", label="measured on the hand")
    ax_ph.plot(w, ph, "ks", ms=5, mfc="none")
    ax_mag.plot(w, 20 * np.log10(np.abs(pred)), "C0.", ms=3)
    ax_mag.legend(fontsize=9)
    return fig
