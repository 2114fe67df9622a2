"""The specification of a controller designed for an object.

:func:`~controllers.design.design_for_object` designs from a :class:`DesignSpec`.

A scenario, the CLI and :func:`~controllers.registry.default_spec` give a specification as
flat names (``{"phase_margin_deg": 60.0, "crossover_rad_s": 30.0, "horizon": 20}``: the
JSON of a results row and the key of the design cache); :meth:`DesignSpec.from_mapping`
reads them, the names of its fields into the fields and the rest into ``options``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from controllers.design_plant import DEFAULT_FORCE_GRID_N
from controllers.reflex import ReflexSpec


@dataclass(frozen=True)
class DesignSpec:
    """What a controller designed for one object must meet, and the layers it runs in.

    Attributes
    ----------
    phase_margin_deg : float
        Target phase margin (loop-shaping kinds: PID, lead-lag), degrees, met at
        every design force.
    crossover_rad_s, bandwidth_rad_s : float or None
        Target gain crossover or closed-loop bandwidth (loop-shaping kinds), rad/s;
        neither: :data:`controllers.design.DEFAULT_CROSSOVER_RAD_S`.
    safety_factor : float
        Grip over the *sensed* slip threshold for the MPC's lower bound
        (:class:`controllers.bounds.SensedSlipBound`).
    slip_reflex : ReflexSpec, mapping or None
        Enables the reflex (:class:`controllers.reflex.SlipReflex`) with these
        settings (a mapping: :class:`~controllers.reflex.ReflexSpec`'s fields by
        name); ``None`` or empty: no reflex.
    closing_command : float
        Normalized motor command while closing onto the object.
    scheduled : bool
        Schedule designs over the grid (default) or make one fixed design at
        ``operating_force_n``.
    operating_force_n : float or None
        The fixed design's force, N; default
        :func:`controllers.design_plant.default_operating_force_n`.
    force_max_n : float or None
        The user's force limit (a fragile setting), N: the MPC's upper bound and
        the reflex's ceiling. ``None``: no limit.
    forces_n : tuple of float
        The design grid, N.
    options : mapping
        The kind's own options (its registered ``options``, e.g. ``horizon`` and
        ``solver`` of the MPC, ``lag_ratio`` of the lead-lag; defaults: the kind's
        registered ones); options of other kinds are ignored.
    """

    phase_margin_deg: float = 60.0
    crossover_rad_s: float | None = None
    bandwidth_rad_s: float | None = None
    safety_factor: float = 1.5
    slip_reflex: ReflexSpec | Mapping[str, float] | None = None
    closing_command: float = 0.2
    scheduled: bool = True
    operating_force_n: float | None = None
    force_max_n: float | None = None
    forces_n: tuple[float, ...] = DEFAULT_FORCE_GRID_N
    options: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_mapping(cls, spec: Mapping[str, Any] | None) -> DesignSpec:
        """A specification from flat names: its fields by name, every other name an option.

        Parameters
        ----------
        spec : mapping or None
            E.g. a scenario's controller specification or
            :func:`~controllers.registry.default_spec`; ``None``: the defaults.
        """
        names = {f.name for f in dataclasses.fields(cls)} - {"options"}
        given = dict(spec or {})
        options = {k: v for k, v in given.items() if k not in names}
        return cls(**{k: v for k, v in given.items() if k in names}, options=options)

    def reflex_spec(self) -> ReflexSpec | None:
        """The reflex's settings, or ``None`` without a reflex."""
        if not self.slip_reflex:
            return None
        if isinstance(self.slip_reflex, ReflexSpec):
            return self.slip_reflex
        return ReflexSpec(**dict(self.slip_reflex))
