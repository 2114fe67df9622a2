"""Errors of live sessions: each one line, naming what was expected and what was found."""

from __future__ import annotations

from sim.errors import GriploopError


class LslUnavailableError(GriploopError, RuntimeError):
    """pylsl or the liblsl library inside it cannot be loaded on this machine."""


class StreamNotFoundError(GriploopError, LookupError):
    """No LSL stream with the requested name resolved in time."""


class StreamMismatchError(GriploopError, ValueError):
    """The stream's channel count or rate differs from the calibration recording's."""


class SessionError(GriploopError, RuntimeError):
    """A live session cannot run as asked (its settings or its stream)."""
