"""What the prosthesis does with the force estimate: controllers and loop analysis.

Every controller has ``reset()``, ``act(observation) -> command`` (normalized
motor command in -1..1) and ``loop(plant) -> control.LTI`` (the open loop
``C P z**-d`` with sample-and-hold and computation delay), and is designed
from a specification (phase margin, crossover) with a ``report_``.
"""

from controllers.analysis import LoopMargins, loop_margins, sweep_margins
from controllers.approach import ContactGate
from controllers.base import Observation, as_observation
from controllers.bounds import ForceBounds, force_bounds, slip_threshold_n
from controllers.errors import (
    IdentificationError,
    PlantError,
    SpecificationError,
    UnknownControllerError,
)
from controllers.figures import save_loop_figures
from controllers.identify import IdentifiedPlant, identify_low_order
from controllers.lead_lag import LinearController, design_lead_lag
from controllers.mpc import MPC, design_mpc
from controllers.pid import PID, design_pid
from controllers.plant import PlantReport, check_plant, loop_plant
from controllers.reflex import SlipReflex
from controllers.registry import CONTROLLER_NAMES, design_controller
from controllers.report import DesignReport

__all__ = [
    "CONTROLLER_NAMES",
    "ContactGate",
    "DesignReport",
    "ForceBounds",
    "IdentificationError",
    "IdentifiedPlant",
    "LinearController",
    "LoopMargins",
    "MPC",
    "Observation",
    "PID",
    "PlantError",
    "PlantReport",
    "SlipReflex",
    "SpecificationError",
    "UnknownControllerError",
    "as_observation",
    "check_plant",
    "design_controller",
    "design_lead_lag",
    "design_mpc",
    "design_pid",
    "force_bounds",
    "identify_low_order",
    "loop_margins",
    "loop_plant",
    "save_loop_figures",
    "slip_threshold_n",
    "sweep_margins",
]
