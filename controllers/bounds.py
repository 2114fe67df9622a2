"""Grip-force bounds of an object: above the slip threshold, below the fragility limit."""

from __future__ import annotations

from dataclasses import dataclass

from controllers.errors import SpecificationError

GRAVITY_M_S2 = 9.81  # MuJoCo's default gravity: the simulated world's g


def slip_threshold_n(mass_kg: float, friction: float, *, n_contacts: int = 2) -> float:
    """Coulomb threshold of a pinch: ``m g / (n_contacts mu)`` in N.

    For a two-sided pinch (two pads, ``n_contacts = 2``) this is the
    ``N* = m g / (2 mu)`` of CALIBRATION.md (0.98 N for 0.2 kg at mu = 1).

    Raises
    ------
    SpecificationError
        If mass is negative or friction not positive.
    """
    if mass_kg < 0:
        raise SpecificationError(f"slip threshold: expected mass_kg >= 0, found {mass_kg}")
    if friction <= 0:
        raise SpecificationError(f"slip threshold: expected friction > 0, found {friction}")
    return mass_kg * GRAVITY_M_S2 / (n_contacts * friction)


@dataclass(frozen=True)
class ForceBounds:
    """Bounds on grip force in N.

    Attributes
    ----------
    min_n : float
        Lowest force that holds the object (slip threshold times safety factor).
    max_n : float
        Highest force before the object is crushed (fragility limit).
    """

    min_n: float
    max_n: float


def force_bounds(
    mass_kg: float,
    friction: float,
    *,
    fragility_limit_n: float = float("inf"),
    safety_factor: float = 1.5,
    n_contacts: int = 2,
) -> ForceBounds:
    """Force bounds from object mass, friction estimate and fragility limit.

    Parameters
    ----------
    mass_kg : float
        Object mass estimate in kg.
    friction : float
        Pad-object friction coefficient estimate.
    fragility_limit_n : float
        Grip force at which the object breaks, N (``inf`` for a rigid object).
    safety_factor : float
        Multiplies the slip threshold (>= 1; grip/load ratio margin).
    n_contacts : int
        Pads pressing on the object.

    Raises
    ------
    SpecificationError
        If the safety factor is below 1 or the lower bound exceeds the fragility limit.
    """
    if safety_factor < 1:
        raise SpecificationError(
            f"force bounds: expected safety_factor >= 1, found {safety_factor}"
        )
    low = safety_factor * slip_threshold_n(mass_kg, friction, n_contacts=n_contacts)
    if low >= fragility_limit_n:
        raise SpecificationError(
            f"force bounds: holding needs at least {low:.3g} N (slip threshold x {safety_factor}) "
            f"but the object breaks at {fragility_limit_n:.3g} N"
        )
    return ForceBounds(min_n=low, max_n=float(fragility_limit_n))
