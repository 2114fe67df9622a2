"""The feature window in C: MAV, RMS and WL over an int8 ring, as :mod:`estimation.features`.

The C extractor keeps, per selected channel, the last ``win`` samples in a ring and
three running integer sums (``|x|``, ``x^2`` and ``|x(i) - x(i-1)|`` over the window's
consecutive pairs), updated at every sample by adding what enters and removing what
leaves. The sums are exact in int32 (a window of 8-bit samples sums to at most
``win * 255^2``), so at the end of each window the features are exactly the integer
sums :func:`estimation.features.emg_features` computes, divided (MAV, RMS) in the
real type: the C values are the Python values rounded to float32 (at most one unit
in the last place apart, from the division and the square root).

Window ``j`` covers samples ``[j*step, j*step + win)``: the first features come with
sample ``win - 1`` (counting from 0), the next every ``step`` samples.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from dataclasses import dataclass

from estimation.features import FEATURES, FeatureError, extract_features, window_samples
from sim.c_source import CModel, ExportError, model_digest, render


def paper_window_ms() -> tuple[float, float]:
    """The window and increment (ms) features are extracted with unless told otherwise.

    Read from :func:`estimation.features.extract_features`' defaults (the paper's
    400 ms every 125 ms), the settings every calibration here uses.
    """
    params = inspect.signature(extract_features).parameters
    return float(params["window_ms"].default), float(params["step_ms"].default)


@dataclass(frozen=True)
class FeatureWindow:
    """What the C feature extractor computes, and from which armband channels.

    Attributes
    ----------
    fs_hz : float
        sEMG sampling rate, Hz.
    n_armband_channels : int
        Channels in one frame the sensor callback delivers.
    channel_index : tuple of int
        Zero-based columns of the frame the features are computed on, in output order.
    window_ms, step_ms : float
        Window length and increment, ms.
    features : tuple of str
        Feature order within a channel (a subset of ``("mav", "rms", "wl")``).
    """

    fs_hz: float
    n_armband_channels: int
    channel_index: tuple[int, ...]
    window_ms: float
    step_ms: float
    features: tuple[str, ...] = FEATURES

    @property
    def samples(self) -> tuple[int, int]:
        """Window length and increment in samples (:func:`estimation.features.window_samples`)."""
        return window_samples(self.fs_hz, self.window_ms, self.step_ms)

    @property
    def n_features(self) -> int:
        """Features per update: channels times features per channel."""
        return len(self.channel_index) * len(self.features)

    def check(self) -> None:
        """Refuse settings the C extractor cannot run exactly.

        Raises
        ------
        ExportError
            Bad channel index, unknown feature, or a window whose int32 sums could overflow.
        """
        bad = [i for i in self.channel_index if not 0 <= i < self.n_armband_channels]
        if bad or not self.channel_index or len(set(self.channel_index)) != len(
                self.channel_index):
            raise ExportError(f"feature window: expected distinct channel indices in "
                              f"0..{self.n_armband_channels - 1}, found {list(self.channel_index)}")
        unknown = [f for f in self.features if f not in FEATURES]
        if unknown or not self.features:
            raise ExportError(f"feature window: expected features among {FEATURES}, found "
                              f"{list(self.features)}")
        try:
            win, _ = self.samples
        except FeatureError as exc:
            raise ExportError(f"feature window: {exc}") from None
        if win * 255 ** 2 >= 2 ** 31:
            raise ExportError(f"feature window: {win} samples could overflow the int32 sums; "
                              f"expected fewer than {2 ** 31 // 255 ** 2}")


def export_features(window: FeatureWindow) -> CModel:
    """``griploop_features.h`` and ``.c`` for ``window``.

    Raises
    ------
    ExportError
        See :meth:`FeatureWindow.check`.
    """
    window.check()
    win, step = window.samples
    constants = {"fs_hz": window.fs_hz, "armband": window.n_armband_channels,
                 "channels": list(window.channel_index), "win": win, "step": step,
                 "features": list(window.features)}
    digest = model_digest("features", {}, constants)
    ctx = dict(constants, digest=digest, window_ms=window.window_ms, step_ms=window.step_ms,
               n_channels=len(window.channel_index), n_features=window.n_features,
               has=lambda f: f in window.features)
    files = {name: render("estimation.export_c", name + ".j2", **ctx)
             for name in ("griploop_features.h", "griploop_features.c")}
    summary = {"window_samples": win, "step_samples": step, "fs_hz": window.fs_hz,
               "window_ms": window.window_ms, "step_ms": window.step_ms,
               "channels": [i + 1 for i in window.channel_index],
               "n_features": window.n_features, "features": list(window.features)}
    return CModel("features", files, digest, summary)


def feature_window(fs_hz: float, n_armband_channels: int, channel_index: Sequence[int], *,
                   window_ms: float | None = None, step_ms: float | None = None,
                   features: Sequence[str] = FEATURES) -> FeatureWindow:
    """A :class:`FeatureWindow`, with the calibration's window and increment by default."""
    default_window, default_step = paper_window_ms()
    return FeatureWindow(float(fs_hz), int(n_armband_channels),
                         tuple(int(i) for i in channel_index),
                         default_window if window_ms is None else float(window_ms),
                         default_step if step_ms is None else float(step_ms), tuple(features))
