"""Register griploop's Gymnasium environments (imported by ``sim/__init__``).

``gymnasium.make("griploop/GraspLift-v0", object="can", reference=15.0)``
builds a :class:`sim.hand.grasp_env.GraspEnv`. The environment ends its episodes
itself (``episode_s``), so no ``max_episode_steps`` wrapper is added.
"""

from __future__ import annotations

import gymnasium

GRASP_LIFT_ID = "griploop/GraspLift-v0"

if GRASP_LIFT_ID not in gymnasium.registry:
    gymnasium.register(id=GRASP_LIFT_ID, entry_point="sim.hand.grasp_env:GraspEnv")
