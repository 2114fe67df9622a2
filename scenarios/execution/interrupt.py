"""Stop signals as exceptions: Ctrl-C (SIGINT) and SIGTERM end a command cleanly.

:class:`Interrupted` is a :class:`KeyboardInterrupt` that remembers its signal,
so ``finally`` blocks and context managers run (a sweep releases its claims and
stops its worker processes) and the CLI exits with ``128 + signum`` (130 for
SIGINT, 143 for SIGTERM). Kept free of heavy imports: the CLI imports it first.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; ``signum`` says which (exit status ``128 + signum``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)


class StopRequest:
    """Set when a stop signal arrived while :func:`raise_on_stop` was active."""

    def __init__(self) -> None:
        self.signum: int | None = None

    def __bool__(self) -> bool:
        return self.signum is not None


@contextmanager
def raise_on_stop() -> Iterator[StopRequest]:
    """Turn SIGINT and SIGTERM into :class:`Interrupted` inside the block.

    Yields a :class:`StopRequest` that stays true once a signal arrived (code that
    catches exceptions broadly can check it). Outside the main thread, where
    handlers cannot be installed, the block runs with the handlers unchanged.
    """
    request = StopRequest()

    def handler(signum: int, frame: object) -> None:
        request.signum = signum
        raise Interrupted(signum)

    if threading.current_thread() is not threading.main_thread():
        yield request
        return
    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield request
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


def exit_status(exc: BaseException) -> int:
    """``128 + signum`` of an interrupt (130 for a plain ``KeyboardInterrupt``)."""
    return 128 + int(getattr(exc, "signum", signal.SIGINT))
