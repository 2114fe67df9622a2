"""What a :class:`~sim.hand.grasp_env.GraspEnv` is made of: the simulated hand and the task.

:class:`HandSpec`
    The prosthesis as simulated: transmission, motor, fingertip pads and the
    physics timestep (what :func:`sim.hand.model.build_model` compiles).
:class:`GraspTask`
    The episode as a reinforcement-learning task: its duration, its reward
    (:class:`RewardWeights`), when it ends, what counts as slip and drop, and how
    the object is placed at reset.

Both are frozen and default to the environment's defaults, so
``GraspEnv("can", 15.0, task=GraspTask(episode_s=2.5))`` changes only the duration.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sim.hand.drive import DriveSpec
from sim.hand.model import MotorSpec, PadSpec

__all__ = ["GraspTask", "HandSpec", "RewardWeights"]


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms (all terms are <= 0).

    ``tracking = -tracking * |reference - grip| / force_scale_n``;
    ``slip = -slip * slip_speed / 0.01 m/s`` while grasped;
    ``drop = -drop`` and ``crush = -crush`` on the step where they happen.
    """

    tracking: float = 1.0
    force_scale_n: float = 10.0
    slip: float = 0.1
    drop: float = 100.0
    crush: float = 100.0


@dataclass(frozen=True)
class HandSpec:
    """The simulated prosthetic hand of an environment.

    Attributes
    ----------
    drive : str or DriveSpec
        The transmission (:mod:`sim.hand.drive`): ``"backdrivable"`` (default) or
        ``"self_locking"``, whose digits move only under motor torque and stay where
        they are without it.
    motor : MotorSpec
        Motor and gearbox parameters of the backdrivable hand (a self-locking drive
        sizes the motor for the same rated grip and speed,
        :func:`sim.hand.drive.motor_for`).
    pads : PadSpec
        Compliant fingertip pads.
    physics_dt_s : float
        MuJoCo timestep, s (0.001-0.002); the control period is a whole multiple of it.
    """

    drive: str | DriveSpec = "backdrivable"
    motor: MotorSpec = field(default_factory=MotorSpec)
    pads: PadSpec = field(default_factory=PadSpec)
    physics_dt_s: float = 0.002


@dataclass(frozen=True)
class GraspTask:
    """The episode of an environment: duration, reward, ending and reset.

    Attributes
    ----------
    episode_s : float
        Episode duration, s; ``truncated`` is set when it is reached.
    reward_weights : RewardWeights
        Reward composition.
    terminate_on_drop : bool
        End the episode (``terminated``) when the object is dropped. A user who
        lifts by themselves and tries again after the object stayed behind needs
        the episode to go on; the crush always ends it.
    slip_threshold_m_s : float
        Slip speed above which the grasp slips, m/s
        (:class:`sim.hand.contact.OutcomeTracker`).
    drop_distance_m : float
        Displacement of the object from the palm that counts as a drop, m
        (:class:`sim.hand.contact.OutcomeTracker`).
    position_jitter_m : float
        Half-width of a uniform random offset of the object in x and y at reset,
        m (0..0.01; 0 = none), drawn from the environment's ``np_random``.
    preshape_aperture_m : float or None
        The digits start pre-shaped to the object (the intact hand, :mod:`sim.hand.human`):
        open by this much beyond the object's width, both sides together, m (0..0.05), and
        they open no wider during the episode. ``None`` (default): the digits start
        straight and open to the joints' range. Draws nothing at random.
    """

    episode_s: float = 4.0
    reward_weights: RewardWeights = field(default_factory=RewardWeights)
    terminate_on_drop: bool = True
    slip_threshold_m_s: float = 0.005
    drop_distance_m: float = 0.03
    position_jitter_m: float = 0.0
    preshape_aperture_m: float | None = None
