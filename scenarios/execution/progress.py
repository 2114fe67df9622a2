"""The progress bar of a sweep."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Progress bar of a sweep (:mod:`tqdm`): done, failed, rate and ETA.

    On a terminal tqdm redraws the line in place at most every
    ``min_interval_s``; otherwise (a log file, CI) tqdm's line is printed
    whole every tenth of the sweep or every ``log_interval_s``, whichever comes
    first. ``total`` may change while the sweep runs (scenarios found stored or
    run by another driver are taken off).

    Parameters
    ----------
    total : int
        Scenarios to run (skipped ones excluded).
    label : str
        Prefix of the line (the sweep name).
    stream : text stream, optional
        Where to write; default ``sys.stderr``.
    """

    FORMAT = ("{desc} {percentage:3.0f}%|{bar:24}| {n_fmt}/{total_fmt} done{postfix} "
              "[{elapsed}<{remaining}, {rate_fmt}]")

    def __init__(
        self,
        total: int,
        label: str = "sweep",
        stream: TextIO | None = None,
        *,
        min_interval_s: float = 0.1,
        log_interval_s: float = 10.0,
    ) -> None:
        from tqdm import tqdm

        class _Bar(tqdm):  # no monitor thread: sandbox children are forked from this process
            monitor_interval = 0

        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.log_interval_s = log_interval_s
        self.failed = 0
        self._bar = _Bar(total=total, desc=label, file=self.stream, bar_format=self.FORMAT,
                         unit="scenario", mininterval=min_interval_s, ascii=not self.tty,
                         dynamic_ncols=self.tty, disable=False, leave=True,
                         postfix="0 failed", delay=0 if self.tty else float("inf"))
        self._last = time.perf_counter()
        self._last_done = 0

    @property
    def total(self) -> int:
        """Scenarios to run."""
        return int(self._bar.total or 0)

    @total.setter
    def total(self, value: int) -> None:
        self._bar.total = max(0, int(value))

    @property
    def done(self) -> int:
        """Scenarios finished so far."""
        return int(self._bar.n)

    def update(self, status: str) -> None:
        """Count one finished scenario and redraw if due."""
        self.failed += status == "failed"
        self._bar.set_postfix_str(f"{self.failed} failed", refresh=False)
        self._bar.update(1)
        if self.tty:
            return
        now = time.perf_counter()
        step = max(1, self.total // 10)
        if (self.done - self._last_done >= step or now - self._last >= self.log_interval_s
                or self.done >= self.total):
            self._last, self._last_done = now, self.done
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def line(self) -> str:
        """The current progress line (tqdm's meter)."""
        return str(self._bar)

    def close(self) -> None:
        """Finish the line."""
        self._bar.close()
