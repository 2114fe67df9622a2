"""Errors raised by :mod:`controllers` where a plant, a specification or a name enters.

Each subclasses a built-in so the ``griploop`` CLI turns it into one line on
stderr (see :mod:`scenarios.cli.main`).
"""

from __future__ import annotations

from sim.errors import GriploopError


class PlantError(GriploopError, ValueError):
    """A plant cannot be used for design: unstable, non-minimal, not SISO or badly sampled."""


class SpecificationError(GriploopError, ValueError):
    """A design specification cannot be met; the message names the limit that was hit."""


class IdentificationError(GriploopError, ValueError):
    """Step-response data cannot identify a low-order model (shape, length or excitation)."""


class UnknownControllerError(GriploopError, LookupError):
    """A controller name is not registered; the message lists the valid names."""
