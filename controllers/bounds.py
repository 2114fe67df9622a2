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


class SensedSlipBound:
    """The slip bound a prosthesis can know: from the load it carries and the slips it feels.

    The object's mass and friction are not known to a prosthesis. What it can
    sense is the weight it carries (the upward force on the object, from a
    wrist load cell: ``Observation.lift_force_n``) and whether the object
    slips. The bound is::

        min_grip_n = safety_factor * load_n / (2 * mu_hat)

    with ``load_n`` the carried (upward) load, while both sides touch and it
    exceeds ``min_load_n`` (``-inf`` otherwise: on the table nothing is
    carried, and the digits may even press the object down),
    with the friction estimate ``mu_hat`` starting at the
    conservative ``friction_prior`` and lowered whenever a slip is sensed at
    grip ``G`` under load ``L``: a two-sided grasp slips only if
    ``L > 2 mu G``, so ``mu_hat <- max(friction_floor, min(mu_hat, L / (2 G)))``.
    Slips count only once both sides have touched for ``arming_s`` (while the
    digits close, the pads slide over the object under load without the
    object slipping out). The bound rises at no more than ``rise_rate_n_s``
    (it falls at once), so a sudden load is met by a ramp, not a slam.

    Parameters
    ----------
    safety_factor : float
        Grip over the estimated slip threshold (>= 1).
    friction_prior : float
        Friction coefficient assumed before any slip is felt (0.6: skin-like
        pads on everyday objects; slips felt lower it).
    friction_floor : float
        Lowest friction estimate.
    min_load_n : float
        Load (N) below which nothing is carried and no bound applies.
    slip_speed_threshold_m_s : float
        Slip speed counted as a slip, m/s.
    arming_s : float
        Both sides must have touched this long before a slip counts, s.
    rise_rate_n_s : float
        Largest rise rate of the bound, N/s.
    dt_s : float
        Sample period of :meth:`update`, s.
    """

    def __init__(self, *, safety_factor: float = 1.5, friction_prior: float = 0.6,
                 friction_floor: float = 0.1, min_load_n: float = 0.05,
                 slip_speed_threshold_m_s: float = 0.02, arming_s: float = 0.2,
                 rise_rate_n_s: float = 40.0, dt_s: float = 0.01) -> None:
        if safety_factor < 1:
            raise SpecificationError(
                f"sensed slip bound: expected safety_factor >= 1, found {safety_factor}"
            )
        if not 0 < friction_floor <= friction_prior:
            raise SpecificationError(
                f"sensed slip bound: expected 0 < friction_floor <= friction_prior, found "
                f"{friction_floor}, {friction_prior}"
            )
        self.safety_factor = float(safety_factor)
        self.friction_prior = float(friction_prior)
        self.friction_floor = float(friction_floor)
        self.min_load_n = float(min_load_n)
        self.slip_speed_threshold_m_s = float(slip_speed_threshold_m_s)
        if min(arming_s, rise_rate_n_s, dt_s) <= 0:
            raise SpecificationError(
                "sensed slip bound: expected positive arming_s, rise_rate_n_s and dt_s, found "
                f"{arming_s}, {rise_rate_n_s}, {dt_s}"
            )
        self.arming_s = float(arming_s)
        self.rise_rate_n_s = float(rise_rate_n_s)
        self.dt_s = float(dt_s)
        self.reset()

    def reset(self) -> None:
        """Forget the friction estimate and the bound."""
        self.friction_ = self.friction_prior
        self.min_n = float("-inf")
        self._touching_s = 0.0

    def update(self, grip_force_n: float, load_force_n: float, slip_speed_m_s: float,
               both_sides: bool) -> float:
        """Update from one sensed sample (``load_force_n``: the carried, upward load, N).

        Returns the lower grip bound in N.
        """
        self._touching_s = self._touching_s + self.dt_s if both_sides else 0.0
        if not both_sides or load_force_n <= self.min_load_n:
            self.min_n = float("-inf")
            return self.min_n
        if (self._touching_s >= self.arming_s
                and slip_speed_m_s > self.slip_speed_threshold_m_s and grip_force_n > 0):
            self.friction_ = max(self.friction_floor,
                                 min(self.friction_, load_force_n / (2.0 * grip_force_n)))
        target = self.safety_factor * load_force_n / (2.0 * self.friction_)
        start = grip_force_n if self.min_n == float("-inf") else self.min_n
        self.min_n = min(target, start + self.rise_rate_n_s * self.dt_s)
        return self.min_n
