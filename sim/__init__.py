"""The simulated world: virtual users (muscles, electrodes, FSR) and the MuJoCo hand.

``sim`` imports none of the other griploop packages.
"""

from sim.recording import Recording, RecordingError, load_recording

__all__ = ["Recording", "RecordingError", "load_recording"]
