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


class StreamSpecError(GriploopError, ValueError):
    """A stream named in a form griploop does not read (an empty host, a malformed source_id)."""


class AmbiguousStreamError(GriploopError, LookupError):
    """Several LSL streams match what was asked for: which one is the person's is unknown."""


class RemoteStreamError(GriploopError, PermissionError):
    """The stream comes from another host, which was not allowed (LSL has no authentication)."""


class ImuChannelError(GriploopError, ValueError):
    """An IMU stream without a channel griploop can read the forearm's pitch from."""


class ArmPosesError(GriploopError, ValueError):
    """Arm poses that cannot map the forearm's pitch to the wrist's height."""
