"""A real person in the loop: live sEMG over Lab Streaming Layer drives the simulated hand.

- :mod:`scenarios.live.lsl`: loading liblsl (one line with the fix when it cannot be
  loaded), resolving streams by identity (name, host, source_id; several matches and
  remote streams refused), watching that a session's source keeps its name, and the
  session's outlets;
- :mod:`scenarios.live.player`: a recording played as the armband's outlets (``griploop
  stream``: sEMG, force, orientation) with the faults a session must survive;
- :mod:`scenarios.live.arm`: the person's arm moving the wrist, from the forearm's pitch
  on the armband's IMU stream or from a key;
- :mod:`scenarios.live.calibration_fit`: an estimator fitted on a calibration recording,
  and an open/close decoder on its open contractions (refused in one line without any);
- :mod:`scenarios.live.recorded`: a virtual subject's grasp recording, and a recording
  replayed in a trial, its wrist following the recorded forearm (the offline
  counterpart of a live session), scored with the reference of its feature windows
  (:mod:`scenarios.live.reference_windows`);
- :mod:`scenarios.live.session`: the person of a live trial (the one trial loop,
  :mod:`scenarios.runners.trial_loop`), paced by the incoming samples, with
  its timing report (:mod:`scenarios.live.timing`), gap handling and bad-sample
  accounting; :mod:`scenarios.live.inlets` feeds it from LSL inlets, and its outputs
  and clock are :mod:`scenarios.live.hooks`;
- :mod:`scenarios.live.calibrate`: the paper's calibration session recorded from a live
  person with terminal cues (and, with ``--open``, open contractions after it);
- :mod:`scenarios.live.display`: the MuJoCo viewer when a display exists, else a GIF
  rendered after the session from the states it stored.

Nothing here imports :mod:`pylsl` at import time: :func:`scenarios.live.lsl.pylsl_module`
loads it when a command needs it.
"""
