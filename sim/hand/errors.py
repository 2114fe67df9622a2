"""Errors of the hand: an impossible hand or environment specification, a grasp that fails."""

from sim.errors import GriploopError


class HandSpecError(GriploopError, ValueError):
    """A hand, pad, motor or environment parameter outside its valid range."""


class GraspFailedError(GriploopError, RuntimeError):
    """The hand could not reach the requested grasp (no contact, no convergence)."""
