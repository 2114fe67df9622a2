"""The prosthetic hand: MuJoCo model, objects, contact readings, GraspEnv, linearization.

:mod:`sim.hand.model` builds the MJCF hand (``assets/hand.xml``),
:mod:`sim.hand.objects` the graspable objects (a registry), :mod:`sim.hand.contact` reads
grip force, slip, drop and crush from MuJoCo's contacts,
:mod:`sim.hand.grasp_env` is the Gymnasium environment
(``griploop/GraspLift-v0``, registered by :mod:`sim.hand.registration`; its hand and
task are :mod:`sim.hand.env_spec` specs) and
:mod:`sim.hand.linearize` linearizes a held grasp for controller design.

May import: numpy, mujoco, gymnasium, :mod:`sim.references`, :mod:`sim.registry`.
Never :mod:`sim.user`.
"""

from sim.hand import registration as _registration  # noqa: E402, F401  (griploop/GraspLift-v0)
