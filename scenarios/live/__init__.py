"""A real person in the loop: live sEMG over Lab Streaming Layer drives the simulated hand.

- :mod:`scenarios.live.lsl`: loading liblsl (one line with the fix when it cannot be
  loaded), resolving a stream by name, the session's outlets and the recording player
  behind ``griploop stream``;
- :mod:`scenarios.live.windowing`: MAV/RMS/WL windows updated one sample at a time,
  equal to :func:`estimation.features.extract_features` on the same samples (int8
  counts bit for bit);
- :mod:`scenarios.live.recorded`: an estimator fitted on a calibration recording, a
  virtual subject's grasp recording, and the offline episode driven by a given recording
  (the reference a live session is compared with);
- :mod:`scenarios.live.session`: the real-time loop, paced by the incoming samples, with
  its timing report, gap handling and bad-sample accounting;
- :mod:`scenarios.live.calibrate`: the paper's calibration session recorded from a live
  person with terminal cues;
- :mod:`scenarios.live.display`: the MuJoCo viewer when a display exists, else a GIF
  rendered after the session from the states it stored.

Nothing here imports :mod:`pylsl` at import time: :func:`scenarios.live.lsl.pylsl_module`
loads it when a command needs it.
"""
