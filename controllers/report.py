"""The design report every design function attaches to its controller."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from controllers.analysis import LoopMargins
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
    """

    controller: str
    spec: dict[str, Any]
    parameters: dict[str, float]
    plant: PlantReport
    margins: LoopMargins
    notes: list[str] = field(default_factory=list)

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
