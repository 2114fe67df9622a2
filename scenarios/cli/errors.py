"""Errors of the command line's own options."""

from sim.errors import GriploopError


class UsageError(GriploopError, ValueError):
    """A command-line option with an invalid value."""


class UnknownChoiceError(GriploopError, LookupError):
    """A command-line option naming something that is not registered."""
