"""The simulated world: virtual users (muscles, electrodes, FSR) and the MuJoCo hand.

``sim`` imports none of the other griploop packages.
"""

from sim import registration as _registration  # noqa: F401  (griploop/GraspLift-v0)
from sim.protocol import IntentProfile, grasp_lift_hold, paper_protocol, ramp_profile
from sim.recording import Recording, RecordingError, load_recording
from sim.subjects import GENERATORS, VirtualSubject, make_population

__all__ = ["Recording", "RecordingError", "load_recording"]
__all__ += ["GENERATORS", "IntentProfile", "VirtualSubject", "grasp_lift_hold", "make_population",
            "paper_protocol", "ramp_profile"]
