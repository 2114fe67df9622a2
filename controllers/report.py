"""The design report every design function attaches to its controller."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.analysis import LoopMargins
from controllers.errors import SpecificationError
from controllers.plant import PlantReport


@dataclass(frozen=True)
class DesignReport:
    """Specification, resulting parameters and the achieved loop figures.

    Attributes
    ----------
    controller : str
        Registered controller name (``"pid"``, ``"lead_lag"``, ``"mpc"``).
    spec : dict
        The specification as given (e.g. ``phase_margin_deg``, ``crossover_rad_s``).
    parameters : dict
        Designed parameters (gains, corner frequencies, weights), with units in the keys.
    plant : PlantReport
        The plant check made before design.
    margins : LoopMargins
        Analysis of the designed loop ``C P z**-d``.
    notes : list of str
        Design decisions worth knowing (fixed ratios, limits close to binding).

    Raises
    ------
    SpecificationError
        If the designed loop is closed-loop unstable: a specification met at
        the crossover does not guarantee stability (e.g. a lead's high-frequency
        gain can lift the loop above 1 where its phase crosses -180 deg), so no
        report, and hence no design, exists for an unstable loop.
    """

    controller: str
    spec: dict[str, Any]
    parameters: dict[str, float]
    plant: PlantReport
    margins: LoopMargins
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        m = self.margins
        if m.stable:
            return
        spec = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                         for k, v in self.spec.items() if isinstance(v, (int, float, str)))
        worst = (f"gain margin {min(m.gain_margins_db):.1f} dB at "
                 f"{m.phase_crossover_rad_s[int(np.argmin(m.gain_margins_db))]:.4g} rad/s; "
                 if len(m.gain_margins_db) else "")
        raise SpecificationError(
            f"{self.controller} design ({spec}) gives an unstable closed loop ({worst}largest "
            f"closed-loop pole |z| = {np.max(np.abs(m.closed_loop_poles)):.3f}); lower the "
            "crossover or raise the phase margin"
        )

    def to_text(self) -> str:
        """A short human-readable report."""
        m = self.margins
        lines = [f"{self.controller} design"]
        lines += [f"  spec  {k} = {v}" for k, v in self.spec.items()]
        lines += [f"  param {k} = {v:.6g}" for k, v in self.parameters.items()]
        lines.append(
            f"  achieved: PM {m.phase_margin_deg:.2f} deg at "
            f"{', '.join(f'{w:.4g}' for w in m.crossover_rad_s)} rad/s, "
            f"GM {m.gain_margin_db:.2f} dB, DM {m.delay_margin_s * 1e3:.1f} ms, "
            f"Ms {m.ms:.3f}, bandwidth {m.bandwidth_rad_s:.4g} rad/s, stable {m.stable}"
        )
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)
